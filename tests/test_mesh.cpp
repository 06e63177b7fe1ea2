// The mesh reader (gmsh API): the paper's meshes have the sizes section 8 states, boundary parts
// are found by name, and bad meshes give clear errors.
#include <gtest/gtest.h>

#include "error.hpp"
#include "mesh.hpp"
#include "testing.hpp"

using namespace ltl;
using ltl::testing::source_path;
using ltl::testing::test_path;

TEST(Mesh, Fig3BarHasThePapersCounts) {
  // [LTL87 sec. 8] 168 triangles and 28 contact segments (P2: 399 nodes; the paper's Ruas
  // elements had 201).
  const Mesh m = load_mesh(source_path("experiments/fig3/bar.geo"));
  EXPECT_EQ(m.dim, 2);
  EXPECT_EQ(m.num_cells(), 168);
  EXPECT_EQ(m.nodes_per_cell(), 6);
  EXPECT_EQ(m.num_nodes(), 29 * 4 + 28 * 4 + 29 * 3 + 28 * 3);
  EXPECT_EQ(m.boundary("contact").facets.rows(), 28);
  EXPECT_EQ(m.boundary("top").facets.rows(), 28);
  EXPECT_EQ(m.boundary("right").facets.rows(), 3);
  EXPECT_EQ(m.boundary_nodes("right").size(), 7u);
  // Contact nodes lie on x2 = 0.
  for (int i : m.boundary_nodes("contact")) EXPECT_EQ(m.X(i, 1), 0.0);
}

TEST(Mesh, ParametersRefineTheGeometry) {
  const Mesh m = load_mesh(source_path("experiments/fig3/bar.geo"), {{"nx", 56}, {"H", 0.05}});
  EXPECT_EQ(m.num_cells(), 56 * 3 * 2);
  EXPECT_NEAR(m.X.col(1).maxCoeff(), 0.05, 1e-15);
}

TEST(Mesh, Fig6GutterHas270Hexahedra) {
  const Mesh m = load_mesh(source_path("experiments/fig6/gutter.geo"));
  EXPECT_EQ(m.dim, 3);
  EXPECT_EQ(m.num_cells(), 270);
  EXPECT_EQ(m.nodes_per_cell(), 8);
  EXPECT_EQ(m.boundary("outer").facets.rows(), 9 * 15);
  EXPECT_EQ(m.boundary("inner").facets.rows(), 9 * 15);
  EXPECT_EQ(m.boundary("clamped").facets.rows(), 2 * 9);
  // Outer face at radius 1.2 from the axis x1.
  for (int i : m.boundary_nodes("outer")) EXPECT_NEAR(std::hypot(m.X(i, 1), m.X(i, 2)), 1.2, 1e-12);
}

TEST(Mesh, Fig5HalfDiscIsCurvedP2) {
  const Mesh m = load_mesh(source_path("experiments/fig5/half_disc.geo"));
  EXPECT_EQ(m.num_cells(), 122);
  // Mid-edge nodes of the contact arc are on the circle (isoparametric P2).
  for (int i : m.boundary_nodes("contact")) EXPECT_NEAR(m.X.row(i).norm(), 1.0, 1e-12);
}

TEST(Mesh, MissingGroupNamesTheFileAndTheGroups) {
  const Mesh m = load_mesh(test_path("geometry/square.geo"));
  try {
    m.boundary("contcat", "contact.group");
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("square.geo"), std::string::npos) << w;
    EXPECT_NE(w.find("'contcat'"), std::string::npos) << w;
    EXPECT_NE(w.find("contact.group"), std::string::npos) << w;
    EXPECT_NE(w.find("'left'"), std::string::npos) << w;
  }
}

TEST(Mesh, BadFilesGiveClearErrors) {
  EXPECT_THROW(load_mesh(test_path("geometry/no_such_file.geo")), Error);
  const auto dir = ltl::testing::temp_dir("mesh");
  ltl::testing::write_file(dir / "broken.geo", "Point(1) = {0, 0, 0;\n");
  try {
    load_mesh((dir / "broken.geo").string());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("broken.geo"), std::string::npos) << e.what();
  }
  // Quadrilaterals in 2-D are refused: the 2-D element is the P2 triangle.
  ltl::testing::write_file(dir / "quads.geo",
                           "Point(1)={0,0,0};Point(2)={1,0,0};Point(3)={1,1,0};Point(4)={0,1,0};"
                           "Line(1)={1,2};Line(2)={2,3};Line(3)={3,4};Line(4)={4,1};"
                           "Curve Loop(1)={1,2,3,4};Plane Surface(1)={1};"
                           "Transfinite Surface{1};Recombine Surface{1};\n");
  try {
    load_mesh((dir / "quads.geo").string());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("triangles"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

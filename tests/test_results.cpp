// The results layer: HDF5 layout (read back with the raw HDF5 C API, independently of the
// reader in results.cpp), round trips, a killed writer, resume, XDMF, the Python reader, errors.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "error.hpp"
#include "results.hpp"

#ifndef LTL_SOURCE_DIR
#define LTL_SOURCE_DIR ""
#endif

namespace fs = std::filesystem;
using namespace ltl;

namespace {

fs::path source_dir() {
  if (std::string(LTL_SOURCE_DIR).size()) return LTL_SOURCE_DIR;
  return fs::absolute(fs::path(__FILE__)).parent_path().parent_path();  // standalone builds
}

/// A fresh directory under the system temporary directory, removed at the end of the test.
class ResultsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    dir_ = fs::temp_directory_path() /
           ("ltl_test_results_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// ---- meshes and states with distinct values --------------------------------------------------

/// Two P2 triangles on the unit square; the mid-node of edge 0-1 of the first triangle is pushed
/// down by 0.1, adding a parabolic segment of area (2/3) * 1 * 0.1 to it.
Mesh mesh2d() {
  Mesh m;
  m.dim = 2;
  m.X.resize(9, 2);
  m.X << 0, 0,    // 0
      1, 0,       // 1
      1, 1,       // 2
      0, 1,       // 3
      0.5, -0.1,  // 4: mid 0-1 (curved)
      0.5, 0.5,   // 5: mid 1-3
      0, 0.5,     // 6: mid 3-0
      1, 0.5,     // 7: mid 1-2
      0.5, 1;     // 8: mid 2-3
  m.cells.resize(2, 6);
  m.cells << 0, 1, 3, 4, 5, 6,  // vertices, mid-edges 01, 12, 20
      1, 2, 3, 7, 8, 5;
  m.source = "two_triangles.msh";
  Mesh::Boundary b;
  b.name = "contact";
  b.facets.resize(3, 3);
  b.facets << 0, 1, 4, 1, 2, 7, 2, 3, 8;
  m.boundaries.push_back(b);
  return m;
}

/// One hexahedron, the box [1,3] x [0,3] x [-1,3] (volume 24), gmsh node order.
Mesh mesh3d() {
  Mesh m;
  m.dim = 3;
  m.X.resize(8, 3);
  m.X << 1, 0, -1, 3, 0, -1, 3, 3, -1, 1, 3, -1, 1, 0, 3, 3, 0, 3, 3, 3, 3, 1, 3, 3;
  m.cells.resize(1, 8);
  m.cells << 0, 1, 2, 3, 4, 5, 6, 7;
  return m;
}

// Exactly representable values that differ in every index, so transpositions show.
double u_value(int p, int a, int i) {
  return 100.0 * p + 10 * a + i + 0.5;
}
/// Entry (i, j) of cell c's tensor number k (0 E, 1 lambda, 2 P, 3 sigma).
double tensor_value(int p, int k, int c, int i, int j) {
  return 1000.0 * p + 100 * c + 10 * i + j + 0.25 * k;
}
double e_value(int p, int f, int i) {
  return p + 10.0 * f + i + 0.125;
}
double lc_value(int p, int f, int i) {
  return -(p + 10.0 * f + i) - 0.375;
}
double beta_value(int p, int f) {
  return 0.5 + f + 0.0625 * p;
}

Eigen::MatrixXd tensor_field(int p, int k, int nc, int dim) {  // transposed-block layout
  Eigen::MatrixXd T(dim * nc, dim);
  for (int c = 0; c < nc; ++c)
    for (int i = 0; i < dim; ++i)
      for (int j = 0; j < dim; ++j) T(dim * c + j, i) = tensor_value(p, k, c, i, j);
  return T;
}

State make_state(const Mesh& m, int n_points, int p) {
  const int dim = m.dim;
  State s;
  s.u.resize(m.num_nodes(), dim);
  for (int a = 0; a < m.num_nodes(); ++a)
    for (int i = 0; i < dim; ++i) s.u(a, i) = u_value(p, a, i);
  s.E = tensor_field(p, 0, m.num_cells(), dim);
  s.lambda = tensor_field(p, 1, m.num_cells(), dim);
  s.e.resize(n_points, dim);
  s.lambda_c.resize(n_points, dim);
  s.beta.resize(n_points);
  for (int f = 0; f < n_points; ++f) {
    s.beta(f) = beta_value(p, f);
    for (int i = 0; i < dim; ++i) {
      s.e(f, i) = e_value(p, f, i);
      s.lambda_c(f, i) = lc_value(p, f, i);
    }
  }
  return s;
}

StepReport make_report(int p) {
  StepReport r;
  r.converged = true;
  r.status = "converged";
  r.iterations = 3 + p;
  r.strain_failures = p - 1;
  r.newton_iterations = p + 1;
  for (int n = 1; n <= r.iterations; ++n) {
    IterationRecord h;
    h.n = n;
    h.r_G = 1.0 / (1 << n);
    h.r_B = 3.0 / (1 << n);
    h.t_global = 0.25 * n;
    h.t_strain = 0.5 * n;
    h.t_contact = 0.75 * n;
    h.t_update = 0.125 * n;
    h.wall = n + 0.0625 * p;
    r.history.push_back(h);
  }
  return r;
}

/// Everything a step writes, kept alive together.
struct Step {
  State state;
  StepReport report;
  StepData data;
};

Step make_step(const Mesh& m, int n_points, int p) {
  Step s;
  s.state = make_state(m, n_points, p);
  s.report = make_report(p);
  s.data.p = p;
  s.data.t = 0.5 * p;
  s.data.fields["P"] = tensor_field(p, 2, m.num_cells(), m.dim);
  s.data.fields["sigma"] = tensor_field(p, 3, m.num_cells(), m.dim);
  Eigen::VectorXd pressure(m.num_cells()), contact_pressure(n_points), gap(n_points);
  for (int c = 0; c < m.num_cells(); ++c) pressure(c) = p + c + 0.75;
  for (int f = 0; f < n_points; ++f) {
    contact_pressure(f) = 2.0 * p + f;
    gap(f) = -f - 0.5 * p;
  }
  s.data.fields["pressure"] = pressure;
  if (n_points > 0) {
    s.data.fields["contact_pressure"] = contact_pressure;
    s.data.fields["gap"] = gap;
  }
  return s;
}

void append_step(ResultsFile& r, const Mesh& m, int n_points, int p) {
  Step s = make_step(m, n_points, p);
  s.data.state = &s.state;
  s.data.report = &s.report;
  r.append(s.data);
}

/// Contact centres in the ContactPoints layout (dim x #points): (10 f + i + 0.5).
Eigen::MatrixXd centres(int dim, int n_points) {
  Eigen::MatrixXd c(dim, n_points);
  for (int f = 0; f < n_points; ++f)
    for (int i = 0; i < dim; ++i) c(i, f) = 10.0 * f + i + 0.5;
  return c;
}

/// Options of a file with the contact surface m.boundaries[0] (and its centres and areas).
ResultsOptions contact_options(const Mesh& m, const Eigen::MatrixXd& centre = {},
                               const Eigen::VectorXd& area = {}) {
  ResultsOptions o;
  o.contact.facets = &m.boundaries[0];
  o.contact.centre = centre;
  o.contact.area = area;
  return o;
}

RunInfo run_info() {
  RunInfo info;
  info.name = "unit";
  info.config_text = "[time]\nsteps = 3\n";
  info.config_path = "/some/where/unit.toml";
  info.attributes = {{"code_version", "0.1.0"}, {"hdf5", "1.x"}};
  return info;
}

/// Writes steps 1..n of the 2-D problem with contact into `path`.
void write_2d(const std::string& path, int n) {
  const Mesh m = mesh2d();
  const Eigen::MatrixXd c = centres(2, 3);
  const Eigen::VectorXd area = Eigen::Vector3d(1.25, 1.5, 1.75);
  ResultsFile r = ResultsFile::create(path, m, run_info(), contact_options(m, c, area));
  for (int p = 1; p <= n; ++p) append_step(r, m, 3, p);
}

// ---- raw HDF5 access, independent of results.cpp -----------------------------------------------

struct Raw {
  std::vector<hsize_t> dims;
  std::vector<double> v;
};

Raw raw_read(const std::string& path, const std::string& dataset) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Raw out;
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  EXPECT_GE(f, 0) << path;
  if (f < 0) return out;
  const hid_t d = H5Dopen2(f, dataset.c_str(), H5P_DEFAULT);
  EXPECT_GE(d, 0) << dataset;
  if (d >= 0) {
    const hid_t s = H5Dget_space(d);
    out.dims.resize(H5Sget_simple_extent_ndims(s));
    H5Sget_simple_extent_dims(s, out.dims.data(), nullptr);
    out.v.resize(H5Sget_simple_extent_npoints(s));
    if (!out.v.empty()) {
      EXPECT_GE(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.v.data()), 0);
    }
    H5Sclose(s);
    H5Dclose(d);
  }
  H5Fclose(f);
  return out;
}

/// An attribute of object `obj` as text (strings as they are, numbers with %.17g).
std::string attr_text(hid_t a) {
  const hid_t t = H5Aget_type(a);
  std::string out;
  if (H5Tget_class(t) == H5T_STRING) {
    char* s = nullptr;
    const hid_t m = H5Tcopy(H5T_C_S1);
    H5Tset_size(m, H5T_VARIABLE);
    H5Tset_cset(m, H5T_CSET_UTF8);
    if (H5Aread(a, m, &s) >= 0 && s) out = s;
    H5free_memory(s);
    H5Tclose(m);
  } else {
    double v = 0;
    H5Aread(a, H5T_NATIVE_DOUBLE, &v);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    out = buf;
  }
  H5Tclose(t);
  return out;
}

std::string raw_attr(const std::string& path, const std::string& obj, const std::string& name) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  EXPECT_GE(f, 0) << path;
  if (f < 0) return "";
  std::string out = "<missing>";
  const hid_t a = H5Aopen_by_name(f, obj.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
  if (a >= 0) {
    out = attr_text(a);
    H5Aclose(a);
  }
  H5Fclose(f);
  return out;
}

/// Whether the object at absolute `path` exists (H5Lexists along the path).
bool path_exists(hid_t f, const std::string& path) {
  std::size_t start = 1;
  while (start <= path.size()) {
    std::size_t end = path.find('/', start);
    if (end == std::string::npos) end = path.size();
    if (H5Lexists(f, path.substr(0, end).c_str(), H5P_DEFAULT) <= 0) return false;
    start = end + 1;
  }
  return true;
}

bool raw_exists(const std::string& path, const std::string& obj) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return false;
  const bool e = path_exists(f, obj);
  H5Fclose(f);
  return e;
}

/// Every object, dataset (shape and values) and attribute in a file, as text, for comparisons.
std::map<std::string, std::string> dump(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  std::map<std::string, std::string> out;
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  EXPECT_GE(f, 0) << path;
  if (f < 0) return out;
  struct Ctx {
    std::map<std::string, std::string>* out;
    std::string obj;
  };
  auto attrs = [](hid_t o, const char* name, const H5A_info_t*, void* data) -> herr_t {
    auto* ctx = static_cast<Ctx*>(data);
    const hid_t a = H5Aopen(o, name, H5P_DEFAULT);
    (*ctx->out)[ctx->obj + "@" + name] = attr_text(a);
    H5Aclose(a);
    return 0;
  };
  Ctx root{&out, "/"};
  H5Aiterate2(f, H5_INDEX_NAME, H5_ITER_INC, nullptr, attrs, &root);
  auto visit = [](hid_t g, const char* name, const H5L_info_t*, void* data) -> herr_t {
    auto* out = static_cast<std::map<std::string, std::string>*>(data);
    const hid_t o = H5Oopen(g, name, H5P_DEFAULT);
    Ctx ctx{out, std::string("/") + name};
    H5Aiterate2(
        o, H5_INDEX_NAME, H5_ITER_INC, nullptr,
        [](hid_t oo, const char* n, const H5A_info_t*, void* d) -> herr_t {
          auto* c = static_cast<Ctx*>(d);
          const hid_t a = H5Aopen(oo, n, H5P_DEFAULT);
          (*c->out)[c->obj + "@" + n] = attr_text(a);
          H5Aclose(a);
          return 0;
        },
        &ctx);
    std::ostringstream s;
    s.precision(17);
    if (H5Iget_type(o) == H5I_DATASET) {
      const hid_t sp = H5Dget_space(o);
      std::vector<hsize_t> dims(H5Sget_simple_extent_ndims(sp));
      H5Sget_simple_extent_dims(sp, dims.data(), nullptr);
      std::vector<double> v(H5Sget_simple_extent_npoints(sp));
      if (!v.empty()) H5Dread(o, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
      s << "dataset";
      for (auto d : dims) s << ' ' << d;
      s << ':';
      for (double x : v) s << ' ' << x;
      H5Sclose(sp);
    } else {
      s << "group";
    }
    (*out)[ctx.obj] = s.str();
    H5Oclose(o);
    return 0;
  };
  H5Lvisit(f, H5_INDEX_NAME, H5_ITER_INC, visit, &out);
  H5Fclose(f);
  return out;
}

int count_steps(const std::string& path) {
  int n = 0;
  for (const auto& [k, v] : dump(path))
    if (k.rfind("/steps/", 0) == 0 && k.size() == 13 && v == "group") ++n;
  return n;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t i = s.find(what); i != std::string::npos; i = s.find(what, i + 1)) ++n;
  return n;
}

/// "" if `s` is well-formed XML (one root element, balanced tags, quoted attributes), else why.
std::string xml_problem(const std::string& s) {
  std::vector<std::string> open;
  int roots = 0;
  std::size_t i = 0;
  while ((i = s.find('<', i)) != std::string::npos) {
    if (s.compare(i, 4, "<!--") == 0) {
      const std::size_t j = s.find("-->", i);
      if (j == std::string::npos) return "unterminated comment";
      i = j + 3;
      continue;
    }
    if (s.compare(i, 2, "<?") == 0) {
      const std::size_t j = s.find("?>", i);
      if (j == std::string::npos) return "unterminated declaration";
      i = j + 2;
      continue;
    }
    const std::size_t j = s.find('>', i);
    if (j == std::string::npos) return "unterminated tag";
    const std::string tag = s.substr(i + 1, j - i - 1);
    if (tag.empty()) return "empty tag";
    if (count(tag, "\"") % 2) return "unbalanced quotes in <" + tag + ">";
    if (tag[0] == '/') {
      if (open.empty() || open.back() != tag.substr(1))
        return "</" + tag.substr(1) + "> closes " + (open.empty() ? "nothing" : open.back());
      open.pop_back();
    } else {
      const std::string name = tag.substr(0, tag.find_first_of(" \t\n/"));
      if (open.empty() && ++roots > 1) return "more than one root element";
      if (tag.back() != '/') open.push_back(name);
    }
    i = j + 1;
  }
  if (!open.empty()) return "unclosed <" + open.back() + ">";
  return roots == 1 ? "" : "no root element";
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "<no ltl::Error>";
}

}  // namespace

// ---- tests ------------------------------------------------------------------------------------

TEST_F(ResultsTest, TwoDimensionalLayoutAndRoundTrip) {
  const std::string path = file("run.h5");
  write_2d(path, 3);

  // The reader returns the last step in the solver's layouts, exactly.
  const auto last = ResultsFile::read_last_step(path);
  ASSERT_TRUE(last);
  EXPECT_EQ(last->p, 3);
  EXPECT_EQ(last->t, 1.5);
  EXPECT_EQ(last->iterations, 6);
  const Mesh m = mesh2d();
  const State want = make_state(m, 3, 3);
  const State& got = last->state;
  for (auto [name, a, b] : {std::tuple{"u", &got.u, &want.u},
                            {"E", &got.E, &want.E},
                            {"lambda", &got.lambda, &want.lambda},
                            {"e", &got.e, &want.e},
                            {"lambda_c", &got.lambda_c, &want.lambda_c}}) {
    ASSERT_EQ(a->rows(), b->rows()) << name;
    ASSERT_EQ(a->cols(), b->cols()) << name;
    EXPECT_TRUE((a->array() == b->array()).all()) << name << ":\n" << *a << "\nwant\n" << *b;
  }
  EXPECT_TRUE((got.beta.array() == want.beta.array()).all());
  EXPECT_EQ(cell_tensor(got.E, 1)(0, 1), tensor_value(3, 0, 1, 0, 1));

  // The file layout, read with the raw C API: natural (#cells, dim, dim) tensors etc.
  const std::string g = "/steps/000003/";
  for (auto [name, k] : {std::pair{"E", 0}, {"lambda", 1}, {"P", 2}, {"sigma", 3}}) {
    const Raw t = raw_read(path, g + name);
    ASSERT_EQ(t.dims, (std::vector<hsize_t>{2, 2, 2})) << name;
    for (int c = 0; c < 2; ++c)
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
          EXPECT_EQ(t.v[(c * 2 + i) * 2 + j], tensor_value(3, k, c, i, j)) << name;
  }
  const Raw u = raw_read(path, g + "u");
  ASSERT_EQ(u.dims, (std::vector<hsize_t>{9, 2}));
  for (int a = 0; a < 9; ++a)
    for (int i = 0; i < 2; ++i) EXPECT_EQ(u.v[a * 2 + i], u_value(3, a, i));
  const Raw e = raw_read(path, g + "e"), lc = raw_read(path, g + "lambda_c");
  ASSERT_EQ(e.dims, (std::vector<hsize_t>{3, 2}));
  ASSERT_EQ(lc.dims, (std::vector<hsize_t>{3, 2}));
  for (int f = 0; f < 3; ++f)
    for (int i = 0; i < 2; ++i) {
      EXPECT_EQ(e.v[f * 2 + i], e_value(3, f, i));
      EXPECT_EQ(lc.v[f * 2 + i], lc_value(3, f, i));
    }
  EXPECT_EQ(raw_read(path, g + "beta").v, (std::vector<double>{0.6875, 1.6875, 2.6875}));
  EXPECT_EQ(raw_read(path, g + "pressure").v, (std::vector<double>{3.75, 4.75}));
  EXPECT_EQ(raw_read(path, g + "contact_pressure").v, (std::vector<double>{6, 7, 8}));
  EXPECT_EQ(raw_read(path, g + "gap").v, (std::vector<double>{-1.5, -2.5, -3.5}));
  const Raw h = raw_read(path, g + "history");
  ASSERT_EQ(h.dims, (std::vector<hsize_t>{6, 8}));
  const StepReport rep = make_report(3);
  for (int n = 0; n < 6; ++n) {
    const auto& r = rep.history[n];
    const double row[8] = {double(r.n), r.r_G,       r.r_B,      r.t_global,
                           r.t_strain,  r.t_contact, r.t_update, r.wall};
    for (int k = 0; k < 8; ++k) EXPECT_EQ(h.v[n * 8 + k], row[k]) << n << ", " << k;
  }
  EXPECT_EQ(raw_attr(path, g + "history", "columns"),
            "n r_G r_B t_global t_strain t_contact t_update wall");
  EXPECT_EQ(raw_attr(path, g, "p"), "3");
  EXPECT_EQ(raw_attr(path, g, "t"), "1.5");
  EXPECT_EQ(raw_attr(path, g, "iterations"), "6");
  EXPECT_EQ(raw_attr(path, g, "status"), "converged");
  EXPECT_EQ(raw_attr(path, g, "strain_failures"), "2");
  EXPECT_EQ(raw_attr(path, g, "newton_iterations"), "4");
  EXPECT_EQ(raw_attr(path, "/steps/000001", "t"), "0.5");
  EXPECT_EQ(count_steps(path), 3);

  // Padded ParaView copies in 2-D.
  const Raw u3 = raw_read(path, g + "xdmf/u");
  ASSERT_EQ(u3.dims, (std::vector<hsize_t>{9, 3}));
  for (int a = 0; a < 9; ++a) {
    EXPECT_EQ(u3.v[a * 3 + 0], u_value(3, a, 0));
    EXPECT_EQ(u3.v[a * 3 + 1], u_value(3, a, 1));
    EXPECT_EQ(u3.v[a * 3 + 2], 0.0);
  }
  const Raw P3 = raw_read(path, g + "xdmf/P");
  ASSERT_EQ(P3.dims, (std::vector<hsize_t>{2, 3, 3}));
  for (int c = 0; c < 2; ++c)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        EXPECT_EQ(P3.v[(c * 3 + i) * 3 + j], i < 2 && j < 2 ? tensor_value(3, 2, c, i, j) : 0.0);

  // Mesh.
  const Raw X = raw_read(path, "/mesh/X"), cells = raw_read(path, "/mesh/cells");
  ASSERT_EQ(X.dims, (std::vector<hsize_t>{9, 2}));
  EXPECT_EQ(X.v[4 * 2 + 1], -0.1);
  ASSERT_EQ(cells.dims, (std::vector<hsize_t>{2, 6}));
  EXPECT_EQ(cells.v, (std::vector<double>{0, 1, 3, 4, 5, 6, 1, 2, 3, 7, 8, 5}));
  const Raw vol = raw_read(path, "/mesh/cell_volume");
  ASSERT_EQ(vol.v.size(), 2u);
  EXPECT_NEAR(vol.v[0], 0.5 + 2.0 / 3 * 0.1, 1e-14);
  EXPECT_NEAR(vol.v[1], 0.5, 1e-14);
  EXPECT_EQ(raw_read(path, "/mesh/contact_facets").v,
            (std::vector<double>{0, 1, 4, 1, 2, 7, 2, 3, 8}));
  EXPECT_EQ(raw_read(path, "/mesh/contact_centre").v,
            (std::vector<double>{0.5, 1.5, 10.5, 11.5, 20.5, 21.5}));
  EXPECT_EQ(raw_read(path, "/mesh/contact_area").v, (std::vector<double>{1.25, 1.5, 1.75}));
  EXPECT_EQ(raw_attr(path, "/mesh/contact_facets", "boundary"), "contact");
  EXPECT_EQ(raw_attr(path, "/mesh", "cell_type"), "Triangle_6");

  // Root attributes.
  EXPECT_EQ(ResultsFile::read_attribute(path, "name"), "unit");
  EXPECT_EQ(ResultsFile::read_attribute(path, "config"), "[time]\nsteps = 3\n");
  EXPECT_EQ(ResultsFile::read_attribute(path, "config_path"), "/some/where/unit.toml");
  EXPECT_EQ(ResultsFile::read_attribute(path, "code_version"), "0.1.0");
  EXPECT_EQ(ResultsFile::read_attribute(path, "hdf5"), "1.x");
  EXPECT_EQ(ResultsFile::read_attribute(path, "status"), "running");
  EXPECT_EQ(ResultsFile::read_attribute(path, "no_such_attribute"), "");
  {
    ResultsFile r = ResultsFile::open(path);
    r.set_status("diverged at step 4: NaN");
  }
  EXPECT_EQ(ResultsFile::read_attribute(path, "status"), "diverged at step 4: NaN");
  EXPECT_EQ(ResultsFile::read_last_step(path)->p, 3);  // open + close changes no step
}

/// A structured P2 triangle mesh of [0, nx] x [0, ny], two triangles a square (no boundary).
Mesh p2_grid(int nx, int ny) {
  Mesh m;
  m.dim = 2;
  const int w = 2 * nx + 1;
  m.X.resize(w * (2 * ny + 1), 2);
  for (int j = 0; j <= 2 * ny; ++j)
    for (int i = 0; i < w; ++i) m.X.row(j * w + i) << 0.5 * i, 0.5 * j;
  m.cells.resize(2 * nx * ny, 6);
  const auto at = [w](int i, int j) { return j * w + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = 2 * i, b = 2 * j, c = 2 * (j * nx + i);
      m.cells.row(c) << at(a, b), at(a + 2, b), at(a + 2, b + 2), at(a + 1, b), at(a + 2, b + 1),
          at(a + 1, b + 1);
      m.cells.row(c + 1) << at(a, b), at(a + 2, b + 2), at(a, b + 2), at(a + 1, b + 1),
          at(a + 1, b + 2), at(a, b + 1);
    }
  m.source = "p2_grid";
  return m;
}

/// Gives step `s` (of make_step, on nc cells) its state, its report and the plane-strain sigma33
/// = 1000 + c, which the padded copies of P and sigma read; returns sigma33.
Eigen::VectorXd give_sigma33(Step& s, int nc) {
  Eigen::VectorXd s33(nc);
  for (int c = 0; c < nc; ++c) s33(c) = 1000.0 + c;
  s.data.fields["sigma33"] = s33;
  s.data.state = &s.state;
  s.data.report = &s.report;
  return s33;
}

/// A step's fields are written a block of entities at a time (lib/results_layout.cpp:
/// write_field, 16 384 entities a block): on a mesh of 2.6 blocks of cells and 5.2 of nodes, every
/// entry of u, E, lambda and P is where the file's layout puts it, and the padded ParaView copies
/// have the out-of-plane entries of their own cells across the blocks' edges: E33 = 1 and
/// P33 = det E sigma33 (1.5). Fails when a block is written at another's place or a padded block
/// reads another's cells.
TEST_F(ResultsTest, Eq1_5_FieldsOfManyBlocksAreWrittenEntityByEntity) {
  const std::string path = file("blocks.h5");
  const Mesh m = p2_grid(150, 140);
  const int nc = m.num_cells(), nn = m.num_nodes();
  ASSERT_GT(nc, 2 * 16384);
  Step s = make_step(m, 0, 1);
  const Eigen::VectorXd s33 = give_sigma33(s, nc);
  {
    ResultsFile r = ResultsFile::create(path, m, run_info());
    r.append(s.data);
  }
  const auto last = ResultsFile::read_last_step(path);
  ASSERT_TRUE(last);
  EXPECT_TRUE((last->state.u.array() == s.state.u.array()).all());
  EXPECT_TRUE((last->state.E.array() == s.state.E.array()).all());
  EXPECT_TRUE((last->state.lambda.array() == s.state.lambda.array()).all());
  const Raw P = raw_read(path, "/steps/000001/P"), P3 = raw_read(path, "/steps/000001/xdmf/P"),
            E3 = raw_read(path, "/steps/000001/xdmf/E"),
            u3 = raw_read(path, "/steps/000001/xdmf/u");
  ASSERT_EQ(P3.v.size(), 9u * nc);
  ASSERT_EQ(u3.v.size(), 3u * nn);
  const Eigen::MatrixXd& Pc = s.data.fields["P"];
  int wrong = 0;
  for (int c = 0; c < nc; ++c) {
    const Eigen::Matrix2d Ec = s.state.E.block<2, 2>(2 * c, 0);
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) {
        wrong += P.v[4 * c + 2 * i + j] != Pc(2 * c + j, i);
        wrong += P3.v[9 * c + 3 * i + j] != Pc(2 * c + j, i);
      }
    wrong += E3.v[9 * c + 8] != 1.0;
    wrong += std::abs(P3.v[9 * c + 8] - Ec.determinant() * s33(c)) >
             1e-15 * std::abs(Ec.determinant() * s33(c));
  }
  for (int a = 0; a < nn; ++a)
    for (int i = 0; i < 3; ++i) wrong += u3.v[3 * a + i] != (i < 2 ? s.state.u(a, i) : 0.0);
  EXPECT_EQ(wrong, 0);
}

/// A FieldSource serving whole matrices, which records how the writer asks for them.
class RecordingSource final : public FieldSource {
 public:
  std::map<std::string, Eigen::MatrixXd> fields;
  std::map<std::string, Eigen::Index> largest;  ///< the most rows read at once, per field
  std::map<std::string, int> reads;             ///< reads per field
  std::map<std::string, int> open_now;
  int most_open = 0;  ///< fields open at once, at most
  int misuse = 0;     ///< reads of a field not open, closes of a field not open

  std::pair<Eigen::Index, Eigen::Index> open(const std::string& name) override {
    ++open_now[name];
    int n = 0;
    for (const auto& [k, v] : open_now) n += v;
    most_open = std::max(most_open, n);
    const auto it = fields.find(name);
    return it == fields.end() ? std::make_pair(Eigen::Index(0), Eigen::Index(0))
                              : std::make_pair(it->second.rows(), it->second.cols());
  }
  void read(const std::string& name, Eigen::Index first, Eigen::Index count,
            Eigen::MatrixXd& rows) override {
    misuse += open_now[name] <= 0;
    largest[name] = std::max(largest[name], count);
    ++reads[name];
    rows = fields.at(name).middleRows(first, count);
  }
  void close(const std::string& name) noexcept override {
    misuse += open_now[name] <= 0;
    if (--open_now[name] == 0) open_now.erase(name);
  }
};

/// The writer reads a source's fields a block at a time (lib/results_layout.cpp, 16 384 entities
/// a block; lib/step_fields.hpp makes them so on the ranks' cells): on the mesh of 2.6 blocks of
/// cells and 5.2 of nodes, the file written from a source is the file written from whole
/// matrices, dataset by dataset; no read exceeds one block (a tensor's 2 rows per cell), every
/// field is read block by block for the stored copy and the padded one, and the padded P holds E
/// and sigma33 open beside it (det E sigma33 of (1.5)), the padded sigma sigma33: three fields at
/// most, each closed. Fails when the writer reads a whole field at once or leaves one open.
TEST_F(ResultsTest, Eq1_5_ASourcesFieldsAreReadABlockAtATime) {
  const Mesh m = p2_grid(150, 140);
  const int nc = m.num_cells(), nn = m.num_nodes();
  Step s = make_step(m, 0, 1);
  give_sigma33(s, nc);
  const std::string whole = file("whole.h5"), blocks = file("source.h5");
  {
    ResultsFile r = ResultsFile::create(whole, m, run_info());
    r.append(s.data);
  }
  RecordingSource source;
  source.fields = s.data.fields;
  source.fields["u"] = s.state.u;
  source.fields["E"] = s.state.E;
  source.fields["lambda"] = s.state.lambda;
  StepData from_source = s.data;
  from_source.fields.clear();
  from_source.source = &source;
  {
    ResultsFile r = ResultsFile::create(blocks, m, run_info());
    r.append(from_source);
  }
  int differ = 0, compared = 0;
  for (const char* name : {"u", "E", "lambda", "P", "sigma", "sigma33", "pressure", "xdmf/u",
                           "xdmf/E", "xdmf/P", "xdmf/sigma"}) {
    const std::string path = std::string("/steps/000001/") + name;
    const Raw a = raw_read(whole, path), b = raw_read(blocks, path);
    EXPECT_EQ(a.dims, b.dims) << name;
    differ += a.v != b.v;
    compared += !a.v.empty();
  }
  EXPECT_EQ(compared, 11);
  EXPECT_EQ(differ, 0);
  const int cell_blocks = (nc + 16383) / 16384, node_blocks = (nn + 16383) / 16384;
  ASSERT_EQ(cell_blocks, 3);
  ASSERT_EQ(node_blocks, 6);
  EXPECT_EQ(source.largest["u"], 16384);
  EXPECT_EQ(source.largest["E"], 2 * 16384);
  EXPECT_EQ(source.largest["P"], 2 * 16384);
  EXPECT_EQ(source.largest["sigma33"], 16384);
  EXPECT_EQ(source.reads["u"], 2 * node_blocks);  // stored, and its ParaView copy
  EXPECT_EQ(source.reads["P"], 2 * cell_blocks);
  // E: stored, its copy, and beside the padded P; sigma33: stored, and beside P and sigma.
  EXPECT_EQ(source.reads["E"], 3 * cell_blocks);
  EXPECT_EQ(source.reads["sigma33"], 3 * cell_blocks);
  EXPECT_EQ(source.most_open, 3);
  EXPECT_TRUE(source.open_now.empty());
  EXPECT_EQ(source.misuse, 0);
}

TEST_F(ResultsTest, ThreeDimensionalWithoutContact) {
  const std::string path = file("hex");  // no .h5: the XDMF file is hex.xdmf
  const Mesh m = mesh3d();
  {
    ResultsFile r = ResultsFile::create(path, m, run_info());
    for (int p = 1; p <= 3; ++p) {
      Step s = make_step(m, 0, p);
      s.data.state = &s.state;
      s.data.report = p == 2 ? nullptr : &s.report;  // no report: no history, 0 iterations
      r.append(s.data);
    }
  }
  const auto last = ResultsFile::read_last_step(path);
  ASSERT_TRUE(last);
  EXPECT_EQ(last->p, 3);
  const State want = make_state(m, 0, 3);
  EXPECT_TRUE((last->state.u.array() == want.u.array()).all());
  ASSERT_EQ(last->state.E.rows(), 3);
  EXPECT_TRUE((last->state.E.array() == want.E.array()).all());
  EXPECT_TRUE((last->state.lambda.array() == want.lambda.array()).all());
  EXPECT_EQ(last->state.e.rows(), 0);
  EXPECT_EQ(last->state.e.cols(), 3);
  EXPECT_EQ(last->state.lambda_c.rows(), 0);
  EXPECT_EQ(last->state.beta.size(), 0);

  const Raw P = raw_read(path, "/steps/000003/P");
  ASSERT_EQ(P.dims, (std::vector<hsize_t>{1, 3, 3}));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_EQ(P.v[i * 3 + j], tensor_value(3, 2, 0, i, j));
  EXPECT_NEAR(raw_read(path, "/mesh/cell_volume").v.at(0), 24.0, 1e-13);
  EXPECT_EQ(raw_read(path, "/steps/000002/history").dims, (std::vector<hsize_t>{0, 8}));
  EXPECT_EQ(raw_attr(path, "/steps/000002", "iterations"), "0");
  EXPECT_FALSE(raw_exists(path, "/steps/000003/beta"));
  EXPECT_FALSE(raw_exists(path, "/steps/000003/gap"));
  EXPECT_FALSE(raw_exists(path, "/steps/000003/xdmf"));
  EXPECT_FALSE(raw_exists(path, "/mesh/contact_facets"));

  const std::string x = read_text(path + ".xdmf");
  EXPECT_EQ(xml_problem(x), "");
  EXPECT_EQ(count(x, "TopologyType=\"Hexahedron\""), 3);
  EXPECT_EQ(count(x, "GeometryType=\"XYZ\""), 3);
  EXPECT_EQ(count(x, "Dimensions=\"1 8\""), 3);
  EXPECT_EQ(count(x, "Dimensions=\"8 3\""), 6);  // X and u, per step
  EXPECT_NE(x.find("hex:/steps/000003/u<"), std::string::npos);
  EXPECT_NE(x.find("hex:/steps/000003/sigma<"), std::string::npos);
  EXPECT_EQ(x.find("/xdmf/"), std::string::npos);
}

TEST_F(ResultsTest, XdmfDescribesEveryStep) {
  const std::string path = file("run.h5");
  write_2d(path, 3);
  const std::string xpath = file("run.xdmf");
  ASSERT_TRUE(fs::exists(xpath));
  EXPECT_FALSE(fs::exists(xpath + ".tmp"));
  const std::string x = read_text(xpath);
  EXPECT_EQ(xml_problem(x), "") << x;
  if (std::system("command -v xmllint > /dev/null 2>&1") == 0) {
    EXPECT_EQ(std::system(("xmllint --noout '" + xpath + "'").c_str()), 0);
  }
  EXPECT_EQ(count(x, "CollectionType=\"Temporal\""), 1);
  EXPECT_EQ(count(x, "<Grid Name=\"step_"), 3);
  for (int p = 1; p <= 3; ++p) {
    const std::string g = "run.h5:/steps/00000" + std::to_string(p);
    EXPECT_NE(x.find("<Grid Name=\"step_00000" + std::to_string(p) + "\""), std::string::npos);
    const char* t[] = {"", "0.5", "1", "1.5"};
    EXPECT_NE(x.find(std::string("<Time Value=\"") + t[p] + "\"/>"), std::string::npos);
    EXPECT_NE(x.find(g + "/xdmf/u<"), std::string::npos);
    EXPECT_NE(x.find(g + "/xdmf/P<"), std::string::npos);
    EXPECT_NE(x.find(g + "/xdmf/sigma<"), std::string::npos);
    EXPECT_NE(x.find(g + "/pressure<"), std::string::npos);
  }
  EXPECT_EQ(count(x, "TopologyType=\"Triangle_6\" NumberOfElements=\"2\""), 3);
  EXPECT_EQ(count(x, "GeometryType=\"XY\""), 3);
  EXPECT_EQ(count(x, "AttributeType=\"Vector\" Center=\"Node\""), 3);
  // E, P, sigma and the deformation gradient E shown as F (derived_fields.hpp)
  EXPECT_EQ(count(x, "AttributeType=\"Tensor\" Center=\"Cell\""), 12);
  EXPECT_EQ(count(x, "Dimensions=\"9 3\""), 3);     // padded u
  EXPECT_EQ(count(x, "Dimensions=\"2 3 3\""), 12);  // padded E (twice: E and F), P, sigma
  EXPECT_EQ(count(x, "<Attribute Name=\"E\""), 3);
  EXPECT_EQ(count(x, "<Attribute Name=\"F\""), 3);
  EXPECT_EQ(count(x, "Dimensions=\"2 6\" NumberType=\"Int\""), 3);
}

TEST_F(ResultsTest, KilledWriterKeepsStepsAndResumeMatchesUninterruptedRun) {
  const std::string killed = (dir_ / "a" / "run.h5").string();
  const std::string whole = (dir_ / "b" / "run.h5").string();
  fs::create_directories(dir_ / "a");
  fs::create_directories(dir_ / "b");

  // A child process writes two steps and dies without running any destructor.
  std::fflush(nullptr);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    try {
      const Mesh m = mesh2d();
      const Eigen::MatrixXd c = centres(2, 3);
      const Eigen::VectorXd area = Eigen::Vector3d(1.25, 1.5, 1.75);
      auto* r =
          new ResultsFile(ResultsFile::create(killed, m, run_info(), contact_options(m, c, area)));
      append_step(*r, m, 3, 1);
      append_step(*r, m, 3, 2);
    } catch (...) {
      _exit(1);
    }
    _exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 0);

  const auto last = ResultsFile::read_last_step(killed);
  ASSERT_TRUE(last);
  EXPECT_EQ(last->p, 2);
  EXPECT_TRUE((last->state.u.array() == make_state(mesh2d(), 3, 2).u.array()).all());
  EXPECT_EQ(count_steps(killed), 2);
  EXPECT_EQ(ResultsFile::read_attribute(killed, "status"), "running");
  const std::string x = read_text((dir_ / "a" / "run.xdmf").string());
  EXPECT_EQ(xml_problem(x), "");
  EXPECT_EQ(count(x, "<Grid Name=\"step_"), 2);

  // Resume: append step 3; then the file equals one written in a single run.
  {
    ResultsFile r = ResultsFile::open(killed);
    r.set_status("running");
    append_step(r, mesh2d(), 3, 3);
    r.set_status("complete");
  }
  write_2d(whole, 3);
  {
    ResultsFile r = ResultsFile::open(whole);
    r.set_status("complete");
  }
  const auto a = dump(killed), b = dump(whole);
  EXPECT_GT(a.size(), 50u);
  EXPECT_EQ(a.count("/steps/000003/u"), 1u);
  EXPECT_EQ(a.count("/@status"), 1u);
  EXPECT_EQ(a, b);
  EXPECT_EQ(read_text((dir_ / "a" / "run.xdmf").string()),
            read_text((dir_ / "b" / "run.xdmf").string()));
}

TEST_F(ResultsTest, FlushedStepsAreReadableWhileTheWriterIsOpen) {
  const std::string path = file("open.h5");
  const Mesh m = mesh2d();
  ResultsFile r = ResultsFile::create(path, m, run_info(), contact_options(m));
  EXPECT_FALSE(ResultsFile::read_last_step(path));  // a results file with no step yet
  append_step(r, m, 3, 1);
  append_step(r, m, 3, 2);
  const auto last = ResultsFile::read_last_step(path);
  ASSERT_TRUE(last);
  EXPECT_EQ(last->p, 2);
  EXPECT_EQ(last->state.lambda_c(2, 1), lc_value(2, 2, 1));
  EXPECT_EQ(count(read_text(file("open.xdmf")), "<Grid Name=\"step_"), 2);
  EXPECT_FALSE(raw_exists(path, "/mesh/contact_centre"));  // not given
}

TEST_F(ResultsTest, IncompleteStepIsIgnoredAndRemovedOnResume) {
  const std::string path = file("partial.h5");
  write_2d(path, 2);
  {  // what a process killed inside append() leaves behind
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    const hid_t g = H5Gcreate2(f, "/steps/incomplete", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(g, 0);
    H5Gclose(g);
    H5Fclose(f);
  }
  EXPECT_EQ(ResultsFile::read_last_step(path)->p, 2);
  {
    ResultsFile r = ResultsFile::open(path);
    EXPECT_FALSE(raw_exists(path, "/steps/incomplete"));
    append_step(r, mesh2d(), 3, 3);
  }
  EXPECT_EQ(ResultsFile::read_last_step(path)->p, 3);
  EXPECT_EQ(count_steps(path), 3);
}

TEST_F(ResultsTest, MoveConstructionAndAssignment) {
  const Mesh m = mesh3d();
  ResultsFile a = ResultsFile::create(file("a.h5"), m, run_info());
  ResultsFile b(std::move(a));
  append_step(b, m, 0, 1);
  ResultsFile c = ResultsFile::create(file("c.h5"), m, run_info());
  c = std::move(b);  // closes c.h5, takes over a.h5
  EXPECT_EQ(c.path(), file("a.h5"));
  append_step(c, m, 0, 2);
  EXPECT_FALSE(ResultsFile::read_last_step(file("c.h5")));
  EXPECT_EQ(ResultsFile::read_last_step(file("a.h5"))->p, 2);
}

TEST_F(ResultsTest, PythonReader) {
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "/usr/bin/python3 is missing";
  ASSERT_TRUE(fs::exists(source_dir() / "figures" / "ltl_results.py"))
      << "figures/ltl_results.py not found under " << source_dir();
  const std::string path = file("run.h5");
  write_2d(path, 3);
  const std::string script = file("check.py");
  std::ofstream(script) << "import sys\n"
                        << "sys.path.insert(0, " << (source_dir() / "figures") << ")\n"
                        << R"(import numpy as np
import ltl_results
r = ltl_results.load(sys.argv[1])
assert len(r.steps) == 3, len(r.steps)
assert [s.p for s in r.steps] == [1, 2, 3]
assert list(r.times()) == [0.5, 1.0, 1.5]
s = r.steps[-1]
assert s.iterations == 6 and s.status == "converged"
u = s.fields["u"]
assert u.shape == (9, 2), u.shape
for a in range(9):
    for i in range(2):
        assert u[a, i] == 100 * 3 + 10 * a + i + 0.5
P = s.fields["P"]
assert P.shape == (2, 2, 2)
assert P[1, 0, 1] == 1000 * 3 + 100 * 1 + 10 * 0 + 1 + 0.5
assert s.fields["e"][2, 1] == 3 + 20 + 1 + 0.125
assert "xdmf" not in s.fields
assert list(s.history["r_G"]) == [0.5 ** n for n in range(1, 7)]
assert r.attrs["name"] == "unit" and r.attrs["status"] == "running"
assert r.mesh.dim == 2 and r.mesh.cells.shape == (2, 6)
assert r.mesh.contact_centre[2, 1] == 21.5
assert abs(r.mesh.cell_volume[0] - (0.5 + 0.2 / 3)) < 1e-14
assert r.step(2).fields["u"][0, 0] == 200.5
d = ltl_results.deformed(r.mesh.X, u, 0.5)
assert d[1, 0] == 1 + 0.5 * u[1, 0]
only = ltl_results.load(sys.argv[1], fields=["u"])
assert sorted(only.steps[0].fields) == ["u"]
ltl_results.print_table("check", {"p": [1, 2, 3], "t": r.times()})
print("PYTHON-OK")
)";
  const std::string out = file("python.out");
  const int rc = std::system(
      ("/usr/bin/python3 '" + script + "' '" + path + "' > '" + out + "' 2>&1").c_str());
  EXPECT_EQ(rc, 0) << read_text(out);
  EXPECT_NE(read_text(out).find("PYTHON-OK"), std::string::npos) << read_text(out);
}

TEST_F(ResultsTest, ClearErrorsNamingTheFile) {
  // HDF5's default: print the error stack of every failed call. The results layer must silence it.
  H5Eset_auto2(H5E_DEFAULT, reinterpret_cast<H5E_auto2_t>(H5Eprint2), stderr);
  testing::internal::CaptureStderr();
  const std::string missing = file("missing.h5");
  std::string msg = error_of([&] { ResultsFile::read_last_step(missing); });
  EXPECT_NE(msg.find(missing), std::string::npos) << msg;
  EXPECT_NE(msg.find("no such file"), std::string::npos) << msg;
  msg = error_of([&] { ResultsFile::open(missing); });
  EXPECT_NE(msg.find(missing), std::string::npos) << msg;
  msg = error_of([&] { ResultsFile::read_attribute(missing, "name"); });
  EXPECT_NE(msg.find(missing), std::string::npos) << msg;

  const std::string text = file("text.h5");
  std::ofstream(text) << "not HDF5 at all\n";
  msg = error_of([&] { ResultsFile::read_last_step(text); });
  EXPECT_NE(msg.find(text), std::string::npos) << msg;
  EXPECT_NE(msg.find("not an HDF5 file"), std::string::npos) << msg;

  const std::string other = file("other.h5");  // HDF5, but not a results file
  H5Fclose(H5Fcreate(other.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  msg = error_of([&] { ResultsFile::read_last_step(other); });
  EXPECT_NE(msg.find(other), std::string::npos) << msg;
  EXPECT_NE(msg.find("not a results file"), std::string::npos) << msg;
  msg = error_of([&] { ResultsFile::open(other); });
  EXPECT_NE(msg.find("not a results file"), std::string::npos) << msg;

  msg = error_of([&] { ResultsFile::create(file("no/such/dir/x.h5"), mesh2d(), run_info()); });
  EXPECT_NE(msg.find("no/such/dir/x.h5: cannot create"), std::string::npos) << msg;

  // A step whose dataset is missing or has the wrong shape.
  const std::string path = file("broken.h5");
  write_2d(path, 1);
  {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    EXPECT_GE(H5Ldelete(f, "/steps/000001/E", H5P_DEFAULT), 0);
    H5Fclose(f);
  }
  msg = error_of([&] { ResultsFile::read_last_step(path); });
  EXPECT_NE(msg.find(path + ": missing dataset /steps/000001/E"), std::string::npos) << msg;

  // Wrong sizes and duplicate steps when appending.
  {
    const Mesh m = mesh2d();
    ResultsFile r = ResultsFile::create(file("sizes.h5"), m, run_info(), contact_options(m));
    Step s = make_step(m, 3, 1);
    s.data.state = &s.state;
    s.state.u.conservativeResize(8, 2);
    msg = error_of([&] { r.append(s.data); });
    EXPECT_NE(msg.find("u is 8 x 2, expected 9 x 2"), std::string::npos) << msg;
    s.state = make_state(m, 3, 1);
    s.state.beta.resize(2);
    msg = error_of([&] { r.append(s.data); });
    EXPECT_NE(msg.find("beta"), std::string::npos) << msg;
    s.state = make_state(m, 3, 1);
    r.append(s.data);
    msg = error_of([&] { r.append(s.data); });
    EXPECT_NE(msg.find("step 1 is already stored"), std::string::npos) << msg;
    s.data.state = nullptr;
    msg = error_of([&] { r.append(s.data); });
    EXPECT_NE(msg.find("no state"), std::string::npos) << msg;
  }
  EXPECT_EQ(ResultsFile::read_last_step(file("sizes.h5"))->p, 1);

  // A mesh of cells that cannot be stored.
  Mesh tri3;
  tri3.dim = 2;
  tri3.X = Eigen::MatrixXd::Zero(3, 2);
  tri3.cells = Eigen::MatrixXi::Zero(1, 3);
  msg = error_of([&] { ResultsFile::create(file("tri3.h5"), tri3, run_info()); });
  EXPECT_NE(msg.find("3-node cells"), std::string::npos) << msg;

  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");  // HDF5 printed nothing
}

TEST(LibraryVersions, NamesAndValues) {
  const auto v = library_versions();
  ASSERT_EQ(v.size(), 4u);
  EXPECT_EQ(v.at("eigen"), std::to_string(EIGEN_WORLD_VERSION) + "." +
                               std::to_string(EIGEN_MAJOR_VERSION) + "." +
                               std::to_string(EIGEN_MINOR_VERSION));
  unsigned a = 0, b = 0, c = 0;
  H5get_libversion(&a, &b, &c);
  EXPECT_EQ(v.at("hdf5"), std::to_string(a) + "." + std::to_string(b) + "." + std::to_string(c));
  for (const char* k : {"cholmod", "gmsh"}) {
    EXPECT_EQ(count(v.at(k), "."), 2) << k << " = " << v.at(k);
    EXPECT_TRUE(std::isdigit(static_cast<unsigned char>(v.at(k)[0]))) << k;
  }
}

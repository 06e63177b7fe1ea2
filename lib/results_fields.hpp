// The field table of the results files: every dataset of the mesh and of a step, with where it
// lives, its shape, unit and description. One table drives the writer (which fields a step has,
// their shapes and the "unit" and "description" attributes), the reader (the state read back for
// --resume), the XDMF writer (which fields ParaView shows, and how a 2-D field is padded to 3-D)
// and the Python reader (figures/ltl_results.py holds python_field_table(), checked by
// tests/test_results_layers.cpp, which checks the layout table of experiments/README.md too).
//
// Adding a field: one row here (Source::Derived) and its computation, made when the writer asks
// for the row's name (lib/step_fields.cpp, StepFields::make: on the state's cells, gathered to
// the writer under mpirun; a field of the Dirichlet conditions goes into StepData::fields in
// lib/simulation.cpp, step_data), in the solver's layouts: a scalar is a
// column (#entities), a vector #entities x dim, a tensor dim x dim blocks stacked like State::E
// (block c = T_c^T). Then regenerate the block of figures/ltl_results.py and add the row to
// experiments/README.md (the test prints both).
#pragma once

#include <string>
#include <string_view>

namespace ltl {

/// Where a field lives: the mesh (written once), or per step on the nodes, the cells, the contact
/// points (the contact nodes or facets), or the step as a whole.
enum class Location { Mesh, Node, Cell, Point, Step, Support };
/// Its shape per entity: one number, dim numbers, dim x dim numbers; Table: a mesh table or the
/// iteration history, written by their own code.
/// Vector3, Tensor3: 3 and 3 x 3 numbers in 2-D too (plane strain: with the out-of-plane
/// entries), in the solver's layout #entities x 3 and #entities x 9 (row-major).
enum class Shape { Scalar, Vector, Tensor, Table, Vector3, Tensor3 };
/// Who provides it: the solver's State (read back for --resume), a computation at the step
/// (StepData::fields), or the mesh and bookkeeping code (ResultsFile::create, the history and
/// the measures' contact set).
enum class Source { State, Derived, Other };
/// The out-of-plane entry of a 2-D tensor in its ParaView copy (3x3); vectors get a zero third
/// component. None: not shown in the XDMF files.
enum class Pad33 { None, Zero, One, Sigma33, DetESigma33 };

struct Field {
  const char* name;
  Location at;
  Shape shape;
  Source source;
  Pad33 xdmf;  ///< None: no XDMF attribute
  const char* unit_2d;
  const char* unit_3d;
  const char* description;
};

// clang-format off
inline constexpr Field kFields[] = {
    {"X", Location::Mesh, Shape::Vector, Source::Other, Pad33::None, "m", "m",
     "reference positions of the nodes (#nodes, dim)"},
    {"cells", Location::Mesh, Shape::Table, Source::Other, Pad33::None, "1", "1",
     "node indices of each cell, gmsh order (= XDMF order)"},
    {"cell_volume", Location::Mesh, Shape::Scalar, Source::Other, Pad33::None, "m^2", "m^3",
     "reference volume of each cell (plane strain: area, per metre of depth), from the "
     "discretization's cell operators (lib/fe: CellOperators::vol)"},
    {"contact_facets", Location::Mesh, Shape::Table, Source::Other, Pad33::None, "1", "1",
     "node indices of each facet of the contact surface"},
    {"contact_nodes", Location::Mesh, Shape::Scalar, Source::Other, Pad33::None, "1", "1",
     "mesh node of each contact point (nodal contact)"},
    {"contact_topology", Location::Mesh, Shape::Table, Source::Other, Pad33::None, "1", "1",
     "the contact facets as indices into the contact points (nodal contact): the topology of "
     "the contact-surface XDMF grid"},
    {"contact_centre", Location::Mesh, Shape::Vector, Source::Other, Pad33::None, "m", "m",
     "reference position of each contact point (#points, dim)"},
    {"contact_area", Location::Mesh, Shape::Scalar, Source::Other, Pad33::None, "m", "m^2",
     "weight of each contact point: facet measure, or integral of the node's shape function "
     "over the contact surface (plane strain: per metre of depth)"},
    {"contact_obstacle", Location::Mesh, Shape::Scalar, Source::Other, Pad33::None, "1", "1",
     "several obstacles ([[contact]]) only: the obstacle (0, 1, ...) of each contact point; the "
     "points of obstacle k are consecutive, and every per-point field splits by it"},
    {"u", Location::Node, Shape::Vector, Source::State, Pad33::Zero, "m", "m",
     "displacement of the nodes (#nodes, dim)"},
    {"E", Location::Cell, Shape::Tensor, Source::State, Pad33::One, "1", "1",
     "deformation gradient F = I + grad u of each cell, the paper's strain unknown F of (2.7) "
     "(named E in the code; the XDMF shows it as F too); [c][i][j] = F_c(i, j)"},
    {"detF", Location::Cell, Shape::Scalar, Source::Derived, Pad33::Zero, "1", "1",
     "det F of each cell (lib/derived_fields.hpp)"},
    {"stretches", Location::Cell, Shape::Vector3, Source::Derived, Pad33::Zero, "1", "1",
     "principal stretches of each cell, the singular values of F, decreasing (plane strain: "
     "with F33 = 1)"},
    {"von_mises", Location::Cell, Shape::Scalar, Source::Derived, Pad33::Zero, "Pa", "Pa",
     "von Mises stress sqrt(3/2 s : s) of each cell, s the deviator of sigma (with sigma33 in "
     "plane strain)"},
    {"sigma_node", Location::Node, Shape::Tensor3, Source::Derived, Pad33::Zero, "Pa", "Pa",
     "Cauchy stress recovered at the nodes: volume-weighted mean of the stresses of the cells "
     "around each node (with sigma33 in plane strain)"},
    {"von_mises_node", Location::Node, Shape::Scalar, Source::Derived, Pad33::Zero, "Pa", "Pa",
     "von Mises stress of sigma_node at each node"},
    {"lambda", Location::Cell, Shape::Tensor, Source::State, Pad33::None, "Pa", "Pa",
     "multiplier of I + grad u = E of each cell (a first Piola-Kirchhoff stress)"},
    {"P", Location::Cell, Shape::Tensor, Source::Derived, Pad33::DetESigma33, "Pa", "Pa",
     "first Piola-Kirchhoff stress of each cell, P = 2 C1 E - lambda"},
    {"sigma", Location::Cell, Shape::Tensor, Source::Derived, Pad33::Sigma33, "Pa", "Pa",
     "Cauchy stress of each cell, sigma = P E^T / det E"},
    {"sigma33", Location::Cell, Shape::Scalar, Source::Derived, Pad33::Zero, "Pa", "Pa",
     "plane strain: out-of-plane Cauchy stress of each cell, from the law with F33 = 1 and "
     "the pressure (Material::plane_strain_sigma33, (1.5))"},
    {"pressure", Location::Cell, Shape::Scalar, Source::Derived, Pad33::Zero, "Pa", "Pa",
     "mean stress of each cell, -trace(sigma) / 3 (with sigma33 in plane strain)"},
    {"beta", Location::Point, Shape::Scalar, Source::State, Pad33::Zero, "1", "1",
     "adhesion intensity of each contact point, in [0, 1]"},
    {"e", Location::Point, Shape::Vector, Source::State, Pad33::Zero, "m", "m",
     "contact displacement of each contact point (the paper's h)"},
    {"lambda_c", Location::Point, Shape::Vector, Source::State, Pad33::Zero, "Pa", "Pa",
     "multiplier of u = e at each contact point: a traction per reference area (#points, dim)"},
    {"contact_pressure", Location::Point, Shape::Scalar, Source::Derived, Pad33::Zero, "Pa",
     "Pa", "contact pressure of each contact point, -lambda_c . N (> 0: pressed)"},
    {"gap", Location::Point, Shape::Scalar, Source::Derived, Pad33::Zero, "m", "m",
     "gap of each contact point to the obstacle plane, g - e . N"},
    {"reactions", Location::Support, Shape::Vector, Source::Derived, Pad33::None, "N/m", "N",
     "force each Dirichlet condition's support exerts on the body (#conditions, dim; plane "
     "strain: per metre of depth), in the order of the step's attribute `conditions` "
     "(lib/reactions.hpp)"},
    {"support_u", Location::Support, Shape::Vector, Source::Derived, Pad33::None, "m", "m",
     "mean displacement of the nodes of each Dirichlet condition (#conditions, dim)"},
    {"in_contact", Location::Point, Shape::Scalar, Source::Other, Pad33::None, "1", "1",
     "1 at the contact points in the contact set, p > kContactThreshold * max p "
     "(lib/measures.hpp), else 0"},
    {"history", Location::Step, Shape::Table, Source::Other, Pad33::None, "1 1 1 s s s s s",
     "1 1 1 s s s s s",
     "one row per iteration: n, r_G, r_B (scaled residuals, (3.3)), seconds in the global, "
     "strain, contact and update phases, wall seconds since the step began"},
};
// clang-format on

/// Whether the field is shown in ParaView as stored: scalars, and the 3-component shapes (the
/// others get a 3-vector / 3x3 copy in 2-D, under /xdmf/).
inline bool shown_as_stored(const Field& f) {
  return f.shape == Shape::Scalar || f.shape == Shape::Vector3 || f.shape == Shape::Tensor3;
}

/// The row named `name`, or null.
const Field* find_field(std::string_view name);
/// The row named `name`; an Error naming it (and `file`) when the table has none.
const Field& field(std::string_view name, const std::string& file);
/// The shape of a field as the layout table of experiments/README.md writes it, e.g.
/// "(#cells, dim, dim)" ("" for a Table).
std::string shape_text(const Field& f);
/// The unit as the layout table writes it: "m", or "m^2 (2-D), m^3".
std::string unit_text(const Field& f);
/// The table as the Python reader holds it (FIELDS in figures/ltl_results.py, between its
/// "BEGIN FIELDS" and "END FIELDS" lines).
std::string python_field_table();

}  // namespace ltl

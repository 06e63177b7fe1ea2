// Derived fields for the results files, computed in one place: the cell fields users read in
// ParaView (det F, principal stretches, von Mises), the Cauchy stress recovered at the nodes,
// and the contact pressure at the nodes of P2 triangle faces read consistently.
//
// Symbols: the paper's strain unknown F of (2.7) (F = I + grad u on each cell, written E in the
// code, the `E` dataset) is the deformation gradient; sigma = P F^T / det F the Cauchy stress.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "fe.hpp"
#include "mesh.hpp"

namespace ltl {

/// Per-cell and nodal derived fields of one state.
struct DerivedFields {
  Eigen::VectorXd detF;        ///< #cells, det F (1)
  Eigen::MatrixXd stretches;   ///< #cells x 3, principal stretches, decreasing (plane strain:
                               ///< the in-plane two and F33 = 1, sorted with them)
  Eigen::VectorXd von_mises;   ///< #cells, sqrt(3/2 s : s), s the deviator of the 3x3 sigma (Pa)
  Eigen::MatrixXd sigma_node;  ///< #nodes x 9, the 3x3 Cauchy stress at the nodes, row-major (Pa)
  Eigen::VectorXd von_mises_node;  ///< #nodes, von Mises of sigma_node (Pa)
};

/// The derived fields of the cell deformation gradients F (State::E layout: dim x dim blocks,
/// transposed) and Cauchy stresses sigma (same layout; plane strain: sigma33 per cell, else
/// empty). Nodal stress: the volume-weighted average of the cell stresses of the cells around
/// each node, sigma_a = sum_c |O_c| sigma_c / sum_c |O_c| (exact for a uniform stress).
/// Every cell's: cell_fields, then nodal_stress of nodal_stress_sums.
DerivedFields derived_fields(const Mesh& mesh, const Eigen::VectorXd& cell_volume,
                             const Eigen::MatrixXd& F, const Eigen::MatrixXd& sigma,
                             const Eigen::VectorXd& sigma33);

/// The cell fields (detF, stretches, von_mises; the nodal ones left empty) of the blocks of F and
/// sigma (and sigma33): every cell's, or some cells' in their order (a rank's rows), alike.
DerivedFields cell_fields(const Eigen::MatrixXd& F, const Eigen::MatrixXd& sigma,
                          const Eigen::VectorXd& sigma33);

/// The sums of the nodal stress average over the cells `cells` (sorted; null: every cell),
/// whose blocks sigma (and sigma33) and volumes cell_volume hold in that order (a rank's cells
/// with their volumes alone, CellOperators::vol), at the nodes first_node ..
/// first_node + count - 1 (count < 0: every node from first_node): count x 10, columns 0-8
/// sum_c |O_c| sigma_c (3x3, row-major), column 9 sum_c |O_c|. The sums of the ranks' cells add
/// up to the whole mesh's (one reduction), from which nodal_stress makes the average; a block of
/// nodes at a time, the writer holds that block's sums alone.
Eigen::MatrixXd nodal_stress_sums(const Mesh& mesh, const Eigen::VectorXd& cell_volume,
                                  const Eigen::MatrixXd& sigma, const Eigen::VectorXd& sigma33,
                                  const std::vector<int>* cells = nullptr, int first_node = 0,
                                  int count = -1);
/// The same on a part of the mesh (Discretization::part() of a rank's cells): its row k the k-th
/// cell of sigma and cell_volume, its node j the mesh's node node[j], of num_nodes in the mesh.
Eigen::MatrixXd nodal_stress_sums(const Mesh& part, const std::vector<int>& node, int num_nodes,
                                  const Eigen::VectorXd& cell_volume, const Eigen::MatrixXd& sigma,
                                  const Eigen::VectorXd& sigma33, int first_node, int count);

/// sigma_node (#nodes x 9) and von_mises_node from the sums of every cell (nodal_stress_sums;
/// of a block of nodes: those nodes' rows),
/// which become sigma_node in place (the column of weights dropped): no second nodal array.
void nodal_stress(Eigen::MatrixXd&& sums, DerivedFields& out);

/// von Mises stress sqrt(3/2 s : s) of a 3x3 Cauchy stress, s = sigma - tr(sigma)/3 I.
double von_mises(const Eigen::Matrix3d& sigma);

/// The nodal contact pressure read consistently from the contact forces f_a = w_a p_a (the
/// lumped weights w_a of nodal_points, the pressures p_a = -lambda_c . N): on six-node P2
/// triangle faces the consistent load of a pressure field p_h = sum_b p_b phi_b is
/// integral p_h phi_a, which for a uniform p is 0 at the vertices and p |G|/3 per face at the
/// mid-edge nodes, so f_a / w_a reads 0 and 4 p / 3 there. The pressure returned solves
/// M p = f, M the consistent P2 mass matrix of the contact surface (integral phi_a phi_b), and
/// reads a uniform pressure as uniform. Other facets (2-node and 3-node edges, 3-node triangles,
/// quadrilaterals), whose weights are the integrals of the shape functions: p unchanged.
/// `points` are the nodal contact points (points.nodes in the order of p).
Eigen::VectorXd consistent_nodal_pressure(const Mesh& mesh, const Mesh::Boundary& boundary,
                                          const ContactPoints& points, const Eigen::VectorXd& p);
/// The same with the areas of the boundary part's faces given (face_areas, made at the set-up):
/// what a rank reads after it has released the mesh's positions (Mesh::release_X); `mesh` gives
/// the number of nodes and the file's name.
Eigen::VectorXd consistent_nodal_pressure(const Mesh& mesh, const Mesh::Boundary& boundary,
                                          const Eigen::VectorXd& area, const ContactPoints& points,
                                          const Eigen::VectorXd& p);
/// The areas of a boundary part's faces when they are six-node P2 triangles whose nodes are the
/// nodal contact points `points` (those consistent_nodal_pressure reads, the area of the affine
/// face on its vertices), else empty.
Eigen::VectorXd face_areas(const Mesh& mesh, const Mesh::Boundary& boundary,
                           const ContactPoints& points);

}  // namespace ltl

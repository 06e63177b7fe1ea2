// The contact points of the contact surface Gamma_c and everything the solver knows of them, in
// one place: their weights, reference positions and (facet-mean points) facet vertices, the map
// from nodal values to point values, and the initial gap to the obstacle plane with its normal.
// Built by the discretization (fe.hpp: facet_mean_points, nodal_points; discretization.cpp: gap
// and N); read by the global step (4.5), the local contact step (contact_step.hpp, (6.1)-(6.8)),
// the kernel quadrature (adhesion_kernel.hpp), the Newton phase and the measures.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <vector>

namespace ltl {

using SpMat = Eigen::SparseMatrix<double>;
using SpMatR = Eigen::SparseMatrix<double, Eigen::RowMajor>;

/// The contact points of one contact surface: the facets of the boundary part
/// (discretization.contact = "facet-mean", the paper's P0 choice: one point per facet, its
/// value the facet mean) or its nodes ("nodal", the default: one point per node).
struct ContactPoints {
  int dim = 2;             ///< 2 or 3
  Eigen::VectorXd area;    ///< #points, weight |G_s|: facet measure, or integral of phi_a
  Eigen::MatrixXd centre;  ///< dim x #points, reference position x_s (facet centre or node)
  SpMatR mean;             ///< #points x #nodes, (mean * U).row(s) = ubar_s (facet mean or u_a)
  /// #nodes x #points, transpose of mean weighted by |G_s|: its row index is of every node.
  /// Empty on a discretization of some cells (a rank's, paper_notes/mpi.md), which keeps the same
  /// entries by point instead (meanT_area_by_point; meanT_area_of makes this matrix again).
  SpMatR meanT_area;
  /// The entries of meanT_area compressed by point (index of #points + 1, not of every node):
  /// held on a discretization of some cells only, else empty.
  SpMat meanT_area_by_point;
  /// Facet-mean points only, for the exact kernel integral: the corners of each point's facet
  /// (2 in 2-D, 3 (triangle faces) or 4 (quadrilateral faces, cyclic order) in 3-D), each
  /// dim x #points; empty for nodal points.
  std::vector<Eigen::MatrixXd> vertices;
  /// Nodal points only: the mesh node of each point; empty for facet-mean points.
  std::vector<int> nodes;
  Eigen::VectorXd gap;  ///< #points, initial gap g_s = (p0 - x_s) . N to the obstacle plane
  /// dim, unit normal of the obstacle plane, pointing into it. The points of several obstacles
  /// (Discretization::points()) have no one normal: empty there, read `normals`.
  Eigen::VectorXd N;
  /// #points x dim: row s is the unit normal N_k of the obstacle k of point s (every row N for
  /// the points of one obstacle). The constraint of point s is N_k . e_s <= g_s (4.11).
  Eigen::MatrixXd normals;
  /// The points of obstacle k are rows offset[k] .. offset[k + 1] - 1 ({0, #points} for one
  /// obstacle): the points of several obstacles are those of each, one after the other, so that
  /// a node of two obstacles' groups is two points, one per plane (paper_notes/obstacles.md).
  std::vector<int> offset;
  int size() const { return static_cast<int>(area.size()); }
  /// [(4.5), (4.1)] meanT_area: itself, or when only meanT_area_by_point is held the same matrix
  /// made from it into `work` (the same entries in the same order, so that its products are the
  /// whole discretization's to the bit): for the set-up and the step's end, not an iteration.
  const SpMatR& meanT_area_of(SpMatR& work) const {
    if (meanT_area.nonZeros() > 0 || meanT_area_by_point.nonZeros() == 0) return meanT_area;
    work = meanT_area_by_point;
    return work;
  }
  /// The number of obstacles whose points these are (1 for the points of one obstacle).
  int obstacles() const { return offset.empty() ? 1 : static_cast<int>(offset.size()) - 1; }
};

}  // namespace ltl

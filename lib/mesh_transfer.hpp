// A finite-element field of one mesh evaluated at points of another mesh of the same body (grid
// sequencing: the nested start of lib/nested_start.hpp, paper_notes/nested.md).
//
// Point location: a bucket grid over the cells' bounding boxes (about one cell per bucket), then
// per candidate cell the inverse of the isoparametric map x(xi) = sum_a N_a(xi) X_a by Newton's
// method (exact in one step on affine cells; a few steps on H8 and curved P2 cells). A point
// inside no cell (a node of a finer mesh on a curved boundary lies outside the coarse mesh's
// chords) gets the value of the closest cell at the clamped reference point, and the distance
// says by how much it was outside.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "mesh.hpp"

namespace ltl {

class PointLocator {
 public:
  /// The bucket grid of `mesh`'s cells (mesh must outlive the locator). Cells of any type of
  /// mesh.hpp: P2 triangles, P2 tetrahedra, H8.
  explicit PointLocator(const Mesh& mesh);

  /// Where a point is: its cell, the reference coordinates in it (first dim entries), and the
  /// distance from the point to x(xi) (0 up to round-off when inside, the reference point then
  /// in the reference cell up to 1e-10; outside every cell: xi clamped to the reference cell of
  /// the closest cell found). `size` is the diameter of the cell's bounding box, the scale
  /// against which a distance is small.
  struct Hit {
    int cell = -1;
    Eigen::Vector3d xi = Eigen::Vector3d::Zero();
    double distance = 0, size = 0;
    bool in_cell = false;
    bool inside() const { return in_cell; }
  };
  /// Locates x (dim entries): the containing cell among the cells whose boxes cover x's bucket,
  /// else the closest among those of the surrounding buckets (3^dim of them, widened until one
  /// holds a cell).
  Hit locate(const Eigen::VectorXd& x) const;
  /// The widening of a cell's box in the test of locate(), relative to its size: round-off for
  /// an H8 cell (trilinear: the cell lies in its nodes' convex hull), room for a P2 cell's curved
  /// edges beyond its nodes' box (a quarter of its size).
  static double box_margin(const Mesh& mesh) { return mesh.nodes_per_cell() == 8 ? 1e-9 : 0.25; }

  /// The value at `hit` of a nodal field (#nodes x k): sum_a N_a(xi) field(cell node a, :).
  Eigen::RowVectorXd evaluate(const Eigen::MatrixXd& field, const Hit& hit) const;

  const Mesh& mesh() const { return mesh_; }

 private:
  /// The reference point of cell c closest to x in the map's metric (Newton's iteration on
  /// x(xi) = x, projected onto the reference cell), and the distance |x(xi) - x|.
  Hit project(int c, const Eigen::VectorXd& x) const;
  int bucket(const Eigen::Vector3i& ijk) const;
  Eigen::Vector3i bucket_of(const Eigen::VectorXd& x) const;

  const Mesh& mesh_;
  int dim_;
  Eigen::Vector3d lo_ = Eigen::Vector3d::Zero(), h_ = Eigen::Vector3d::Ones();
  Eigen::Vector3i n_ = Eigen::Vector3i::Ones();  ///< buckets per direction (1 beyond dim)
  std::vector<int> start_, cells_;               ///< CSR: the cells of bucket b
  Eigen::VectorXd size_;                         ///< per cell, the diagonal of its box
  /// Per cell, its box widened by a margin (box_margin): a point outside it is not in the cell,
  /// so locate() projects onto the cells whose box holds the point first.
  Eigen::MatrixXd box_lo_, box_hi_;
};

}  // namespace ltl

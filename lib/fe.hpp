// Reference elements, quadrature, and the discrete operators of the mean-gradient formulation.
//
// [LTL87 (2.7), (3.3); paper_notes/section3-4.md] The constraint B is imposed on means:
//   Gbar_e(v) = (1/|O_e|) integral over cell e of grad v        (cell mean gradient)
//   vbar_s    = (1/|G_s|) integral over facet s of v            (facet mean)
// Both are linear in the nodal values and are stored as sparse matrices acting on the
// #nodes x dim matrix of nodal displacements, so that every per-iteration transfer between the
// nodes and the cells/facets is one sparse product.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <functional>
#include <vector>

#include "contact_points.hpp"
#include "mesh.hpp"

namespace ltl {

/// Cell operators. Moved, not copied, when a Discretization is handed to a Solver: Eigen 3.4's
/// SparseMatrix has no move constructor, so the moves swap the matrices (a copy would keep two
/// sets of them resident through the setup).
struct CellOperators {
  CellOperators() = default;
  CellOperators(const CellOperators&) = default;
  CellOperators& operator=(const CellOperators&) = default;
  CellOperators(CellOperators&& o) noexcept { swap(o); }
  CellOperators& operator=(CellOperators&& o) noexcept {
    swap(o);
    return *this;
  }
  void swap(CellOperators& o) noexcept {
    vol.swap(o.vol);
    cell.swap(o.cell);
    node.swap(o.node);
    std::swap(num_nodes, o.num_nodes);
    Gbar.swap(o.Gbar);
    GbarT_vol.swap(o.GbarT_vol);
    laplacian.swap(o.laplacian);
  }

  /// |O_e| of the held cells, in their order: vol(k) is cell cell[k]'s (vol(e) is cell e's
  /// when every cell is held). On a rank's cells their volumes alone (paper_notes/mpi.md); the
  /// whole mesh's are cell_volumes'.
  Eigen::VectorXd vol;
  /// The cells whose operators are held (sorted; every cell unless some were asked for): Gbar's
  /// row blocks, in this order.
  std::vector<int> cell;
  /// The nodes of Gbar's and the Laplacian's columns: empty when every cell is held (column i is
  /// node i); on some cells, the sorted nodes of those cells (column i is node node[i]): a
  /// rank's nodes numbered locally, as a distributed mesh numbers its part (paper_notes/mpi.md),
  /// so that no index of the operators is of the whole mesh's size.
  std::vector<int> node;
  int num_nodes = 0;  ///< the mesh's
  /// The operators' columns: #nodes, or on some cells the number of their nodes.
  int columns() const { return node.empty() ? num_nodes : static_cast<int>(node.size()); }
  /// (dim * #held) x columns(): row dim*k + j of Gbar * U is the j-th column of the mean
  /// gradient of cell e = cell[k], i.e. (Gbar * U)(dim*k + j, i) = mean of d u_i / d x_j over
  /// cell e (U: columns() x dim, row i the displacement of column i's node; k = e when every
  /// cell is held). On a rank's cells, its rows alone and its nodes' columns alone: no index of
  /// the other ranks' cells or nodes (paper_notes/mpi.md).
  SpMatR Gbar;
  /// #nodes x (dim * #cells): transpose of Gbar with rows weighted by |O_e|, so that
  /// GbarT_vol * T assembles sum_e |O_e| T_e : Gbar_e(v) for T: (dim*#cells) x dim, with
  /// T(dim*e + j, i) = (T_e)_{ij}.
  SpMatR GbarT_vol;
  /// columns() x columns(), the scalar Laplacian integral grad phi_a . grad phi_b (exact
  /// quadrature on affine P2 triangles and tetrahedra and on parallelepipeds).
  SpMat laplacian;
};

/// [(2.7), (3.3)] The operators of the cells `held` (sorted; null: every cell): Gbar has their
/// rows only, in their order (CellOperators::cell), and the Laplacian sums them only, both on
/// the columns of their nodes (CellOperators::node; a rank's cells in a distributed run,
/// paper_notes/mpi.md), and vol holds their volumes alone. GbarT_vol is built only when every
/// cell is held: on some cells it stays empty, and their forces go run by run (add_cell_forces).
CellOperators cell_operators(const Mesh& mesh, const std::vector<int>* held = nullptr);

/// [(2.7)] |O_e| = sum_q w_q of every cell (the quadrature of for_each_quadrature_point, summed
/// in the order in which cell_operators sums it: the same numbers as its vol), without the
/// operators: the whole mesh's volumes where a rank holds its cells' alone (the results file's
/// /mesh/cell_volume, the body's volume and centroid).
Eigen::VectorXd cell_volumes(const Mesh& mesh);

/// [(2.7), (4.1)] f += sum_e |O_e| T_e : Gbar_e(v) over the held cells at .. at + n - 1
/// (positions in CellOperators::cell: a run of a rank's cells), T their (dim n) x dim blocks,
/// scaled by |O_e| (vol(at + k)) in place: GbarT_vol T on those cells, from Gbar's rows dim at ..
/// dim (at + n) - 1 (on
/// a rank's cells T holds their rows only, and GbarT_vol is not built; paper_notes/mpi.md). The
/// force of Gbar's column i goes to row i of f, or with row_of to row row_of[i]: on some cells
/// f's row of the column's node (row_of = ops.node.data()), or a rank's right-hand side on its
/// ghost layer's rows (alg2_mpi.cpp).
void add_cell_forces(const CellOperators& ops, int n, int at, Eigen::Ref<Eigen::MatrixXd> T,
                     Eigen::MatrixXd& f, const int* row_of = nullptr);

/// [(2.7), (3.3)] T = Gbar u on the held cells at .. at + n - 1 (positions in CellOperators::cell;
/// T (dim n) x dim, transposed blocks like Gbar u). u whole (#nodes x dim): each column of Gbar
/// reads u's row of its node (CellOperators::node), so that the operators of some cells meet a
/// whole u without a copy of it on their columns; with row_of, column j reads u's row
/// row_of[j] (a rank's iterate on its ghost layer's rows, alg2_mpi.cpp).
void mean_gradients(const CellOperators& ops, int at, int n, const Eigen::MatrixXd& u,
                    Eigen::Ref<Eigen::MatrixXd> T, const int* row_of = nullptr);

/// [(2.7), (3.3)] The integrals over cell c of its shape functions' gradients grad_q (at the
/// quadrature points of for_each_quadrature_point, weights w_q): returns |O_c| = sum_q w_q, with
/// gint = sum_q w_q grad_q (#nodes_per_cell x dim) and L = sum_q w_q grad_q grad_q^T
/// (#nodes_per_cell square): the sums from which cell_operators builds Gbar and the Laplacian,
/// and Newton its per-cell mean gradient and fluctuation block. gint and L are resized.
double cell_integrals(const Mesh& mesh, int c, Eigen::MatrixXd& gint, Eigen::MatrixXd& L);

/// Calls visit(grad, w) at every quadrature point of cell c, with grad the physical gradients of
/// the shape functions (#nodes_per_cell x dim) and w the weight times |det J| (the rules used by
/// cell_operators): P2 triangle 6 points, degree 4; P2 tetrahedron 6 points, degree 3 (det of a
/// P2 gradient on an affine cell is cubic); H8 2x2x2 Gauss. For assembling other operators, e.g.
/// the elasticity matrix of section 7.
void for_each_quadrature_point(const Mesh& mesh, int c,
                               const std::function<void(const Eigen::MatrixXd&, double)>& visit);
/// The quadrature rule of for_each_quadrature_point on the reference cell of the mesh's cell
/// type: per point k, the gradients of the shape functions with respect to the reference
/// coordinates, dN[k] (#nodes_per_cell x dim), and the reference weight w[k]. On cell c, with Xe
/// its nodes' positions (#nodes_per_cell x dim) and J = Xe^T dN[k], the physical gradients are
/// dN[k] J^-1 and the weight w[k] det J: what for_each_quadrature_point visits, recomputed from
/// the coordinates instead of stored (8 points x 8 nodes x 3 doubles per H8 cell).
struct ReferenceRule {
  std::vector<Eigen::MatrixXd> dN;
  std::vector<double> w;
  int size() const { return static_cast<int>(w.size()); }
};
ReferenceRule reference_rule(const Mesh& mesh);

/// The shape functions of the mesh's cell type at the reference point xi (its first dim
/// entries): N (#nodes_per_cell) and their gradients with respect to the reference coordinates,
/// dN (#nodes_per_cell x dim), in the node order of Mesh::cells. Reference cells: the unit
/// triangle and tetrahedron (P2), the cube [-1, 1]^3 (H8). For the isoparametric map
/// x(xi) = Xe^T N(xi) at points other than the quadrature points (lib/mesh_transfer.hpp).
void reference_shape(const Mesh& mesh, const Eigen::Vector3d& xi, Eigen::VectorXd& N,
                     Eigen::MatrixXd& dN);

ContactPoints facet_mean_points(const Mesh& mesh, const Mesh::Boundary& boundary);

/// The contact "points" of a nodal (collocation) contact condition on a boundary part: one point
/// per node of the part, weight area(a) = integral over the part of phi_a (> 0 for P2 edges:
/// |G|/6 at the ends, 2|G|/3 at the mid-side node; |G|/4 per corner of a parallelogram face);
/// on P2 triangle faces, where integral phi_a = 0 at the vertices, the weights of the face split
/// into four 3-node triangles: |G|/12 per vertex, |G|/4 per mid-edge node,
/// centre = the node's reference position, mean = the selection u -> u_a (so that "vbar_s" is the
/// nodal value and meanT_area assembles sum_a area(a) c_a . v_a). No vertices: the exact kernel
/// integral is defined on facets only. Throws if a weight is not positive.
ContactPoints nodal_points(const Mesh& mesh, const Mesh::Boundary& boundary);

/// The contact points of a contact surface: nodal_points when `nodal`, else facet_mean_points.
inline ContactPoints contact_points(const Mesh& mesh, const Mesh::Boundary& boundary, bool nodal) {
  return nodal ? nodal_points(mesh, boundary) : facet_mean_points(mesh, boundary);
}

/// A vector field affine in the reference position: g(x) = value + gradient * x (first dim
/// entries used). Used for tractions and prescribed displacements.
struct AffineField {
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  Eigen::Matrix3d gradient = Eigen::Matrix3d::Zero();
  Eigen::Vector3d operator()(const Eigen::Vector3d& x) const { return value + gradient * x; }
};

/// Consistent nodal loads (#nodes x dim): integral over the cells of f . phi_a.
Eigen::MatrixXd body_load(const Mesh& mesh, const Eigen::Vector3d& f);
/// Consistent nodal loads (#nodes x dim): integral over the facets of g(x) . phi_a.
Eigen::MatrixXd surface_load(const Mesh& mesh, const Mesh::Boundary& boundary,
                             const AffineField& g);

}  // namespace ltl

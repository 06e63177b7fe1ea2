// The discrete problem, built once from a Problem and independent of how it is solved: the
// cell operators (mean gradients Gbar, volumes, Laplacian), the contact points with their
// initial gaps to the obstacle, the Dirichlet data, the consistent dead loads f and g, the split
// (2.5)-(2.6) of the energy between the global quadratic and the local steps, and, for mean-det
// incompressibility (2.7), the point gradients at the cell quadrature points.
//
// Nothing here depends on the augmentation R, q, q_c of ALG2: the solver (alg2.hpp) meets these
// operators with R q once, in its precompute.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <optional>
#include <vector>

#include "contact_points.hpp"
#include "fe.hpp"
#include "global_step.hpp"
#include "material.hpp"
#include "problem.hpp"
#include "state.hpp"

namespace ltl {

class Discretization {
 public:
  /// Validates the problem and builds every discrete operator; throws a clear Error naming the
  /// group, facet or node on inconsistent data (e.g. a contact point starting inside the plane).
  /// The problem is held here (problem()): moved in (std::move) or copied, its mesh included.
  explicit Discretization(Problem problem) : Discretization(std::move(problem), nullptr) {}
  /// The same with the cell operators (Gbar, the Laplacian; GbarT_vol is then not built) of the
  /// cells `held` only (sorted; null: every cell): a rank's cells in a distributed run
  /// (alg2_mpi.cpp, paper_notes/mpi.md), the rest of the discretization whole. Then the sums over
  /// cells (elastic_energy, energy_gradient, measures.cpp's equilibrium residual) add the held
  /// cells' parts over the MPI ranks, and are collective.
  Discretization(Problem problem, const std::vector<int>* held);

  const Problem& problem() const { return problem_; }
  /// [(2.7)] The held cells as a mesh of their own. On some cells (a rank's, partial()), the
  /// rank's part numbered locally, as a distributed mesh numbers its part (DMPlex's local
  /// numbering, deal.II's locally owned cells): its node j is the operators' column j (the mesh's
  /// node cells().node[j], X its reference position) and its row k the held cell
  /// held_cells()[k] on those nodes; it has no boundary parts. When every cell is held, the
  /// problem's mesh itself (node j and row e the mesh's). What reads a held cell's nodes or
  /// positions after the set-up reads them here, so that a rank can release the mesh's
  /// connectivity (release_mesh_cells).
  const Mesh& part() const { return partial_ ? part_ : problem_.mesh; }
  /// On some cells, per node of the part: 1 if a cell that is not held has it too (a node the
  /// rank shares with another rank's cells), from the whole mesh at the set-up; empty when every
  /// cell is held.
  const std::vector<char>& part_shared() const { return part_shared_; }
  /// The mesh's node of the part's node j.
  int part_node(int j) const { return partial_ ? cells_.node[j] : j; }
  /// The part's row of held cell `cell` at position `at` in held_cells().
  int part_row(int cell, int at) const { return partial_ ? at : cell; }
  /// On some cells, frees the problem's mesh connectivity (Mesh::release_cells; num_cells() is
  /// kept): a rank of a distributed run after its set-up (Solver, paper_notes/mpi.md). Nothing
  /// when every cell is held.
  void release_mesh_cells() {
    if (partial_) problem_.mesh.release_cells();
  }
  /// On some cells, frees the problem's mesh positions (Mesh::release_X; num_nodes() is kept):
  /// a rank of a distributed run that holds them on its part (part()) and its ghost layer's rows
  /// (IterateRows::X), after the set-up. Nothing when every cell is held.
  void release_mesh_X() {
    if (partial_) problem_.mesh.release_X();
  }
  /// Wall-clock seconds the constructor took (part of the run's setup time).
  double build_seconds() const { return build_seconds_; }
  int dim() const { return problem_.mesh.dim; }
  int num_cells() const { return problem_.mesh.num_cells(); }
  int num_nodes() const { return problem_.mesh.num_nodes(); }
  /// The cells whose operators this discretization holds (sorted); all of them unless
  /// partial().
  const std::vector<int>& held_cells() const { return cells_.cell; }
  bool partial() const { return partial_; }
  /// The first row of held cell `cell`'s block (dim rows) in a per-cell field like State::E:
  /// the field is whole (dim #cells rows, the cell's block at dim cell) or the held cells' rows
  /// (dim #held rows in the order of held_cells(), the cell's block at dim at, `at` its position
  /// there: the state between steps of a distributed solver, alg2.hpp). On a discretization of
  /// every cell the two coincide; on some cells their row counts tell them apart.
  Eigen::Index cell_row(const Eigen::MatrixXd& field, int cell, int at) const {
    return static_cast<Eigen::Index>(dim()) * (whole_field(field) ? cell : at);
  }
  /// |O_e| of held cell `cell`, at position `at` in held_cells() [(2.7)]: on a discretization of
  /// some cells (a rank's) only the held cells' volumes are kept (CellOperators::vol).
  double cell_volume(int cell, int at) const { return cells_.vol(partial_ ? at : cell); }
  /// Is a per-cell field (State::E, lambda) whole, dim #cells rows (not the held cells' rows)?
  bool whole_field(const Eigen::MatrixXd& field) const {
    return field.rows() == static_cast<Eigen::Index>(dim()) * num_cells();
  }

  /// The material as split between the global and the local steps (2.5)-(2.6):
  /// problem().material, except that in plane strain with DiscretizationChoice::c2_pointwise the
  /// incompressible C2 term is moved into C1 (C1 + C2, C2 = 0), an identity on det F = 1.
  /// P = 2 split().C1 E - lambda.
  const Material& split() const { return split_; }
  const CellOperators& cells() const { return cells_; }
  /// u (#nodes x dim) on the cell operators' columns (CellOperators::node), for Gbar u and L u:
  /// u itself when every cell is held, else its rows of the held cells' nodes, copied into
  /// `work` (resized; no allocation when it has that size already). With u_row, u is not whole:
  /// column j's node is at its row u_row[j] (a rank's iterate on its ghost layer's rows).
  const Eigen::MatrixXd& on_columns(const Eigen::MatrixXd& u, Eigen::MatrixXd& work,
                                    const int* u_row = nullptr) const;
  /// The contact points: facets (discretization.contact = "facet-mean") or the nodes of the
  /// contact surface ("nodal"), with their weights, positions, the map from nodal values (mean)
  /// and the initial gap g_s = (p0 - x_s) . N >= 0 of each to the obstacle plane (section 6);
  /// null without contact.
  /// Several obstacles ([[contact]], paper_notes/obstacles.md): the points of each obstacle,
  /// one after the other (ContactPoints::offset, ContactPoints::normals), a node of two groups
  /// being one point of each; the global step (4.5) sums R q_c M^T |G| M over all of them.
  const ContactPoints* points() const {
    return obstacles_.size() == 1 ? &obstacles_.front() : points_ ? &*points_ : nullptr;
  }
  /// The contact points of obstacle k alone (problem().contacts[k]), with its plane's normal N
  /// and gaps: rows points()->offset[k] .. offset[k + 1] - 1 of points(). Empty without contact.
  const std::vector<ContactPoints>& obstacle_points() const { return obstacles_; }
  int num_obstacles() const { return static_cast<int>(obstacles_.size()); }
  /// N_k . v_s per contact point s (v: #points x dim, e.g. e or lambda_c), N_k the normal of the
  /// obstacle of s.
  Eigen::VectorXd normal_component(const Eigen::MatrixXd& v) const;
  /// Per component, the sorted nodes whose displacement is prescribed, and their values.
  const DirichletData& dirichlet() const { return bc_; }
  /// The consistent dead loads f (body force) and g (tractions) at load factor 1, #nodes x dim
  /// [LTL87 (1.2)]: a new array, made from the loaded nodes' rows (below). An Error once the
  /// loads of other nodes than the rank's have been released (keep_loads).
  Eigen::MatrixXd dead_load() const;
  /// The dead loads as held: the loaded nodes (sorted: those whose row of dead_load() is not
  /// zero, a traction's surface nodes when there is no body force) and their rows, so that a
  /// dead load on a surface takes memory per surface node (paper_notes/mpi.md). After
  /// keep_loads, those of the kept nodes alone.
  const std::vector<int>& loaded_nodes() const { return loaded_; }
  const Eigen::MatrixXd& loaded_rows() const { return F_loaded_; }
  /// max |dead_load()|, the largest nodal dead load (0 without loads), kept by keep_loads.
  double largest_dead_load() const { return largest_dead_load_; }
  /// [(1.2)] f += scale x dead_load() (f: #nodes x dim), without a whole array. An Error after
  /// keep_loads, like dead_load().
  void add_dead_load(Eigen::MatrixXd& f, double scale) const;
  /// On some cells, keeps the dead loads of the nodes n0 .. n1 - 1 (a rank's block of the
  /// nodes, whose equilibrium residual it sums) and of the nodes `owned` (sorted: those whose
  /// loads it adds into the right-hand side) alone: a rank of a distributed run after its set-up,
  /// so that a body force's loads, on every node, are not held whole on every rank
  /// (paper_notes/mpi.md). Nothing when every cell is held.
  void keep_loads(int n0, int n1, const std::vector<int>& owned);
  /// Identity blocks, (dim * #cells) x dim, the transposed-block layout of E and lambda (made
  /// on demand: not stored).
  Eigen::MatrixXd identity() const { return identity_rows(dim(), num_cells()); }
  /// |O_e| repeated on the dim rows of each held cell (every cell unless partial(); made on
  /// demand).
  Eigen::VectorXd volume_rows() const;
  double volume() const { return volume_; }  ///< |Omega|, of every cell also when partial()
  double contact_area() const { return contact_area_; }  ///< |Gamma_c| (0 without contact)

  /// True when incompressibility is imposed on the cell mean of det F
  /// (DiscretizationChoice::mean_det: incompressible with no C2 term left in the local step,
  /// i.e. plane strain with the pointwise C2 split, or C2 = 0 in 3-D).
  bool mean_det() const { return mean_det_; }
  static constexpr int kMaxPoints = 27;  ///< quadrature points per cell (mean-det), at most
  /// [(2.7), discretization.md] Mean-det incompressibility: with delta = grad u - Gbar_e u the
  /// intra-cell fluctuation, (1/|O_e|) integral det F = det(Fbar_e) + c_e(u) with
  ///   c_e = (1/|O_e|) integral det F - det(Fbar_e)   (= the mean of det(delta) in 2-D),
  /// and the pressure p_e of the constraint does the extra work
  /// p_e integral (cof F - cof Fbar) : grad v (= p_e integral cof(delta) : grad v in 2-D).
  /// Returns c_e per held cell, in the order of held_cells() (c(at); c(e) when every cell is
  /// held); zeros when !mean_det(). u whole, or with u_row on some cells column j's node at
  /// u's row u_row[j] (fluctuation's row_of: a rank's iterate on its ghost layer's rows).
  Eigen::VectorXd fluctuation_det(const Eigen::MatrixXd& u, const int* u_row = nullptr) const;
  /// The force sum_e p_e integral_e (cof F - cof Fbar) : grad v (#nodes x dim) with p_e read
  /// from the multiplier, p_e = lambda_e : E_e / (d det E_e) (lambda = p cof E at a fixed point,
  /// cof E : E = d det E); zero when !mean_det(). ALG2 adds it, lagged, to the right-hand side
  /// of (4.1). When partial(): the held cells' part summed over the MPI ranks (collective), E
  /// and lambda whole or on the held cells' rows (cell_row).
  Eigen::MatrixXd fluctuation_force(const State& s) const;
  /// The allocation-free kernel of the two above (after its first call): c (#cells) and/or
  /// force (#nodes x dim, added to, not overwritten) at u, with p_e from lambda and E when force
  /// is wanted. With gamma, force also gains gamma (L - GbarT_vol Gbar) u, the energy of the
  /// intra-cell fluctuation of grad u (mean-det's proximal term, alg2.cpp), cell by cell. On the
  /// cells `cells` (sorted; null: the held cells, all unless partial(), where `cells` must be the
  /// held cells' list, whose volumes alone are kept; a rank's cells when distributed,
  /// alg2_mpi.cpp): then the
  /// k-th cell's rows of lambda and E are the k-th block and its c is c(k). Node i's u is row i
  /// of u and its force goes to row i of force, or with row_of both are row row_of[j], j the
  /// column of node i in the cell operators (i itself when every cell is held,
  /// CellOperators::node; on some cells `cells` must be the held cells' list): a rank's iterate
  /// and right-hand side on its ghost layer's rows (alg2_mpi.cpp).
  void fluctuation(const Eigen::MatrixXd& u, const Eigen::MatrixXd* lambda,
                   const Eigen::MatrixXd* E, Eigen::VectorXd* c, Eigen::MatrixXd* force,
                   double gamma = 0, const std::vector<int>* cells = nullptr,
                   const int* row_of = nullptr) const;

  // Outputs at a state, per cell (transposed-block layout like E) or per contact point. The cell
  // outputs are per block of s.E: every cell's (E whole), or the held cells' in their order (E
  // on their rows, a rank's state between steps), computed alike.
  /// First Piola-Kirchhoff stress P = 2 C1 E - lambda (in-plane block in plane strain).
  Eigen::MatrixXd piola(const State& s) const;
  /// Cauchy stress sigma = P E^T / det E (in-plane block in plane strain).
  Eigen::MatrixXd cauchy(const State& s) const;
  /// Every stress of a state per cell, one definition each: P and sigma (above), in plane
  /// strain the out-of-plane Cauchy stress sigma33 from the law with F33 = 1 (1.5)
  /// (Material::plane_strain_sigma33 of the problem's material, not of the split one), and the
  /// pressure, the mean stress p = -tr(sigma) / 3 of the three-dimensional stress (in plane
  /// strain -(sigma11 + sigma22 + sigma33) / 3). sigma33 is empty in 3-D.
  struct Stresses {
    Eigen::MatrixXd P, sigma;  ///< transposed-block layout like E
    Eigen::VectorXd sigma33, pressure;
  };
  Stresses stresses(const State& s) const;
  /// Nominal contact pressure per contact point, p_c = -lambda_c . N_k (Pa; > 0 where the body
  /// presses): the one definition, which the measures (lib/measures.hpp) use. With nodal contact
  /// on P2 triangle faces, read consistently from the point forces (derived_fields.hpp:
  /// consistent_nodal_pressure), so that a uniform pressure reads uniform.
  Eigen::VectorXd contact_pressure(const State& s) const;
  /// The force of each contact point, |G_s| (-lambda_c_s . N) (N/m in 2-D, N).
  Eigen::VectorXd contact_forces(const State& s) const;
  /// Gap to the plane after deformation per contact point: g_s - e_s . N (>= 0 when admissible).
  Eigen::VectorXd contact_gap(const State& s) const;
  /// Gradient (#nodes x dim, zero on fixed components) of the reduced discrete energy
  ///   Pi(u) = sum_e |O_e| W(I + Gbar_e u) + C1 (||grad u||^2 - sum_e |O_e| |Gbar_e u|^2)
  ///           - F . u
  /// for the compressible law without contact, F the load: zero at the discrete equilibrium.
  Eigen::MatrixXd energy_gradient(const Eigen::MatrixXd& u, const Eigen::MatrixXd& F) const;
  /// [(2.7), (4.1)] The nodal forces 2 C1 L u + sum_e |O_e| T_e : Gbar_e over the held cells,
  /// summed over the MPI ranks when partial() (collective): run by run through add_cell_forces,
  /// with no per-cell array of the whole mesh. `stress(c0, n, at, T)` turns T, Gbar u on the
  /// cells c0 .. c0 + n - 1 ((dim n) x dim, at `at` in held_cells()), into their T_e in place.
  /// The sum over cells of energy_gradient and of measures.cpp's equilibrium residual on a
  /// rank's cells.
  /// With `less_fluctuation` (mean-det; its E and lambda whole or on the held cells' rows): less
  /// those cells' fluctuation_force, before the one sum over the ranks (no second #nodes x dim
  /// array, no second reduction).
  Eigen::MatrixXd held_cell_forces(
      const Eigen::MatrixXd& u,
      const std::function<void(int c0, int n, int at, Eigen::MatrixXd& T)>& stress,
      const State* less_fluctuation = nullptr) const;
  /// The same before the sum over the ranks: the held cells' part alone, on the operators'
  /// columns (row j the force at node cells().node[j]; at node j when every cell is held). What
  /// a rank adds to the blocks of the nodes (mpi::sum_rows_to_blocks, measures.cpp's
  /// equilibrium_residual_rows) without an array of every node. With u_row, u holds column j's
  /// node at row u_row[j] (a rank's iterate on its ghost layer's rows, alg2_mpi.cpp), else u is
  /// whole; so does less_fluctuation's.
  Eigen::MatrixXd held_cell_forces_on_columns(
      const Eigen::MatrixXd& u,
      const std::function<void(int c0, int n, int at, Eigen::MatrixXd& T)>& stress,
      const State* less_fluctuation = nullptr, const int* u_row = nullptr) const;
  /// The elastic and load part of the discrete functional J_p (2.2) at a state, load F:
  ///   sum_e |O_e| W(E_e) + C1 (||grad u||^2 - sum_e |O_e| |Gbar_e u|^2) - F.u
  /// (F empty: without the load's term).
  double elastic_energy(const State& s, const Eigen::MatrixXd& F) const;
  /// Has keep_loads dropped the loads of other nodes than the rank's?
  bool loads_kept() const { return loads_kept_; }

 private:
  Problem problem_;
  bool partial_ = false;
  Mesh part_;                      ///< on some cells, the held cells' mesh (part())
  std::vector<char> part_shared_;  ///< on some cells, part_shared()
  Material split_;
  CellOperators cells_;
  std::optional<ContactPoints> points_;  ///< several obstacles only: their points stacked
  std::vector<ContactPoints> obstacles_;
  /// Per obstacle, its contact group's face areas on P2 triangle faces with nodal points
  /// (face_areas: what contact_pressure reads), else empty
  std::vector<Eigen::VectorXd> face_area_;
  DirichletData bc_;
  std::vector<int> loaded_;
  Eigen::MatrixXd F_loaded_;
  double largest_dead_load_ = 0;
  bool loads_kept_ = false;  ///< keep_loads has dropped other nodes' loads
  double volume_ = 0, contact_area_ = 0, build_seconds_ = 0;
  // Mean-det: the reference rule of the cell type (the point gradients are recomputed per cell
  // from the nodes' positions), and the work buffers of the nodal forces of a block of cells and
  // of their nodes' rows (with a row map, fluctuation).
  bool mean_det_ = false;
  int nq_ = 0;
  ReferenceRule rule_;
  mutable std::vector<double> buffer_;
  mutable std::vector<int> rows_;
};

}  // namespace ltl

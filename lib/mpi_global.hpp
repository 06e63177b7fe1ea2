// The global step (4.1), i.e. the linear problem (4.5), as ONE distributed PETSc KSP over the MPI
// ranks (lib/mpi_comm.hpp): conjugate gradients preconditioned by smoothed-aggregation AMG
// (GAMG), or MUMPS's Cholesky, on an MPIAIJ matrix whose contiguous blocks of rows the ranks own;
// each rank adds its cells' part of K (or, given the whole K, its own rows), the hierarchy or
// the factor set up once per Dirichlet set (like the serial factor, global_step.hpp), with the
// near-null space of cg_amg.hpp (the constants and the centred coordinates, orthonormalized).
//
// CG + GAMG's solves are inexact like the serial CG + AMG's (cg_amg.hpp): warm-started from the
// previous iterate, each stops at ||b - K x|| <= max(eta ||b - K x0||, CgAmg::kFloor ||b||)
// (CgAmg::target; eta CgAmg::kEta or -ltl_cg_eta), and the converged state is the exact step's.
// With the PETSc option -ltl_mpi_rtol R (PETSC_OPTIONS) every solve is converged to
// ||b - K x|| <= R ||r0|| instead (kRtol = 1e-12 in the tests), so that the distributed ALG2
// follows the serial (Cholesky) iterates, iteration by iteration, to about 1e-10: the same
// iteration counts and the same answer (tests/mpi_ranks.cpp). Until 2026-12-03 that tight
// tolerance was the only one (paper_notes/mpi.md, "The distributed CG + GAMG, inexact").
//
// By default (the first slice of the distribution, paper_notes/mpi.md) the right-hand side and
// u are whole arrays on every rank: b is the same on every rank, a rank copies its rows in,
// solves, and the solution's row blocks are gathered back to every rank (mpi::gather). With a
// ghost layer (set_ghost_layer: the rank's cells' and points' nodes) b and u are on the layer's
// rows: each rank's b holds its own cells' and points' part only, added into PETSc's vector row
// by row (the rows of other ranks travel at the assembly), and u is brought back on the layer's
// rows only (a VecScatter of its ghosts; the Dirichlet values imposed on its fixed nodes): no
// O(#nodes) message or array; whole_u makes u whole when a whole u is wanted.
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "contact_points.hpp"
#include "global_step.hpp"
#include "mesh.hpp"
#include "mpi_comm.hpp"

namespace ltl {

/// The cells dealt to `ranks` ranks in slabs along the mesh's longest extent (equal counts, in
/// the order of their centroids' coordinate, stable), each rank's sorted: a coordinate
/// partition, the ranks' cells until 2026-12-02 (now the PETSc option -ltl_mpi_slabs).
mpi::Partition slab_cells(const Mesh& mesh, int ranks);

/// The cells' dual graph in compressed rows: cell c's neighbours, the cells that share a facet
/// with it (Mesh::nodes_per_facet nodes), are next[start[c]] .. next[start[c + 1] - 1], sorted.
struct DualGraph {
  std::vector<int> start, next;
};
/// Built in two passes (counts, then rows), with no list per cell (a vector of vectors until
/// 2026-12-03, copied into these rows for the partition: the same peak, 1.2 million more
/// allocations at 10^5 cells; paper_notes/mpi.md, "The dual graph in compressed rows").
DualGraph facet_neighbours(const Mesh& mesh);

/// From this many ranks on, graph_cells partitions in two levels when it can (mpi_global.cpp,
/// scotch_parts): PT-Scotch's work grows with the parts (721 MB on rank 0 for 1024 parts of
/// 10^6 cells in one level).
constexpr int kTwoLevelParts = 512;

/// The cells dealt to `ranks` ranks by a graph partitioner: PT-Scotch, through PETSc's
/// MatPartitioning, on the cells' dual graph (facet_neighbours), which cuts few facets between
/// the ranks whatever the body's shape (slabs cut a compact body's every slab face), each rank's
/// sorted. From kTwoLevelParts ranks on, when ranks = g m (2 <= g <= m), in two levels: g groups,
/// then m parts of each (the PETSc option -ltl_mpi_two_level_parts sets the threshold). Collective
/// over MPI_COMM_WORLD: rank 0 partitions the whole graph and sends the parts (or its error) to the
/// others, so that the same mesh gives the same partition on any number of processes. One rank:
/// every cell. Several ranks without MPI (a build without LTL_WITH_MPI), or a part with no cell: an
/// Error.
mpi::Partition graph_cells(const Mesh& mesh, int ranks);

/// The partition's cut: the facets between cells of two ranks. The ghost layer's nodes and the
/// off-rank columns of the distributed matrices lie on them.
long cut_facets(const Mesh& mesh, const mpi::Partition& cells);

/// The ranks' cells of a distributed solver: graph_cells, or slab_cells with the PETSc option
/// -ltl_mpi_slabs. Collective.
mpi::Partition cell_partition(const Mesh& mesh, int ranks);

/// The rank whose block of rows of the distributed matrices holds each node: the smallest of the
/// ranks whose cells hold it (rank 0 for a node in no cell). A rank's part of K (4.5), added
/// over its cells, then falls in its own rows but on the nodes it shares with lower ranks.
std::vector<int> node_ranks(const Mesh& mesh, const mpi::Partition& cells);

/// [(4.7), (4.3)] The ranks' contact points: point s on the smallest rank among those whose
/// cells hold every node of s (the cell of its facet for a facet-mean point; for a nodal point,
/// the node's rank of node_ranks), so that a rank's points add no node outside its cells to its
/// ghost layer (when the contact step is distributed). Each rank's sorted. An Error when no cell
/// holds every node of a point (a point must lie on one cell's facet or node).
mpi::Partition point_partition(const Mesh& mesh, const ContactPoints& points,
                               const mpi::Partition& cells);

class DistributedGlobalStep {
 public:
  /// The tight -ltl_mpi_rtol with which the distributed ALG2 follows the serial iterates (the
  /// tests' TightCg).
  static constexpr double kRtol = 1e-12;
  /// CG iterations per solve before the solve is an Error (a preconditioner that fails).
  static constexpr int kMaxIterations = 5000;
  /// CG + GAMG, or MUMPS's distributed Cholesky factorization (computed once, in the
  /// constructor; each solve is its forward and backward substitution: exact like the serial
  /// factor), or Auto: the serial rule of GlobalSolver::Auto (global_step.hpp) with MUMPS's
  /// analysis in place of CHOLMOD's. MUMPS's factor unless the matrix has more than
  /// GlobalStep::kAutoMinRows rows and MUMPS's analysis of the first Dirichlet set predicts
  /// more than GlobalStep::kAutoFactorBytes for its factorization on its most loaded rank
  /// (INFOG(16)) x the Dirichlet sets, plus newton_dim^2 x it with a Newton phase (its tangent's
  /// factor, global_step.hpp); then CG + GAMG, for every set. The PETSc options -ltl_mpi_auto_rows
  /// and -ltl_mpi_auto_bytes replace the two limits (for the tests). solver() tells the choice.
  enum class Solver { CgGamg, Mumps, Auto };

  /// K: the whole (replicated) matrix of (4.5), or with `parts` this rank's part of it (the
  /// sum over its cells, Discretization of some cells): the parts of the ranks add up to K,
  /// and no rank holds the whole. bc: the Dirichlet sets (held by reference: it must outlive
  /// this object, as the Solver's discretization does); X_own: the reference coordinates of the
  /// nodes this rank owns (node_rank), in increasing order (the near-null space, made on the
  /// rank's rows). Collective over MPI_COMM_WORLD. Throws Error without MPI
  /// (a build without LTL_WITH_MPI) or when PETSc fails. K is consumed: released (swapped out,
  /// the caller's left empty) once it is in PETSc's matrices, before the last AMG setup or
  /// factorization. (Eigen 3.4's SparseMatrix has no move constructor: a K taken by value from
  /// std::move would be a copy, and the caller's K would stay through every setup.)
  /// node_rank (#nodes; node_ranks of the ranks' cells): the rank whose block of rows holds each
  /// node, the nodes in their index order within a rank's block.
  DistributedGlobalStep(SpMat&& K, const DirichletData& bc, const Eigen::MatrixXd& X_own,
                        const std::vector<int>& node_rank, Solver solver = Solver::CgGamg,
                        bool parts = false, int newton_dim = 0);
  ~DistributedGlobalStep();
  DistributedGlobalStep(const DistributedGlobalStep&) = delete;
  DistributedGlobalStep& operator=(const DistributedGlobalStep&) = delete;

  /// [LTL87 (4.1), (4.5)] K u = b with u = value_scale x value on the fixed nodes; b whole on
  /// every rank, u in: the warm start, out: the solution, whole on every rank. Collective.
  /// With a ghost layer: b is this rank's part on the layer's rows (#layer x #components, row k
  /// node nodes[k]; the parts of the ranks add up to the right-hand side), and so is u (in: the
  /// warm start, out: the solution on the layer's nodes, which hold the rank's own rows). An
  /// empty u starts from 0; a u of other rows or columns than b's is an Error.
  void solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& u);
  /// The ghost layer: `nodes` (sorted, distinct) are the nodes whose rows of b this rank
  /// fills and of u it reads (b's and u's rows, in this order: its cells' and contact points'
  /// nodes); they must hold the rank's own rows (node_rank). Collective.
  void set_ghost_layer(std::vector<int> nodes);
  bool ghost_layer() const { return ghost_layer_; }
  /// The ghost layer's nodes (empty without one).
  const std::vector<int>& layer_nodes() const { return layer_node_; }
  /// With a ghost layer: u on the layer's rows made whole (#nodes x #components) on every rank,
  /// the ranks' own rows gathered and the fixed nodes' values imposed. Without: unchanged.
  /// Collective.
  void whole_u(Eigen::MatrixXd& u);

  void set_value_scale(double s) { scale_ = s; }
  double value_scale() const { return scale_; }
  int num_sets() const { return static_cast<int>(groups_.size()); }
  Solver solver() const { return solver_; }
  /// With Solver::Auto above the rows' limit: the bytes MUMPS's analysis predicted for its
  /// factorization on its most loaded rank (INFOG(16)), the same on every rank; else -1 (no
  /// analysis was made for the choice).
  double predicted_factor_bytes() const { return predicted_bytes_; }
  /// With MUMPS: the bytes its factorizations of every Dirichlet set allocated on their most
  /// loaded rank (the sum of each factor's INFOG(18)), the same on every rank; 0 with CG + GAMG.
  double factor_bytes() const;

  /// Since construction: KSP iterations and solves, AMG setup seconds; seconds in KSPSolve and
  /// in the gather of u.
  long iterations() const { return iterations_; }
  long solves() const { return solves_; }
  double setup_seconds() const { return setup_seconds_; }
  double ksp_seconds() const { return ksp_seconds_; }
  /// Ghost values a rank's row block needs in a product with K (the fine level's message size
  /// per matrix-vector product, summed over the Dirichlet sets, this rank).
  long ghosts() const { return ghosts_; }
  /// The ghost layer's rows held by other ranks (set_ghost_layer: the nodes this rank adds into
  /// and reads, less its own rows), summed over the Dirichlet sets: what one solve's scatter of u
  /// brings to this rank, and its addition of b sends, per component.
  long layer_ghosts() const;
  /// This rank's rows, summed over the Dirichlet sets (its nodes of node_rank).
  long owned_rows() const;
  /// One Dirichlet set on this rank: its components, free rows (of the mesh), owned rows, the
  /// ghost layer's rows of other ranks, and the bytes of this rank's own arrays for it (its rows'
  /// nodes and shifts, the layer's rows, nodes and values; not PETSc's): O(owned + ghost rows).
  /// Without a ghost layer a solve gathers u whole, and from the first one the set keeps the
  /// node list and a buffer of #free rows for it.
  struct SetShare {
    int components = 0;
    long free_rows = 0, owned = 0, ghosts = 0;
    double bytes = 0;
  };
  std::vector<SetShare> set_shares() const;
  /// GAMG's coarse operators (the levels below A, summed over the Dirichlet sets; 0 with MUMPS);
  /// with_products (optional): those that still hold the data of the product P^T A P that made
  /// them (none once the hierarchy is built: release_coarse_products, mpi_global.cpp).
  int coarse_operators(int* with_products = nullptr) const;

 private:
  struct Group;
  std::vector<std::unique_ptr<Group>> groups_;
  const DirichletData& bc_;  ///< the caller's (the Solver's discretization): not copied
  Solver solver_;
  double predicted_bytes_ = -1;
  double scale_ = 1;
  double rtol_ = 0;  ///< -ltl_mpi_rtol's: every CG + GAMG solve to it (tight), else 0
  double eta_ = 0;   ///< else the inexact solves' eta (CgAmg::eta_option)
  bool ghost_layer_ = false;
  int num_nodes_ = 0;            ///< the mesh's nodes (the rows of u without a ghost layer)
  std::vector<int> layer_node_;  ///< with a ghost layer, the nodes of the rows of b and u
  /// With a ghost layer, per component i: (the layer's row, k) of each fixed node fixed[i][k]
  /// in the layer (the Dirichlet values of u's rows)
  std::vector<std::vector<std::pair<int, int>>> layer_fixed_;
  long iterations_ = 0, solves_ = 0, ghosts_ = 0;
  double setup_seconds_ = 0, ksp_seconds_ = 0;
};

}  // namespace ltl

// ALG2 [LTL87 (4.1)-(4.4)] distributed over the MPI ranks (Solver with Ranks::All; an MPI build,
// lib/mpi_comm.hpp). The first slice of the distribution (paper_notes/mpi.md):
//
//   - PARTITIONED (Solver(Problem, Ranks::All), plain ALG2 or with the Newton phase): the cell
//     operators. Each rank discretizes its own cells only, its part of the cells' dual graph
//     by PT-Scotch (cell_partition, mpi_global.hpp; slabs with -ltl_mpi_slabs; Discretization
//     of some cells: Gbar and the Laplacian of its cells, on the columns of their nodes,
//     CellOperators::node) and assembles its part of K (4.5), which the distributed KSP sums
//     (MatSetValues ADD_VALUES): no rank holds the whole K. The sums over cells of the measures
//     (equilibrium residual, energy) add the ranks' parts. The Newton phase holds its own
//     per-cell data for its cells (newton.hpp). With the replicated factor, the
//     whole discretization on every rank.
//   - REPLICATED: the mesh's boundary parts (its connectivity is released after the set-up,
//     each rank reading its cells on its own part, Discretization::part(), unless the Newton
//     phase; its positions X too when u is on the ghost layer's rows, which then carry X,
//     IterateRows::X), the per-node dense arrays, the contact points' fields, and u in the
//     Newton phase (and without a ghost layer). Every rank reads the whole problem. The whole E and
//     lambda exist only between ALG2 phases (for the Newton phase, the measures and the output) and
//     when the equilibrium stopping test is due; the iterations run on the rank's rows of E and
//     lambda (own_rows, whole), and so do T, Gbar u, J and the previous E. Anderson's packed
//     iterate is the rank's cell rows and its contact points' rows (every point when the contact
//     step is replicated, then in the replicated tail): its inner products sum the distributed head
//     over the ranks. The states the load subdivision keeps to go back to are the rank's rows and
//     its layer's rows of u (kept_copy); the checks after a step run on the rank's cells and the
//     nodes it owns (lib/admissibility.cpp).
//   - DISTRIBUTED: the cells (the partition above) and the contact points (each on the smallest
//     rank whose cells hold all its nodes, point_partition in mpi_global.hpp). A rank computes, on
//     its own cells and points: the global step's per-cell right-hand side Gbar^T [R q (E - I) +
//     lambda - 2 C1 I] and the contact one M^T [R q_c e + lambda_c] (4.1), the mean-det fluctuation
//     terms and targets, Gbar u and ubar; the strain step (4.6); the contact step (4.7) when the
//     points are independent (d0 = 0); the update (4.3) and the residual sums (4.4). The global
//     solve (4.5) is one distributed PETSc KSP (mpi_global.hpp) on a ghost layer: the ranks' parts
//     of the right-hand side are added into PETSc's vector and u comes back on the layer's rows:
//     the iterate's u is on those rows through the phase (own_rows) and, since 2026-12-05,
//     between steps too (between_steps; state_rows for the measures, the reactions and the
//     admissibility check, nodes_to_writer for the writer, whole_u for the Newton phase and
//     whole_state); with mean-det under Anderson, or the
//     PETSc option -ltl_mpi_no_ghosts, the right-hand side is summed (one Allreduce of #nodes x
//     dim) and u gathered whole; with -ltl_mpi_replicated the serial factor on every rank
//     (replicated). The residual parts are summed (3 values); the step's equilibrium residual
//     (4.5), its stopping test (at the iterate's rows on a ghost layer) and the reactions on the
//     ranks' blocks of the nodes (equilibrium_residual_rows, measures.hpp). The points' e,
//     lambda_c and beta are gathered once, at the end of the phase (and E, lambda and u without
//     a ghost layer).
//   - With a dissipative glue (d0 > 0) the contact step is a Gauss-Seidel sweep whose points are
//     coupled by the kernel (6.5): sequential, it runs whole on every rank (replicated).
#include <algorithm>
#include <cmath>
#include <optional>

#include "alg2.hpp"
#include "error.hpp"
#include "measures.hpp"
#include "mpi_comm.hpp"
#include "mpi_global.hpp"

namespace ltl {

struct Solver::Distribution {
  mpi::Partition cells;         ///< the ranks' cells (cell_partition)
  std::vector<int> own;         ///< this rank's cells, sorted
  mpi::Partition points;        ///< the ranks' contact points (point_partition)
  std::vector<int> own_points;  ///< this rank's points, sorted
  std::vector<int> nodes;       ///< the ranks' blocks of nodes (mpi::blocks)
  int n0 = 0, n1 = 0;
  bool contact_replicated = false;
  bool use_ksp = true;  ///< false: the serial factor on every rank
  DistributedGlobalStep::Solver ksp_solver = DistributedGlobalStep::Solver::Mumps;
  /// With a ghost layer (its nodes ksp->layer_nodes(), sorted: the rows of the right-hand side
  /// and of the iterate's u, the rank's cells' and points' nodes): the row there of each column
  /// of the cell operators (CellOperators::node: the rank's cells' nodes on a discretization of
  /// its cells, else every node, -1: none); empty without.
  std::vector<int> layer_row;
  /// With a ghost layer: the layer's rows (positions in its nodes) of the nodes this rank owns
  /// (node_ranks: each node on one rank), in increasing order (IterateRows::owned)
  std::vector<int> owned_rows;
  /// With a ghost layer: the reference positions on the layer's rows (IterateRows::X), the
  /// part's X (Discretization::part()) when the layer's nodes are the part's, else layer_X; the
  /// mesh's X is released after the set-up (release_after_setup)
  const Eigen::MatrixXd* X_rows = nullptr;
  Eigen::MatrixXd layer_X;
  /// With a ghost layer: the rows of `mean` of own_points() (every point when the contact step
  /// is replicated), their columns the layer's rows: ubar from u on the layer
  SpMatR mean_layer;
  /// With a ghost layer: the loaded nodes that the rank owns (node_ranks), their rows of the
  /// right-hand side and their dead loads, which the rank adds into its part
  std::vector<int> dead_rows;
  Eigen::MatrixXd dead_values;
  /// #nodes (with a ghost layer #layer) x #owned points: the owned columns of meanT_area
  SpMatR meanT_own;
  Eigen::MatrixXd point_rhs;  ///< #owned points x dim: R q_c e + lambda_c of the owned points
  std::unique_ptr<DistributedGlobalStep> ksp;
  double scale = 1;
};

void Solver::DropDistribution::operator()(Distribution* d) const {
  delete d;
}

Solver::~Solver() = default;

namespace {
/// node_ranks' owner of each node, the smallest rank whose cells have it; on a discretization
/// of some cells from the ranks' parts (Discretization::part(), one reduction: collective), the
/// mesh's connectivity being released after the set-up.
std::vector<int> node_owners(const Discretization& disc, const mpi::Partition& cells) {
  if (!disc.partial()) return node_ranks(disc.problem().mesh, cells);
  const int P = mpi::size();
  std::vector<double> minus(disc.num_nodes(), -P);  // minus the smallest rank, by a max
  for (int n : disc.cells().node) minus[n] = -mpi::rank();
  mpi::max(minus.data(), static_cast<long>(minus.size()));
  std::vector<int> rank(minus.size());
  for (std::size_t n = 0; n < minus.size(); ++n)
    rank[n] = minus[n] == -P ? 0 : static_cast<int>(-minus[n]);
  return rank;
}
}  // namespace

void Solver::release_after_setup() {
  if (newton_) return;  // its pattern and node rows read the mesh's connectivity (newton.hpp)
  // A rank reads its cells' nodes on its own part of the mesh (Discretization::part()); the
  // writer reads the connectivity from the ranks' parts when it makes the results file
  // (StepFields::kMeshCells; paper_notes/mpi.md, "The mesh's connectivity on the rank's part").
  disc_.release_mesh_cells();
  // The positions, when u is on the ghost layer's rows: what reads them reads the part's or the
  // layer's rows (state_rows, IterateRows::X), the writer those of the nodes each rank owns
  // (StepFields::kMeshX; "The mesh's positions on the rank's nodes").
  if (u_on_layer()) {
    disc_.release_mesh_X();
    // The dead loads of the rank's block of the nodes (its sums of the equilibrium residual,
    // equilibrium_residual_rows) and of the nodes it owns (its right-hand side at a new R):
    // a body force's, on every node, no longer whole on every rank.
    const std::vector<int>& layer = dist_->ksp->layer_nodes();
    std::vector<int> owned;
    owned.reserve(dist_->owned_rows.size());
    for (int row : dist_->owned_rows) owned.push_back(layer[row]);
    disc_.keep_loads(dist_->n0, dist_->n1, owned);
  }
  // The partition's order (every cell's rank): the writer gathers the cells' rows by their
  // numbers (cells_to_writer), and a whole gather makes it again (whole_cells).
  if (disc_.partial()) std::vector<int>().swap(dist_->cells.order);
}

double Solver::owned_load_work(const Eigen::MatrixXd& u) const {
  const Distribution& d = *dist_;
  const std::vector<int>& layer = d.ksp->layer_nodes();  // the dead loads' rows are the layer's
  double w = 0;
  for (std::size_t k = 0; k < d.dead_rows.size(); ++k)
    w += d.dead_values.row(static_cast<Eigen::Index>(k)).dot(u.row(layer[d.dead_rows[k]]));
  mpi::sum(&w, 1);
  return w;
}

const GlobalStep& Solver::global_step() const {
  if (!global_) throw Error("the global step is the distributed KSP: no serial global step");
  return *global_;
}

void Solver::distribute() {
  const int P = mpi::size(), me = mpi::rank();
  const int nn = disc_.num_nodes();
  const ContactPoints* points = disc_.points();
  const int np = points ? points->size() : 0;
  dist_.reset(new Distribution());
  Distribution& d = *dist_;
  // The ranks' cells: those of a discretization of some cells (each rank's, which must add up
  // to the mesh's), else cell_partition's.
  d.cells = disc_.partial() ? mpi::partition_of(disc_.held_cells(), problem().mesh.num_cells())
                            : ltl::cell_partition(problem().mesh, P);
  d.own = d.cells.items(me);
  // The ranks' contact points: each on the rank of a cell that holds all its nodes (its facet's
  // cell), so that its nodes are the rank's cells' (point_partition, mpi_global.hpp).
  if (points) d.points = point_partition(problem().mesh, *points, d.cells);
  d.own_points = points ? d.points.items(me) : std::vector<int>();
  d.nodes = mpi::blocks(nn, P);
  d.n0 = d.nodes[me], d.n1 = d.nodes[me + 1];
  d.contact_replicated = false;
  if (points)
    for (const ContactCondition& c : problem().contacts)
      d.contact_replicated = d.contact_replicated || c.adhesion.d0 > 0;
  // The global solver: algorithm.global_solver = "cg-amg" the distributed CG + GAMG, "cholesky"
  // MUMPS's distributed Cholesky factorization, left out ("auto") the serial rule with MUMPS's
  // analysis (DistributedGlobalStep::Solver::Auto), decided once, at the first set-up; the PETSc
  // option -ltl_mpi_replicated: the serial factor on every rank.
  d.use_ksp = !mpi::option("-ltl_mpi_replicated");
  switch (alg().global_solver) {
    case GlobalSolver::CgAmg:
      d.ksp_solver = DistributedGlobalStep::Solver::CgGamg;
      break;
    case GlobalSolver::Cholesky:
      d.ksp_solver = DistributedGlobalStep::Solver::Mumps;
      break;
    case GlobalSolver::Auto:
      d.ksp_solver = DistributedGlobalStep::Solver::Auto;
      break;
  }
  if (disc_.partial() && !d.use_ksp)
    throw Error("the replicated factor needs the whole discretization (Solver(Discretization))");
  if (points) {  // meanT_area times the selection of the owned points' columns
    const int own = static_cast<int>(d.own_points.size());
    SpMatR select(np, own);
    std::vector<Eigen::Triplet<double> > t;
    t.reserve(own);
    for (int k = 0; k < own; ++k) t.emplace_back(d.own_points[k], k, 1.0);
    select.setFromTriplets(t.begin(), t.end());
    SpMatR work;  // meanT_area, made again on a rank's discretization (contact_points.hpp)
    d.meanT_own = points->meanT_area_of(work) * select;
    d.point_rhs.resize(own, disc_.dim());
  }
}

// The rank's cells (cell_partition): its operators alone, unless the replicated serial
// factor (-ltl_mpi_replicated: K whole on every rank) needs every cell. The Newton phase builds
// its own per-cell data from the mesh for its cells (newton.hpp) and needs none of the
// operators' other rows. The PETSc option -ltl_mpi_whole builds the whole discretization on
// every rank anyway (the memory before the partition, bench_mpi).
Discretization Solver::discretize(Problem problem, Ranks ranks) {
  if (ranks == Ranks::One || mpi::option("-ltl_mpi_replicated") || mpi::option("-ltl_mpi_whole"))
    return Discretization(std::move(problem));
  const std::vector<int> cells = ltl::cell_partition(problem.mesh, mpi::size()).items(mpi::rank());
  return Discretization(std::move(problem), &cells);
}

const ContactPoints* Solver::points_in_K() const {
  return disc_.partial() && mpi::rank() != 0 ? nullptr : disc_.points();
}

const mpi::Partition* Solver::cell_partition() const {
  return dist_ ? &dist_->cells : nullptr;
}

const std::vector<int>& Solver::own_cells() const {
  return dist_ ? dist_->own : disc_.held_cells();
}

const mpi::Partition* Solver::contact_point_partition() const {
  return dist_ && disc_.points() ? &dist_->points : nullptr;
}

const std::vector<int>& Solver::own_points() const {
  return points_distributed() ? dist_->own_points : all_points_;
}

const std::vector<int>& Solver::residual_points() const {
  return dist_ ? dist_->own_points : all_points_;
}

bool Solver::distributed_global_step(SpMat& K, double scale) {
  Distribution& d = *dist_;
  d.scale = scale;
  if (!d.use_ksp) return false;
  d.ksp.reset();
  Eigen::MatrixXd().swap(rhs_);  // sized below: whole, or on the ghost layer's rows
  const std::vector<int> node_rank = node_owners(disc_, d.cells);
  // The positions of the nodes this rank owns, in increasing order (the near-null space): the
  // mesh's, or once released (a new R) the layer's rows of those nodes.
  Eigen::MatrixXd X_own;
  if (problem().mesh.X.rows() > 0) {
    std::vector<int> owned;
    for (int n = 0; n < disc_.num_nodes(); ++n)
      if (node_rank[n] == mpi::rank()) owned.push_back(n);
    X_own = problem().mesh.X(owned, Eigen::all);
  } else {
    if (!d.X_rows) throw Error("internal: the mesh's positions released without a ghost layer");
    X_own = (*d.X_rows)(d.owned_rows, Eigen::all);
  }
  d.ksp = std::make_unique<DistributedGlobalStep>(std::move(K), disc_.dirichlet(), X_own, node_rank,
                                                  d.ksp_solver, disc_.partial(), newton_dim());
  Eigen::MatrixXd().swap(X_own);
  d.ksp->set_value_scale(scale);
  d.ksp_solver = d.ksp->solver();  // Auto decided: the same solver at the next set-up (a new R)
  // The ghost layer: the right-hand side's rows and u's rows this rank touches are its cells'
  // nodes and its contact points' (all points' when the contact step is replicated). Not on one
  // rank (nothing to exchange: the layer would be a copy of every row), not with mean-det under
  // Anderson, whose packed iterate holds u whole (the same on every rank), nor with the PETSc
  // option -ltl_mpi_no_ghosts (the whole right-hand side summed and u gathered, as before
  // 2026-11-28).
  const bool u_packed = disc_.mean_det() && alg().acceleration == Acceleration::Anderson;
  if (mpi::size() > 1 && !u_packed && !mpi::option("-ltl_mpi_no_ghosts")) {
    const Mesh& part = disc_.part();  // the held cells' nodes (the rank's cells' when partial)
    std::vector<char> touched(disc_.num_nodes(), 0);
    for (std::size_t k = 0; k < d.own.size(); ++k) {
      const int row = disc_.part_row(d.own[k], static_cast<int>(k));  // own: the held cells
      for (int a = 0; a < part.nodes_per_cell(); ++a)
        touched[disc_.part_node(part.cells(row, a))] = 1;
    }
    if (const ContactPoints* points = disc_.points()) {
      for (int f : own_points())
        for (SpMatR::InnerIterator it(points->mean, f); it; ++it) touched[it.col()] = 1;
    }
    std::vector<int> nodes;
    d.owned_rows.clear();
    for (int n = 0; n < disc_.num_nodes(); ++n)
      if (touched[n]) {
        if (node_rank[n] == mpi::rank()) d.owned_rows.push_back(static_cast<int>(nodes.size()));
        nodes.push_back(n);
      }
    std::vector<char>().swap(touched);
    // The right-hand side on the layer's rows alone (global_phase_distributed): meanT_own's rows
    // renumbered once, each node's row in the layer (layer_of, whole-size) through the set-up
    // only, each column's kept (below).
    std::vector<int> layer_of(disc_.num_nodes(), -1);
    for (std::size_t k = 0; k < nodes.size(); ++k) layer_of[nodes[k]] = static_cast<int>(k);
    // The dead loads once over the ranks: each rank adds those of the nodes it owns, which are
    // its cells' (node_ranks), into its part.
    const std::vector<int>& loaded = disc_.loaded_nodes();
    std::vector<int> own_loaded;
    d.dead_rows.clear();
    for (std::size_t k = 0; k < loaded.size(); ++k)
      if (const int node = loaded[k]; node_rank[node] == mpi::rank()) {
        if (layer_of[node] < 0)
          throw Error(
              cat("the ghost layer: owned node ", node, " is not one of the rank's cells'"));
        own_loaded.push_back(static_cast<int>(k));
        d.dead_rows.push_back(layer_of[node]);
      }
    d.dead_values = disc_.loaded_rows()(own_loaded, Eigen::all);
    if (d.meanT_own.rows() == disc_.num_nodes()) {
      std::vector<Eigen::Triplet<double> > t;
      t.reserve(d.meanT_own.nonZeros());
      for (int i = 0; i < d.meanT_own.outerSize(); ++i)
        for (SpMatR::InnerIterator it(d.meanT_own, i); it; ++it)
          t.emplace_back(layer_of[i], static_cast<int>(it.col()), it.value());
      SpMatR local(static_cast<int>(nodes.size()), d.meanT_own.cols());
      local.setFromTriplets(t.begin(), t.end());
      d.meanT_own.swap(local);
    }
    if (const ContactPoints* points = disc_.points()) {
      const std::vector<int>& rows = own_points();
      std::vector<Eigen::Triplet<double> > t;
      for (std::size_t k = 0; k < rows.size(); ++k)
        for (SpMatR::InnerIterator it(points->mean, rows[k]); it; ++it)
          t.emplace_back(static_cast<int>(k), layer_of[it.col()], it.value());
      d.mean_layer.resize(static_cast<int>(rows.size()), static_cast<int>(nodes.size()));
      d.mean_layer.setFromTriplets(t.begin(), t.end());
    }
    const std::vector<int>& column_node = disc_.cells().node;  // empty: the columns are nodes
    d.layer_row.resize(column_node.size());
    for (std::size_t j = 0; j < column_node.size(); ++j) d.layer_row[j] = layer_of[column_node[j]];
    if (column_node.empty()) d.layer_row.swap(layer_of);
    // X on the layer's rows: made at the first set-up, from the mesh's X; the same rows at a
    // new R, when the mesh's X may have been released.
    if (problem().mesh.X.rows() > 0) {
      if (disc_.partial() && nodes == disc_.cells().node) {
        Eigen::MatrixXd().swap(d.layer_X);
        d.X_rows = &disc_.part().X;
      } else {
        d.layer_X = problem().mesh.X(nodes, Eigen::all);
        d.X_rows = &d.layer_X;
      }
    } else if (!d.X_rows || d.X_rows->rows() != static_cast<Eigen::Index>(nodes.size())) {
      throw Error(cat("internal: the ghost layer's ", nodes.size(),
                      " rows at a new R, its positions kept on ", d.X_rows ? d.X_rows->rows() : 0,
                      " rows"));
    }
    d.ksp->set_ghost_layer(std::move(nodes));
  }
  rhs_.resize(rhs_rows(), dim());
  return true;
}

int Solver::rhs_rows() const {
  if (dist_ && dist_->ksp && dist_->ksp->ghost_layer())  // the rows solve() takes
    return static_cast<int>(dist_->ksp->layer_nodes().size());
  return disc_.num_nodes();
}

bool Solver::distributed_cg_gamg() const {
  if (dist_ && dist_->ksp) return dist_->ksp->solver() == DistributedGlobalStep::Solver::CgGamg;
  return alg().global_solver == GlobalSolver::CgAmg;
}

std::string Solver::global_step_summary() const {
  if (global_) {
    const int n = global_->num_factors();
    return global_->solver() == GlobalSolver::CgAmg ? cat("CG + AMG on ", n, " Dirichlet set(s)")
                                                    : cat(n, " factor(s)");
  }
  if (!dist_ || !dist_->ksp) return "no global step";
  const DistributedGlobalStep& k = *dist_->ksp;
  std::string s =
      cat(k.solver() == DistributedGlobalStep::Solver::Mumps ? "MUMPS's Cholesky" : "CG + GAMG",
          " over ", mpi::size(), " ranks on ", k.num_sets(), " Dirichlet set(s)");
  if (k.predicted_factor_bytes() >= 0)
    s += cat(" (automatic: MUMPS's analysis predicts ",
             static_cast<long>(std::lround(k.predicted_factor_bytes() / 1e6)),
             " MB on its most loaded rank)");
  return s;
}

double Solver::distributed_value_scale() const {
  return dist_->scale;
}

void Solver::set_distributed_value_scale(double scale) {
  dist_->scale = scale;
  if (dist_->ksp) dist_->ksp->set_value_scale(scale);
}

void Solver::sum_over_ranks(double* x, int n) const {
  if (dist_) mpi::sum(x, n);
}

RankShare Solver::rank_share() const {
  RankShare r;
  if (!dist_) return r;
  const Distribution& d = *dist_;
  r.cells = static_cast<int>(d.own.size());
  r.points = static_cast<int>(d.own_points.size());
  r.contact_replicated = d.contact_replicated;
  r.replicated_cholesky = !d.ksp;
  r.mumps = d.ksp && d.ksp->solver() == DistributedGlobalStep::Solver::Mumps;
  if (d.ksp) {
    r.ksp_iterations = d.ksp->iterations();
    r.ksp_solves = d.ksp->solves();
    r.ghosts = d.ksp->ghosts();
    r.rows = d.ksp->owned_rows();
    r.layer_ghosts = d.ksp->layer_ghosts();
    r.sets = d.ksp->set_shares();
    r.coarse_operators = d.ksp->coarse_operators(&r.coarse_products);
    r.ksp_seconds = d.ksp->ksp_seconds();
    r.ksp_setup_seconds = d.ksp->setup_seconds();
    r.predicted_factor_bytes = d.ksp->predicted_factor_bytes();
    r.factor_bytes = d.ksp->factor_bytes();
  }
  return r;
}

// [LTL87 (4.1), (4.5)] The right-hand side of global_phase (alg2.cpp) from the owned cells and
// points (the dead loads once, on rank 0; the mean-det lagged Laplacian term on the owned node
// rows), summed over the ranks; the distributed solve; then the owned rows of Gbar u, the
// mean-det targets J and ubar (all of ubar when the contact step is replicated). The iterate's E
// and lambda, T, Gbar u and J are the rank's rows (own_rows): the cells' part of the right-hand
// side is sum over the runs of the rank's cells of Gbar_run^T (|O_e| T_e), Gbar's rows read in
// place.
void Solver::global_phase_distributed(State& s, GlobalOutput& g) {
  Distribution& d = *dist_;
  const AlgorithmParams& a = alg();
  const double Rq = R_ * a.q;
  const int dim = this->dim();
  const ContactPoints* points = disc_.points();
  const auto I = identity_rows(dim, static_cast<int>(d.own.size()));
  T_ = Rq * (s.E - I) + s.lambda - 2 * disc_.split().C1 * I;
  // Gbar's block of own[at]: at on a discretization of the rank's cells, else the cell itself.
  // With a ghost layer the right-hand side is on the layer's rows (layer_row, by the cell
  // operators' column), else whole (by column: the column's node, CellOperators::node).
  const bool held_rows = disc_.partial();
  const bool ghosts = d.ksp && d.ksp->ghost_layer();
  const int* row_of = ghosts ? d.layer_row.data() : nullptr;
  const int* column_row = row_of ? row_of : held_rows ? disc_.cells().node.data() : nullptr;
  rhs_.setZero();
  mpi::for_each_run(d.own, [&](int c0, int n, int at) {
    add_cell_forces(disc_.cells(), n, held_rows ? at : c0, T_.middleRows(dim * at, dim * n), rhs_,
                    column_row);
  });
  if (ghosts) {  // the dead loads of the rank's owned nodes, else once, on rank 0
    for (std::size_t k = 0; k < d.dead_rows.size(); ++k)
      rhs_.row(d.dead_rows[k]) += load_factor_ * d.dead_values.row(k);
  } else if (mpi::rank() == 0) {
    disc_.add_dead_load(rhs_, load_factor_);
  }
  if (disc_.mean_det())  // the pressure's work and gamma (L - GbarT_vol Gbar) u, owned cells
    disc_.fluctuation(s.u, &s.lambda, &s.E, nullptr, &rhs_, gamma_, &d.own, row_of);
  if (points) {
    mpi::for_each_run(d.own_points, [&](int f0, int n, int at) {
      d.point_rhs.middleRows(at, n) =
          R_ * a.q_c * s.e.middleRows(f0, n) + s.lambda_c.middleRows(f0, n);
    });
    rhs_.noalias() += d.meanT_own * d.point_rhs;
  }
  if (ghosts) {  // the ranks' parts (layer rows) added into PETSc's vector; u on the layer's
    d.ksp->solve(rhs_, s.u);
  } else {
    mpi::sum(rhs_.data(), rhs_.size());
    if (d.ksp)
      d.ksp->solve(rhs_, s.u);
    else
      global_->solve(rhs_, s.u);
  }

  // Gbar's columns read u's rows: the layer's (row_of), else their nodes'.
  mpi::for_each_run(d.own, [&](int c0, int n, int at) {
    mean_gradients(disc_.cells(), held_rows ? at : c0, n, s.u, g.GU.middleRows(dim * at, dim * n),
                   row_of);
  });
  if (disc_.mean_det()) {
    disc_.fluctuation(s.u, nullptr, nullptr, &g.J, nullptr, 0.0, &d.own, row_of);
    g.J = 1.0 - g.J.array();
  }
  if (points) {
    mpi::for_each_run(own_points(), [&](int f0, int n, int at) {
      if (ghosts)
        g.ubar.middleRows(f0, n).noalias() = d.mean_layer.middleRows(at, n) * s.u;
      else
        g.ubar.middleRows(f0, n).noalias() = points->mean.middleRows(f0, n) * s.u;
    });
  }
}

bool Solver::u_on_layer() const {
  return dist_ && rows_between_steps() && dist_->ksp && dist_->ksp->ghost_layer();
}

const IterateRows* Solver::state_rows(IterateRows& at) const {
  if (!u_on_layer()) return nullptr;
  at.nodes = &dist_->ksp->layer_nodes();
  at.column_row = dist_->layer_row.data();
  at.points = points_distributed() ? &dist_->own_points : nullptr;
  at.owned = &dist_->owned_rows;
  at.X = problem().mesh.X.rows() > 0 ? nullptr : dist_->X_rows;
  return &at;
}

const Eigen::MatrixXd* Solver::reference_rows() const {
  return u_on_layer() ? dist_->X_rows : nullptr;
}

void Solver::layer_rows(Eigen::MatrixXd& u) const {
  if (!u_on_layer() || u.rows() != disc_.num_nodes()) return;  // on the layer's rows already
  Eigen::MatrixXd rows = u(dist_->ksp->layer_nodes(), Eigen::all);
  u.swap(rows);
}

void Solver::whole_u(Eigen::MatrixXd& u) const {
  if (!u_on_layer() || u.rows() == disc_.num_nodes()) return;
  dist_->ksp->whole_u(u);
}

void Solver::nodes_to_writer(const Eigen::MatrixXd& u, Eigen::MatrixXd& block, int first,
                             int count) const {
  if (count < 0) count = disc_.num_nodes() - first;
  Eigen::MatrixXd rows;
  if (!u_on_layer() || u.rows() == disc_.num_nodes()) {  // whole on every rank
    if (mpi::rank() == 0) rows = u.middleRows(first, count);
  } else {  // the rows of the block's nodes that each rank owns, the others zero, summed
    rows = Eigen::MatrixXd::Zero(count, u.cols());
    const std::vector<int>& nodes = dist_->ksp->layer_nodes();
    for (int row : dist_->owned_rows)
      if (const int n = nodes[row]; n >= first && n < first + count)
        rows.row(n - first) = u.row(row);
    mpi::sum_to_writer(rows.data(), rows.size());
  }
  if (mpi::rank() != 0) rows = Eigen::MatrixXd();  // released: the writer's alone
  block.swap(rows);
}

double Solver::equilibrium_error_of(const State& own) const {
  IterateRows rows;
  if (const IterateRows* at = state_rows(rows))
    return equilibrium_error(disc_, own, load_factor_, *at);
  // u whole, E and lambda the rank's rows (or gathered with the replicated factor)
  return equilibrium_error(disc_, dist_ ? between_steps(own) : own, load_factor_);
}

std::optional<double> Solver::iterate_equilibrium_error() const {
  if (!alg2_rows_) return std::nullopt;
  return equilibrium_error_of(*alg2_rows_);
}

bool Solver::points_distributed() const {
  return dist_ && disc_.points() && !dist_->contact_replicated;
}

void Solver::gather_points(State& s) const {
  const Distribution& d = *dist_;
  if (points_distributed()) {
    mpi::gather_rows(s.e, d.points, 1);
    mpi::gather_rows(s.lambda_c, d.points, 1);
    mpi::gather_rows(s.beta, d.points);
  }
}

Eigen::MatrixXd Solver::rank_rows(const Eigen::MatrixXd& A) const {
  const int dim = this->dim();
  if (!disc_.whole_field(A)) return A;  // the rows already
  Eigen::MatrixXd own(dim * static_cast<Eigen::Index>(dist_->own.size()), dim);
  mpi::for_each_run(dist_->own, [&](int c0, int n, int at) {
    own.middleRows(dim * at, dim * n) = A.middleRows(dim * c0, dim * n);
  });
  return own;
}

State Solver::own_rows(State& s) const {
  State own;
  const bool whole = disc_.whole_field(s.E);
  if (whole) {
    own.E = rank_rows(s.E);
    own.lambda = rank_rows(s.lambda);
    s.E = Eigen::MatrixXd();
    s.lambda = Eigen::MatrixXd();
  } else {  // a state between steps on the rank's rows
    own.E.swap(s.E);
    own.lambda.swap(s.lambda);
  }
  if (dist_->ksp && dist_->ksp->ghost_layer() && s.u.rows() == disc_.num_nodes()) {
    const std::vector<int>& layer = dist_->ksp->layer_nodes();
    own.u = s.u(layer, Eigen::all);  // the ghost layer's rows (global_phase_distributed)
    Eigen::MatrixXd().swap(s.u);
  } else {  // whole without a ghost layer, or on its rows already (the state between steps)
    own.u.swap(s.u);
  }
  own.e.swap(s.e);
  own.beta.swap(s.beta);
  own.lambda_c.swap(s.lambda_c);
  return own;
}

State Solver::whole(const State& own) const {
  State s = whole_cells(own);
  s.u = own.u;
  if (dist_->ksp) dist_->ksp->whole_u(s.u);  // after solves with a ghost layer
  gather_points(s);                          // current on the rank's points only
  return s;
}

namespace {
void copy_contact_fields(const State& from, State& to) {  // e, beta, lambda_c: whole
  to.e = from.e;
  to.beta = from.beta;
  to.lambda_c = from.lambda_c;
}
}  // namespace

std::optional<State> Solver::iterate_to_writer(const State& s) const {
  // Between ALG2's phases (a Newton phase) the iterate is in the form of the state between
  // steps, which the writer reads: s, or Newton's iterate in s's form. Not with glue: a glued
  // Newton state is kept only if the local contact step holds there (solve_step), so that its
  // iterates are no point to continue from (another branch of the glue).
  if (!alg2_rows_) {
    if (newton_ && !(contact_ && contact_->glued())) return newton_->current_state(s);
    return std::nullopt;
  }
  // Inside an ALG2 phase on the ranks: the phase's rows made into the state between steps, as at
  // the phase's end (a copy: the phase goes on): E and lambda the rank's rows, which the writer
  // gathers a block at a time (StepFields), u from the ghost layers, the points' fields gathered.
  return between_steps(*alg2_rows_);
}

State Solver::between_steps(State own) const {
  if (!rows_between_steps()) return whole(own);
  // u stays on the ghost layer's rows (u_on_layer); without one it is whole already.
  gather_points(own);
  return own;
}

bool Solver::rows_between_steps() const {
  return dist_ && disc_.partial();
}

void Solver::hold_rows(State& s) const {
  layer_rows(s.u);
  if (!rows_between_steps() || !disc_.whole_field(s.E)) return;  // held on the rows already
  s.E = rank_rows(s.E);
  s.lambda = rank_rows(s.lambda);
}

State Solver::whole_state(const State& s) const {
  if (!rows_between_steps()) return s;
  State w;
  if (disc_.whole_field(s.E)) {
    w = s;
  } else {
    w = whole_cells(s);
    w.u = s.u;
  }
  whole_u(w.u);  // from the ghost layer's rows (collective)
  return w;
}

void Solver::cells_to_writer(const Eigen::MatrixXd& rows, Eigen::MatrixXd& block, int rows_per_cell,
                             int first_cell, int count) const {
  if (!rows_between_steps()) {
    if (count < 0) count = disc_.num_cells() - first_cell;
    block = rows.middleRows(static_cast<Eigen::Index>(rows_per_cell) * first_cell,
                            static_cast<Eigen::Index>(rows_per_cell) * count);
    return;
  }
  mpi::gather_rows_to_writer(rows, block, dist_->own, disc_.num_cells(), rows_per_cell, first_cell,
                             count);
}

State Solver::whole_cells(const State& rows) const {
  State s;
  // The partition's order, released after the set-up (release_after_setup), made again for the
  // time of the gather (one sum of 2 #cells values, collective; whole arrays are made anyway).
  std::optional<mpi::Partition> made;
  if (dist_->cells.order.empty() && disc_.num_cells() > 0)
    made = mpi::partition_of(dist_->own, disc_.num_cells());
  const mpi::Partition& cells = made ? *made : dist_->cells;
  mpi::gather_rows(rows.E, s.E, cells, dim());
  mpi::gather_rows(rows.lambda, s.lambda, cells, dim());
  copy_contact_fields(rows, s);
  return s;
}

State Solver::kept_copy(const State& s) const {
  if (!dist_) return s;
  const Distribution& d = *dist_;
  State kept;
  kept.E = rank_rows(s.E);
  kept.lambda = rank_rows(s.lambda);
  if (u_on_layer()) {  // the ghost layer's rows (the state between steps)
    kept.u = s.u;
    layer_rows(kept.u);
  } else {
    kept.u = s.u.middleRows(d.n0, d.n1 - d.n0);  // the rank's block of the nodes (mpi::blocks)
  }
  copy_contact_fields(s, kept);
  return kept;
}

void Solver::restore(const State& kept, State& s) const {
  s = State();  // released first: one whole state at a time
  if (!dist_) {
    s = kept;
    return;
  }
  const Distribution& d = *dist_;
  if (rows_between_steps()) {  // E and lambda stay on the rank's rows
    s.E = kept.E;
    s.lambda = kept.lambda;
    copy_contact_fields(kept, s);
  } else {
    s = whole_cells(kept);
  }
  if (u_on_layer()) {  // the ghost layer's rows, as kept
    s.u = kept.u;
    return;
  }
  s.u.resize(disc_.num_nodes(), dim());
  s.u.middleRows(d.n0, d.n1 - d.n0) = kept.u;
  mpi::gather_rows(s.u, d.nodes, 1);
}

namespace {
template <class Sparse>
double bytes_of_sparse(const Sparse& A) {  // values and indices, compressed
  return 12.0 * A.nonZeros() + 4.0 * (A.outerSize() + 1);
}
template <class Dense>
double bytes_of(const Dense& A) {
  return 8.0 * A.size();
}
}  // namespace

Holdings Solver::holdings() const {
  Holdings h;
  const Mesh& mesh = problem().mesh;
  h.mesh = bytes_of(mesh.X) + 4.0 * mesh.cells.size();
  for (const Mesh::Boundary& b : mesh.boundaries) h.mesh += 4.0 * b.facets.size();
  if (disc_.partial()) h.mesh += bytes_of(disc_.part().X) + 4.0 * disc_.part().cells.size();
  if (dist_) h.mesh += bytes_of(dist_->layer_X);
  const CellOperators& c = disc_.cells();
  h.operators = bytes_of_sparse(c.Gbar) + bytes_of_sparse(c.GbarT_vol) +
                bytes_of_sparse(c.laplacian) + bytes_of(c.vol) +
                4.0 * static_cast<double>(c.node.size());
  const int dim = this->dim();
  for (Eigen::Index k = 0; k < c.Gbar.rows() / dim; ++k)
    if (c.Gbar.outerIndexPtr()[dim * k + 1] > c.Gbar.outerIndexPtr()[dim * k])
      ++h.cells_with_operators;
  h.cell_arrays = bytes_of(T_) + bytes_of(global_out_.GU) + bytes_of(global_out_.J) +
                  bytes_of(prev_.E) + bytes_of(half_.lambda) + bytes_of(w_cell_) +
                  4.0 * static_cast<double>(disc_.held_cells().size());
  if (dist_) h.cell_arrays += 4.0 * (dist_->cells.order.size() + dist_->own.size());
  h.rhs_rows = static_cast<int>(rhs_.rows());
  if (alg2_rows_) h.iterate_u_rows = static_cast<int>(alg2_rows_->u.rows());
  h.node_arrays = bytes_of(disc_.loaded_rows()) +
                  4.0 * static_cast<double>(disc_.loaded_nodes().size()) + bytes_of(rhs_);
  if (dist_)
    h.node_arrays += bytes_of(dist_->dead_values) +
                     4.0 * static_cast<double>(dist_->dead_rows.size() + dist_->layer_row.size());
  if (dist_ && dist_->ksp)
    h.node_arrays += 4.0 * static_cast<double>(dist_->ksp->layer_nodes().size());
  const DirichletData& bc = disc_.dirichlet();
  for (std::size_t i = 0; i < bc.fixed.size(); ++i)
    h.node_arrays +=
        static_cast<double>(sizeof(int) * bc.fixed[i].size() + sizeof(double) * bc.value[i].size());
  if (const ContactPoints* p = disc_.points()) {
    h.contact = bytes_of_sparse(p->mean) + bytes_of_sparse(p->meanT_area) +
                bytes_of_sparse(p->meanT_area_by_point) + bytes_of(p->area) + bytes_of(p->centre) +
                bytes_of(p->gap) + bytes_of(p->normals) + bytes_of(global_out_.ubar) +
                bytes_of(w_point_);
    if (dist_) h.contact += bytes_of_sparse(dist_->meanT_own) + bytes_of_sparse(dist_->mean_layer);
  }
  if (newton_) {
    const Newton::Holdings n = newton_->holdings();
    h.newton_cells = n.cells;
    h.newton_cell_data = n.cell_data;
    h.newton_positions = n.positions;
    h.newton_whole = n.whole;
  }
  return h;
}

}  // namespace ltl

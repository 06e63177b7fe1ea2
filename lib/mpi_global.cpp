// The distributed global step (4.5): one PETSc KSP (CG + GAMG) over the MPI ranks; see
// mpi_global.hpp.
#include "mpi_global.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>

#include "cg_amg.hpp"
#include "error.hpp"
#include "mpi_comm.hpp"

#ifdef LTL_HAVE_MPI
#include <petscksp.h>
#include <ptscotch.h>  // (after PETSc's headers: it needs stdio.h's FILE and mpi.h)
#endif

namespace ltl {

mpi::Partition slab_cells(const Mesh& mesh, int ranks) {
  const int nc = mesh.num_cells();
  Eigen::Index axis = 0;
  (mesh.X.colwise().maxCoeff() - mesh.X.colwise().minCoeff()).maxCoeff(&axis);
  std::vector<double> x(nc, 0.0);
  for (int c = 0; c < nc; ++c)
    for (int a = 0; a < mesh.nodes_per_cell(); ++a) x[c] += mesh.X(mesh.cells(c, a), axis);
  mpi::Partition part;
  part.order.resize(nc);
  for (int c = 0; c < nc; ++c) part.order[c] = c;
  std::stable_sort(part.order.begin(), part.order.end(), [&](int a, int b) { return x[a] < x[b]; });
  part.offset = mpi::blocks(nc, ranks);
  for (int r = 0; r < ranks; ++r)
    std::sort(part.order.begin() + part.offset[r], part.order.begin() + part.offset[r + 1]);
  return part;
}

DualGraph facet_neighbours(const Mesh& mesh) {
  const int nc = mesh.num_cells(), shared = mesh.nodes_per_facet();
  const NodeCells of = node_cells(mesh);
  DualGraph g;
  g.start.assign(nc + 1, 0);
  std::vector<int> near;
  // f(c, d) for each facet neighbour d of c, in order: `near` holds each cell that shares a node
  // with c once per node shared.
  const auto for_each_neighbour = [&](int c, auto&& f) {
    of.around(mesh, c, near);
    for (std::size_t j = 0; j < near.size();) {
      std::size_t k = j;
      while (k < near.size() && near[k] == near[j]) ++k;
      if (static_cast<int>(k - j) >= shared) f(near[j]);
      j = k;
    }
  };
  for (int c = 0; c < nc; ++c) for_each_neighbour(c, [&](int) { ++g.start[c + 1]; });
  for (int c = 0; c < nc; ++c) g.start[c + 1] += g.start[c];
  g.next.resize(g.start[nc]);
  for (int c = 0; c < nc; ++c) {
    int at = g.start[c];
    for_each_neighbour(c, [&](int d) { g.next[at++] = d; });
  }
  return g;
}

long cut_facets(const Mesh& mesh, const mpi::Partition& cells) {
  const std::vector<int> rank = cells.owners();
  const DualGraph g = facet_neighbours(mesh);
  long cut = 0;
  for (int c = 0; c < mesh.num_cells(); ++c)
    for (int k = g.start[c]; k < g.start[c + 1]; ++k)
      cut += g.next[k] > c && rank[g.next[k]] != rank[c];
  return cut;
}

mpi::Partition cell_partition(const Mesh& mesh, int ranks) {
  return mpi::option("-ltl_mpi_slabs") ? slab_cells(mesh, ranks) : graph_cells(mesh, ranks);
}

std::vector<int> node_ranks(const Mesh& mesh, const mpi::Partition& cells) {
  const int P = static_cast<int>(cells.offset.size()) - 1;
  std::vector<int> rank(mesh.num_nodes(), P);
  for (int r = 0; r < P; ++r)
    for (int j = cells.offset[r]; j < cells.offset[r + 1]; ++j)
      for (int a = 0; a < mesh.nodes_per_cell(); ++a) {
        int& owner = rank[mesh.cells(cells.order[j], a)];
        owner = std::min(owner, r);
      }
  for (int& r : rank)
    if (r == P) r = 0;
  return rank;
}

mpi::Partition point_partition(const Mesh& mesh, const ContactPoints& points,
                               const mpi::Partition& cells) {
  const int P = static_cast<int>(cells.offset.size()) - 1, np = points.size();
  const int nn = mesh.num_nodes(), npc = mesh.nodes_per_cell();
  const std::vector<int> cell_rank = cells.owners();
  std::vector<char> on_points(nn, 0);  // the cells of the points' nodes only
  for (int k = 0; k < points.mean.outerSize(); ++k)
    for (SpMatR::InnerIterator it(points.mean, k); it; ++it) on_points[it.col()] = 1;
  const NodeCells around = node_cells(mesh, &on_points);
  std::vector<int> rank(np, P);
  for (int s = 0; s < np; ++s) {
    SpMatR::InnerIterator first(points.mean, s);
    if (!first) throw Error(cat("point_partition: contact point ", s, " has no node"));
    for (int j = around.start[first.col()]; j < around.start[first.col() + 1]; ++j) {
      const int c = around.cell[j];
      bool all = true;  // does cell c hold every node of point s?
      for (SpMatR::InnerIterator it(points.mean, s); it && all; ++it) {
        bool found = false;
        for (int a = 0; a < npc && !found; ++a) found = mesh.cells(c, a) == it.col();
        all = found;
      }
      if (all) rank[s] = std::min(rank[s], cell_rank[c]);
    }
    if (rank[s] == P)
      throw Error(cat("point_partition: no cell holds every node of contact point ", s));
  }
  return mpi::partition_of_ranks(rank, P);
}

#ifndef LTL_HAVE_MPI

namespace {
std::vector<int> scotch_parts(const Mesh&, int parts) {
  throw Error(cat("the graph partition of the cells into ", parts,
                  " parts needs PETSc (PT-Scotch): build with -DLTL_WITH_MPI=ON"));
}
}  // namespace

struct DistributedGlobalStep::Group {};

DistributedGlobalStep::DistributedGlobalStep(SpMat&&, const DirichletData& bc,
                                             const Eigen::MatrixXd&, const std::vector<int>&,
                                             Solver solver, bool, int)
    : bc_(bc), solver_(solver) {
  throw Error(
      "the distributed global step needs MPI and PETSc: build with -DLTL_WITH_MPI=ON "
      "(`make test-mpi`)");
}
DistributedGlobalStep::~DistributedGlobalStep() = default;
void DistributedGlobalStep::solve(const Eigen::MatrixXd&, Eigen::MatrixXd&) {}
void DistributedGlobalStep::set_ghost_layer(std::vector<int>) {}
void DistributedGlobalStep::whole_u(Eigen::MatrixXd&) {}
std::vector<DistributedGlobalStep::SetShare> DistributedGlobalStep::set_shares() const {
  return {};
}
int DistributedGlobalStep::coarse_operators(int* with_products) const {
  if (with_products) *with_products = 0;
  return 0;
}
double DistributedGlobalStep::factor_bytes() const {
  return 0;
}

#else

namespace {
void check(PetscErrorCode ierr, const std::string& what, const char* call) {
  if (ierr) throw Error(cat(what, ": PETSc's ", call, " failed (PETSc error ", ierr, ")"));
}

// GAMG's Galerkin products P^T A P of the distributed matrices computed "all at once" (PETSc's
// -matptap_via allatonce), while the KSP is set up, unless the user chose an algorithm
// (PETSC_OPTIONS). PETSc's default for MPIAIJ kept 6.6 times the serial product's memory: on the
// 102 400-cell gutter the peak was 822 MB on one rank and 498 on each of 2, against 596
// and 350 all at once, for the same coarse operators (the same CG iterations) and a setup of
// 10 s instead of 4, once per run (paper_notes/mpi.md, "GAMG's products all at once"). Only
// around the setup: a serial (SeqAIJ) matrix, the serial CG + AMG's, refuses the algorithm.
struct AllAtOnceGalerkinProducts {
  PetscBool given = PETSC_FALSE;
  AllAtOnceGalerkinProducts() {
    PetscOptionsHasName(nullptr, nullptr, "-matptap_via", &given);
    if (!given) PetscOptionsSetValue(nullptr, "-matptap_via", "allatonce");
  }
  ~AllAtOnceGalerkinProducts() {
    if (!given) PetscOptionsClearValue(nullptr, "-matptap_via");
  }
  AllAtOnceGalerkinProducts(const AllAtOnceGalerkinProducts&) = delete;
  AllAtOnceGalerkinProducts& operator=(const AllAtOnceGalerkinProducts&) = delete;
};
}  // namespace

namespace {
/// PT-Scotch's `parts` parts of the subgraph of the cells' dual graph (compressed rows ia, ja)
/// on the cells `cells` (null: every cell; at[c]: c's position among them, -1 outside), its
/// edges to one another only, on this process alone (PETSC_COMM_SELF): the part of each of
/// those cells. Scotch's threads run one at a time (SCOTCH_PTHREAD_NUMBER, unless the user's
/// environment sets it; put back afterwards) and its pseudo-random state is reset: the same
/// graph, the same parts.
std::vector<int> scotch_split(const std::vector<int>& ia, const std::vector<int>& ja,
                              const std::vector<int>* cells, const std::vector<int>& at, int parts,
                              const char* what) {
  const int n = cells ? static_cast<int>(cells->size()) : static_cast<int>(ia.size()) - 1;
  auto cell = [&](int k) { return cells ? (*cells)[k] : k; };
  std::size_t edges = 0;
  for (int k = 0; k < n; ++k)
    for (int e = ia[cell(k)]; e < ia[cell(k) + 1]; ++e) edges += !cells || at[ja[e]] >= 0;
  PetscInt *pi = nullptr, *pj = nullptr;  // PETSc's: the MPIAdj matrix takes and frees them
  if (PetscMalloc1(n + 1, &pi) || PetscMalloc1(edges + 1, &pj)) {
    PetscFree(pi);
    throw Error(cat(what, ": PETSc's PetscMalloc1 failed"));
  }
  pi[0] = 0;
  for (int k = 0; k < n; ++k) {
    pi[k + 1] = pi[k];
    for (int e = ia[cell(k)]; e < ia[cell(k) + 1]; ++e)
      if (const int j = cells ? at[ja[e]] : ja[e]; j >= 0) pj[pi[k + 1]++] = j;
  }
  Mat graph = nullptr;
  if (MatCreateMPIAdj(PETSC_COMM_SELF, n, n, pi, pj, nullptr, &graph)) {
    PetscFree(pi);
    PetscFree(pj);
    throw Error(cat(what, ": PETSc's MatCreateMPIAdj failed"));
  }
  const char* threads = std::getenv("SCOTCH_PTHREAD_NUMBER");
  if (!threads) setenv("SCOTCH_PTHREAD_NUMBER", "1", 1);
  SCOTCH_randomReset();
  MatPartitioning partitioner = nullptr;
  IS is = nullptr;
  PetscErrorCode ierr = MatPartitioningCreate(PETSC_COMM_SELF, &partitioner);
  if (!ierr) ierr = MatPartitioningSetAdjacency(partitioner, graph);
  if (!ierr) ierr = MatPartitioningSetType(partitioner, MATPARTITIONINGPTSCOTCH);
  if (!ierr) ierr = MatPartitioningSetNParts(partitioner, parts);
  if (!ierr) ierr = MatPartitioningSetFromOptions(partitioner);
  if (!ierr) ierr = MatPartitioningApply(partitioner, &is);
  std::vector<int> part(n, 0);
  if (!ierr) {
    const PetscInt* r = nullptr;
    ierr = ISGetIndices(is, &r);
    if (!ierr) {
      for (int k = 0; k < n; ++k) part[k] = static_cast<int>(r[k]);
      ISRestoreIndices(is, &r);
    }
  }
  if (!threads) unsetenv("SCOTCH_PTHREAD_NUMBER");
  if (is) ISDestroy(&is);
  if (partitioner) MatPartitioningDestroy(&partitioner);
  MatDestroy(&graph);
  check(ierr, what, "MatPartitioningApply");
  for (int k = 0; k < n; ++k)
    if (part[k] < 0 || part[k] >= parts)
      throw Error(cat(what, ": cell ", cell(k), " in part ", part[k], " of ", parts));
  return part;
}

/// PT-Scotch's parts of the cells' dual graph (facet_neighbours), on this process alone. Above
/// kTwoLevelParts parts (the PETSc option -ltl_mpi_two_level_parts sets another threshold), and
/// when `parts` = g m with 2 <= g <= m, g the largest such divisor: in two levels, the cells first
/// into g groups, then each group's cells into m parts (part g_k m + j). PT-Scotch's work grows
/// with the parts, about 0.7 MB a part at 10^6 cells (721 MB for 1024 parts; paper_notes/mpi.md,
/// "The partition in two levels"); 32 x 32 holds that of 32 parts at a time.
std::vector<int> scotch_parts(const Mesh& mesh, int parts) {
  const int nc = mesh.num_cells();
  const char* what = "the graph partition of the cells (PT-Scotch)";
  const DualGraph graph = facet_neighbours(mesh);
  const std::vector<int>& ia = graph.start;
  const std::vector<int>& ja = graph.next;
  PetscInt threshold = kTwoLevelParts;
  PetscOptionsGetInt(nullptr, nullptr, "-ltl_mpi_two_level_parts", &threshold, nullptr);
  int groups = 1;
  if (parts >= threshold)
    for (int g = 2; g * g <= parts; ++g)
      if (parts % g == 0) groups = g;
  std::vector<int> at;  // a group's positions (two levels)
  if (groups == 1) return scotch_split(ia, ja, nullptr, at, parts, what);
  const int m = parts / groups;
  std::vector<int> part = scotch_split(ia, ja, nullptr, at, groups, what);
  std::vector<std::vector<int> > members(groups);
  for (int c = 0; c < nc; ++c) members[part[c]].push_back(c);  // sorted
  at.assign(nc, -1);
  for (int k = 0; k < groups; ++k) {
    const std::vector<int>& cells = members[k];
    if (static_cast<int>(cells.size()) < m)
      throw Error(cat(what, ": group ", k, " of ", groups, " has ", cells.size(), " cells for ", m,
                      " parts: fewer ranks, or a finer mesh"));
    for (std::size_t j = 0; j < cells.size(); ++j) at[cells[j]] = static_cast<int>(j);
    const std::vector<int> sub = scotch_split(ia, ja, &cells, at, m, what);
    for (std::size_t j = 0; j < cells.size(); ++j) {
      part[cells[j]] = k * m + sub[j];
      at[cells[j]] = -1;
    }
  }
  return part;
}

/// f(M) for the operator M of each of GAMG's coarse levels (not A's, the finest); none when the
/// KSP's preconditioner is not GAMG (MUMPS, or another from the options). Collective.
template <class F>
void for_each_coarse_operator(KSP ksp, const std::string& what, F f) {
  PC pc = nullptr;
  PCType type = nullptr;
  check(KSPGetPC(ksp, &pc), what, "KSPGetPC");
  check(PCGetType(pc, &type), what, "PCGetType");
  if (!type || std::string(type) != PCGAMG) return;
  PetscInt levels = 0;
  check(PCMGGetLevels(pc, &levels), what, "PCMGGetLevels");
  for (PetscInt l = 0; l + 1 < levels; ++l) {  // level levels - 1 is A itself
    KSP smoother = nullptr;
    Mat coarse = nullptr;
    check(PCMGGetSmoother(pc, l, &smoother), what, "PCMGGetSmoother");
    check(KSPGetOperators(smoother, &coarse, nullptr), what, "KSPGetOperators");
    f(coarse);
  }
}

// The coarse operators P^T A P of GAMG's levels keep what PETSc needs to compute them again for a
// new A (for each, the rows of P that other ranks hold, and the pattern of the products). The
// matrix of (4.5) is assembled once and never changes, so nothing computes them again: released
// (PETSc's MatProductClear) once the hierarchy is built. On 8 ranks of the 102 400-cell gutter that
// data was 11 MB of each rank's 88 MB live at the step's end; on one rank too little to measure
// (paper_notes/mpi.md, "GAMG's coarse operators without their products' data").
void release_coarse_products(KSP ksp, const std::string& what) {
  for_each_coarse_operator(
      ksp, what, [&](Mat coarse) { check(MatProductClear(coarse), what, "MatProductClear"); });
}
}  // namespace

/// One distinct Dirichlet set: the ranks' blocks of its free rows, the mesh nodes of this rank's
/// block and of its ghost layer, the constant shift K_fd u_d on the owned rows, and PETSc's
/// matrix, solver and vectors.
struct DistributedGlobalStep::Group {
  std::vector<int> components;
  std::vector<int> offset;    ///< the ranks' blocks of free rows
  std::vector<int> own_node;  ///< #owned, the mesh node of each of this rank's free rows
  Eigen::MatrixXd shift;      ///< #owned x #components
  std::string what;
  Mat A = nullptr;
  KSP ksp = nullptr;
  Vec b = nullptr, xv = nullptr;
  Vec r = nullptr;  ///< b - A x0, the warm start's residual (CG + GAMG, inexact)
  // The ghost layer (set_ghost_layer): the free rows of b this rank adds, and the layer's rows
  // of the free rows of u it reads (the added ones and its owned block) with their scatter from
  // xv into `read`.
  std::vector<PetscInt> add_row;
  std::vector<int> add_at;  ///< the row in the ghost layer's b of each added row
  std::vector<PetscScalar> add_value;
  std::vector<int> read_at;
  /// f(r, k) for each owned row r and the row k of its node in the ghost layer's nodes `layer`:
  /// both lists in increasing order, a merge (set_ghost_layer checks that the layer holds them).
  template <class F>
  void for_each_own_row(const std::vector<int>& layer, F&& f) const {
    std::size_t k = 0;
    for (std::size_t r = 0; r < own_node.size(); ++r) {
      while (layer[k] < own_node[r]) ++k;
      f(static_cast<int>(r), static_cast<int>(k));
    }
  }
  Vec read = nullptr;
  VecScatter scatter = nullptr;
  // Without a ghost layer (one rank, mean-det under Anderson, -ltl_mpi_no_ghosts) every solve
  // gathers u whole: the whole node list and one column's buffer, kept from the first solve.
  std::vector<int> whole_node;
  std::vector<double> whole_x;
  /// The mesh node of every free row (the ranks' blocks in turn), gathered from the ranks'
  /// own_node. Collective.
  std::vector<int> whole_nodes() const {
    std::vector<double> node(offset.back());
    std::copy(own_node.begin(), own_node.end(), node.begin() + offset[mpi::rank()]);
    mpi::gather(node.data(), offset);
    return std::vector<int>(node.begin(), node.end());
  }
  /// Every rank's owned rows of u's column c (own: this rank's, in its row order) gathered into
  /// u's column c on the free nodes of every rank, through x (#free) and the node list of every
  /// free row (whole_nodes; empty: gathered into it). On one rank own is every row: straight
  /// into u. Collective.
  void gather_into(Eigen::MatrixXd& u, int c, const double* own, std::vector<int>& node,
                   std::vector<double>& x) const {
    if (mpi::size() == 1) {
      for (std::size_t i = 0; i < own_node.size(); ++i) u(own_node[i], c) = own[i];
      return;
    }
    if (node.empty()) node = whole_nodes();
    x.resize(offset.back());
    std::copy(own, own + own_node.size(), x.begin() + offset[mpi::rank()]);
    mpi::gather(x.data(), offset);
    for (std::size_t i = 0; i < node.size(); ++i) u(node[i], c) = x[i];
  }
  ~Group() {
    if (!mpi::collective_teardown()) return;  // left to the job's end
    if (scatter) VecScatterDestroy(&scatter);
    if (read) VecDestroy(&read);
    if (r) VecDestroy(&r);
    if (ksp) KSPDestroy(&ksp);
    if (A) MatDestroy(&A);
    if (b) VecDestroy(&b);
    if (xv) VecDestroy(&xv);
  }
};

namespace {
/// `copies` x INFOG(16) of MUMPS's analysis of A (auto_choice), in bytes. Collective.
double analysed_bytes(Mat A, int copies, const std::string& what) {
  Mat F = nullptr;
  check(MatGetFactor(A, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &F), what, "MatGetFactor");
  MatFactorInfo info;
  MatFactorInfoInitialize(&info);
  PetscErrorCode ierr = MatCholeskyFactorSymbolic(F, A, nullptr, &info);
  PetscInt status = 0, mb = 0;
  if (!ierr) ierr = MatMumpsGetInfog(F, 1, &status);
  if (!ierr) ierr = MatMumpsGetInfog(F, 16, &mb);
  MatDestroy(&F);
  check(ierr, what, "MatCholeskyFactorSymbolic (MUMPS's analysis for the automatic choice)");
  if (status < 0)
    throw Error(
        cat(what, ": MUMPS's analysis for the automatic choice failed (INFOG(1) = ", status, ")"));
  return 1e6 * static_cast<double>(mb) * copies;
}

/// Solver::Auto (mpi_global.hpp), the serial rule (GlobalStep::AutoLimits::cg_amg, its limits
/// replaced by the PETSc options -ltl_mpi_auto_rows and -ltl_mpi_auto_bytes): MUMPS's Cholesky
/// unless A has more than kAutoMinRows rows and MUMPS's analysis (its symbolic factorization alone,
/// on a factor destroyed afterwards) predicts more than kAutoFactorBytes on its most loaded rank:
/// `copies` x INFOG(16), the estimated MB of all of MUMPS's data for A's in-core factorization on
/// that rank, the same on every rank; `copies`: the Dirichlet sets, whose factors are held
/// together, plus dim^2 with a Newton phase (its tangent's factor, A's with d x d blocks); the
/// serial rule counts the same way (global_step.hpp). `predicted`: those bytes, or -1 below the
/// rows' limit (no analysis). Collective.
DistributedGlobalStep::Solver auto_choice(Mat A, int rows, int copies, const std::string& what,
                                          double& predicted) {
  PetscInt min_rows = GlobalStep::kAutoMinRows;
  PetscReal limit = GlobalStep::kAutoFactorBytes;
  PetscOptionsGetInt(nullptr, nullptr, "-ltl_mpi_auto_rows", &min_rows, nullptr);
  PetscOptionsGetReal(nullptr, nullptr, "-ltl_mpi_auto_bytes", &limit, nullptr);
  GlobalStep::AutoLimits limits;
  limits.min_rows = static_cast<int>(min_rows);
  limits.factor_bytes = limit;
  predicted = -1;
  return limits.cg_amg(rows, [&] { return predicted = analysed_bytes(A, copies, what); })
             ? DistributedGlobalStep::Solver::CgGamg
             : DistributedGlobalStep::Solver::Mumps;
}

}  // namespace

DistributedGlobalStep::DistributedGlobalStep(SpMat&& K, const DirichletData& bc,
                                             const Eigen::MatrixXd& X_own,
                                             const std::vector<int>& node_rank, Solver solver,
                                             bool parts, int newton_dim)
    : bc_(bc), solver_(solver), num_nodes_(static_cast<int>(K.rows())) {
  bc.check(num_nodes_);
  const auto t0 = std::chrono::steady_clock::now();
  const int n = static_cast<int>(K.rows());
  const int P = mpi::size(), me = mpi::rank();
  for (std::vector<int>& components : components_by_dirichlet_set(bc)) {
    groups_.push_back(std::make_unique<Group>());
    groups_.back()->components = std::move(components);
  }
  // CG + GAMG's tolerance: the serial CG + AMG's, inexact (CgAmg::target), unless the PETSc
  // option -ltl_mpi_rtol asks every solve for that relative reduction.
  PetscReal rtol = 0;
  PetscBool tight = PETSC_FALSE;
  PetscOptionsGetReal(nullptr, nullptr, "-ltl_mpi_rtol", &rtol, &tight);
  if (tight)
    rtol_ = rtol;
  else
    eta_ = CgAmg::eta_option();
  for (auto& gp : groups_) {
    Group& g = *gp;
    // The free nodes, each rank's block of rows those of its nodes (node_rank: the rows of its
    // cells' part of K), in their index order.
    std::vector<int> local(n, -1);
    std::vector<char> fixed(n, 0);
    for (int i : bc.fixed[g.components[0]]) fixed[i] = 1;
    std::vector<int> free_node;  // in the mesh's order, then in the ranks' blocks (node)
    for (int i = 0; i < n; ++i)
      if (!fixed[i]) free_node.push_back(i);
    const int nf = static_cast<int>(free_node.size()), nc = static_cast<int>(g.components.size());
    if (static_cast<int>(node_rank.size()) != n)
      throw Error(cat("the distributed global step (4.5): ranks of ", node_rank.size(),
                      " nodes for ", n, " rows"));
    std::vector<int> rank(nf);
    for (int k = 0; k < nf; ++k) rank[k] = node_rank[free_node[k]];
    const mpi::Partition rows = mpi::partition_of_ranks(rank, P);
    std::vector<int> node(nf);
    for (int k = 0; k < nf; ++k) node[k] = free_node[rows.order[k]];
    std::vector<int>().swap(free_node);
    g.offset = rows.offset;
    for (int k = 0; k < nf; ++k) local[node[k]] = k;
    g.what = cat("distributed global matrix (4.5), ", nf, " free nodes");
    const int f0 = g.offset[me], f1 = g.offset[me + 1], own = f1 - f0;
    g.own_node.assign(node.begin() + f0, node.begin() + f1);
    // K_ff into PETSc's matrix, K_fd u_d into the shift (K is symmetric: row i is column i, the
    // columns in the free numbering): each rank adds the rows it holds, every row of its part of
    // K (parts), else its own block of rows; the rows of other ranks travel at the assembly
    // (ADD_VALUES). First into MATPREALLOCATOR (the exact pattern), then into the matrix.
    std::vector<PetscInt> cols;
    std::vector<PetscScalar> vals;
    std::vector<Vec> shift(nc, nullptr);
    auto add_rows = [&](Mat M, bool with_shift) {
      for (int j = 0; j < n; ++j) {
        const PetscInt row = local[j];
        if (row < 0 || (!parts && (row < f0 || row >= f1))) continue;
        cols.clear();
        vals.clear();
        for (SpMat::InnerIterator it(K, j); it; ++it) {
          const int m = static_cast<int>(it.row());
          if (local[m] >= 0) {
            cols.push_back(local[m]);
            vals.push_back(it.value());
          } else if (with_shift) {
            for (int k = 0; k < nc; ++k)
              check(VecSetValue(shift[k], row, it.value() * bc.value_at(m, g.components[k]),
                                ADD_VALUES),
                    g.what, "VecSetValue");
          }
        }
        if (!cols.empty())
          check(MatSetValues(M, 1, &row, static_cast<PetscInt>(cols.size()), cols.data(),
                             vals.data(), ADD_VALUES),
                g.what, "MatSetValues");
      }
      check(MatAssemblyBegin(M, MAT_FINAL_ASSEMBLY), g.what, "MatAssemblyBegin");
      check(MatAssemblyEnd(M, MAT_FINAL_ASSEMBLY), g.what, "MatAssemblyEnd");
    };
    {
      Mat pattern = nullptr;
      check(MatCreate(PETSC_COMM_WORLD, &pattern), g.what, "MatCreate");
      check(MatSetSizes(pattern, own, own, nf, nf), g.what, "MatSetSizes");
      check(MatSetType(pattern, MATPREALLOCATOR), g.what, "MatSetType");
      check(MatSetUp(pattern), g.what, "MatSetUp");
      add_rows(pattern, false);
      check(MatCreate(PETSC_COMM_WORLD, &g.A), g.what, "MatCreate");
      check(MatSetSizes(g.A, own, own, nf, nf), g.what, "MatSetSizes");
      check(MatSetType(g.A, MATMPIAIJ), g.what, "MatSetType");
      check(MatPreallocatorPreallocate(pattern, PETSC_TRUE, g.A), g.what,
            "MatPreallocatorPreallocate");
      MatDestroy(&pattern);
    }
    for (Vec& v : shift) {
      check(VecCreateMPI(PETSC_COMM_WORLD, own, nf, &v), g.what, "VecCreateMPI");
      check(VecSet(v, 0.0), g.what, "VecSet");
    }
    add_rows(g.A, true);
    g.shift = Eigen::MatrixXd::Zero(own, nc);
    for (int k = 0; k < nc; ++k) {
      check(VecAssemblyBegin(shift[k]), g.what, "VecAssemblyBegin");
      check(VecAssemblyEnd(shift[k]), g.what, "VecAssemblyEnd");
      const PetscScalar* a = nullptr;
      check(VecGetArrayRead(shift[k], &a), g.what, "VecGetArrayRead");
      for (int r = 0; r < own; ++r) g.shift(r, k) = a[r];
      check(VecRestoreArrayRead(shift[k], &a), g.what, "VecRestoreArrayRead");
      VecDestroy(&shift[k]);
    }
    check(MatSetOption(g.A, MAT_SPD, PETSC_TRUE), g.what, "MatSetOption");
    if (solver_ == Solver::Auto)
      solver_ = auto_choice(g.A, nf, static_cast<int>(groups_.size()) + newton_dim * newton_dim,
                            g.what, predicted_bytes_);
    g.what += solver_ == Solver::Mumps ? ", MUMPS Cholesky" : ", CG + GAMG";
    {  // the near-null space (cg_amg.hpp): constants and centred coordinates, orthonormalized,
      // on the rank's rows (its free nodes among those it owns, X_own's rows in the same
      // order), the means and inner products summed over the ranks
      std::vector<Eigen::VectorXd> basis;
      Eigen::MatrixXd Xf(own, X_own.cols());
      int at = 0;  // X_own's row of node i
      for (int i = 0; i < n; ++i) {
        if (node_rank[i] != me) continue;
        if (at >= X_own.rows())
          throw Error(cat(g.what, ": the positions of ", X_own.rows(), " owned nodes for more"));
        if (local[i] >= 0) Xf.row(local[i] - f0) = X_own.row(at);
        ++at;
      }
      if (at != X_own.rows())
        throw Error(cat(g.what, ": the positions of ", X_own.rows(), " owned nodes for ", at));
      const auto summed = [](double x) {
        mpi::sum(&x, 1);
        return x;
      };
      double largest = own > 0 ? Xf.cwiseAbs().maxCoeff() : 0.0;
      mpi::max(&largest, 1);
      for (int k = 0; k < Xf.cols(); ++k) {
        Eigen::VectorXd v = Xf.col(k).array() - summed(Xf.col(k).sum()) / nf;
        for (int pass = 0; pass < 2; ++pass)
          for (const Eigen::VectorXd& q : basis) v -= summed(q.dot(v)) * q;
        const double nv = std::sqrt(summed(v.squaredNorm()));
        if (nv > 1e-10 * std::sqrt(static_cast<double>(nf)) * (largest + 1e-300))
          basis.push_back(v / nv);
      }
      std::vector<Vec> vecs(basis.size());
      for (std::size_t k = 0; k < basis.size(); ++k) {
        check(VecCreateMPI(PETSC_COMM_WORLD, own, nf, &vecs[k]), g.what, "VecCreateMPI");
        PetscScalar* a = nullptr;
        check(VecGetArray(vecs[k], &a), g.what, "VecGetArray");
        for (int r = 0; r < own; ++r) a[r] = basis[k](r);
        check(VecRestoreArray(vecs[k], &a), g.what, "VecRestoreArray");
      }
      MatNullSpace nsp = nullptr;
      check(MatNullSpaceCreate(PETSC_COMM_WORLD, PETSC_TRUE, static_cast<PetscInt>(vecs.size()),
                               vecs.data(), &nsp),
            g.what, "MatNullSpaceCreate");
      check(MatSetNearNullSpace(g.A, nsp), g.what, "MatSetNearNullSpace");
      MatNullSpaceDestroy(&nsp);
      for (Vec& v : vecs) VecDestroy(&v);
    }
    // K is in PETSc's matrices once the last set's is assembled: released before its AMG setup
    // or factorization, the rank's peak (paper_notes/mpi.md, "What a rank holds at its peak").
    if (gp == groups_.back()) SpMat().swap(K);
    std::vector<int>().swap(local);  // whole-size: not through the AMG setup or the factor
    std::vector<int>().swap(node);
    // MUMPS's workspace: its own estimate plus 20 % (ICNTL(14) = 20, MUMPS's default) first;
    // when that is short (INFOG(1) = -9 on 4 ranks of the 1 080-cell gutter: the factor reports
    // an error, the same on every rank) the KSP is set up again with twice the estimate (100 %).
    // Twice the estimate from the start cost rank 0 87 MB more on 2 ranks of the 102 400-cell
    // gutter (paper_notes/mpi.md).
    for (const int extra : {20, 100}) {
      if (g.ksp) KSPDestroy(&g.ksp);
      check(KSPCreate(PETSC_COMM_WORLD, &g.ksp), g.what, "KSPCreate");
      check(KSPSetOperators(g.ksp, g.A, g.A), g.what, "KSPSetOperators");
      PC pc;
      check(KSPGetPC(g.ksp, &pc), g.what, "KSPGetPC");
      if (solver_ == Solver::Mumps) {  // factored once (KSPSetUp), then a triangular pair a solve
        check(KSPSetType(g.ksp, KSPPREONLY), g.what, "KSPSetType");
        check(PCSetType(pc, PCCHOLESKY), g.what, "PCSetType");
        check(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS), g.what, "PCFactorSetMatSolverType");
      } else {
        check(KSPSetType(g.ksp, KSPCG), g.what, "KSPSetType");
        check(KSPSetNormType(g.ksp, KSP_NORM_UNPRECONDITIONED), g.what, "KSPSetNormType");
        check(KSPSetInitialGuessNonzero(g.ksp, PETSC_TRUE), g.what, "KSPSetInitialGuessNonzero");
        check(PCSetType(pc, PCGAMG), g.what, "PCSetType");
        check(PCGAMGSetType(pc, PCGAMGAGG), g.what, "PCGAMGSetType");
        check(KSPSetTolerances(g.ksp, rtol_, 0.0, PETSC_DEFAULT, kMaxIterations), g.what,
              "KSPSetTolerances");
      }
      check(KSPSetFromOptions(g.ksp), g.what, "KSPSetFromOptions");
      PCType type = nullptr;
      PCGetType(pc, &type);
      Mat F = nullptr;
      if (type && std::string(type) == PCCHOLESKY) {
        check(PCFactorSetUpMatSolverType(pc), g.what, "PCFactorSetUpMatSolverType");
        check(PCFactorGetMatrix(pc, &F), g.what, "PCFactorGetMatrix");
        check(MatMumpsSetIcntl(F, 14, extra), g.what, "MatMumpsSetIcntl");
      }
      {
        const AllAtOnceGalerkinProducts products;
        check(KSPSetUp(g.ksp), g.what, "KSPSetUp (the factor or the AMG hierarchy)");
      }
      release_coarse_products(g.ksp, g.what);
      MatFactorError error = MAT_FACTOR_NOERROR;
      if (F) check(MatFactorGetError(F, &error), g.what, "MatFactorGetError");
      if (error == MAT_FACTOR_NOERROR) break;
    }
    check(MatCreateVecs(g.A, &g.xv, &g.b), g.what, "MatCreateVecs");
    if (solver_ == Solver::CgGamg && eta_ > 0)
      check(VecDuplicate(g.b, &g.r), g.what, "VecDuplicate");
    Mat Ad = nullptr, Ao = nullptr;
    const PetscInt* colmap = nullptr;
    if (!MatMPIAIJGetSeqAIJ(g.A, &Ad, &Ao, &colmap) && Ao) {
      PetscInt rows = 0, cols = 0;
      MatGetSize(Ao, &rows, &cols);
      ghosts_ += cols;
    }
  }
  setup_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

DistributedGlobalStep::~DistributedGlobalStep() = default;

void DistributedGlobalStep::set_ghost_layer(std::vector<int> nodes) {
  const int me = mpi::rank();
  layer_fixed_.assign(bc_.fixed.size(), {});
  for (std::size_t i = 0; i < bc_.fixed.size(); ++i)
    for (std::size_t k = 0; k < bc_.fixed[i].size(); ++k)
      if (const int row = mpi::position_in(nodes, bc_.fixed[i][k]); row >= 0)
        layer_fixed_[i].emplace_back(row, static_cast<int>(k));
  for (auto& gp : groups_) {
    Group& g = *gp;
    const int f0 = g.offset[me], f1 = g.offset[me + 1];
    std::vector<int> free_row(num_nodes_, -1);
    {
      const std::vector<int> node = g.whole_nodes();
      for (std::size_t k = 0; k < node.size(); ++k) free_row[node[k]] = static_cast<int>(k);
    }
    std::vector<int>().swap(g.whole_node);  // u is no longer gathered whole by a solve
    std::vector<double>().swap(g.whole_x);
    g.add_row.clear();
    g.add_at.clear();
    std::vector<int> add_node;  // the mesh node of each added row
    for (std::size_t k = 0; k < nodes.size(); ++k)
      if (const int n = nodes[k]; free_row[n] >= 0) {
        g.add_row.push_back(free_row[n]);
        add_node.push_back(n);
        g.add_at.push_back(static_cast<int>(k));
      }
    g.add_value.resize(g.add_row.size());
    // Read: the added rows and the owned block (the warm start of the next solve), each once.
    std::vector<std::pair<PetscInt, int> > row_node;  // (free row, its mesh node)
    for (std::size_t i = 0; i < g.add_row.size(); ++i)
      row_node.emplace_back(g.add_row[i], add_node[i]);
    for (int r = f0; r < f1; ++r) row_node.emplace_back(r, g.own_node[r - f0]);
    std::sort(row_node.begin(), row_node.end());
    row_node.erase(std::unique(row_node.begin(), row_node.end()), row_node.end());
    std::vector<PetscInt> read(row_node.size());
    g.read_at.resize(row_node.size());
    for (std::size_t i = 0; i < row_node.size(); ++i) {
      read[i] = row_node[i].first;
      g.read_at[i] =
          mpi::position_in(nodes, row_node[i].second);  // the added rows' and the owned rows'
    }
    for (std::size_t r = 0; r < g.own_node.size(); ++r)  // for_each_own_row's merge
      if (mpi::position_in(nodes, g.own_node[r]) < 0 ||
          (r > 0 && g.own_node[r] <= g.own_node[r - 1]))
        throw Error(cat(g.what, ": the ghost layer lacks the rank's own node ", g.own_node[r],
                        ", or its own nodes are not in increasing order"));
    if (g.scatter) VecScatterDestroy(&g.scatter);
    if (g.read) VecDestroy(&g.read);
    IS is = nullptr;
    check(ISCreateGeneral(PETSC_COMM_SELF, static_cast<PetscInt>(read.size()), read.data(),
                          PETSC_COPY_VALUES, &is),
          g.what, "ISCreateGeneral");
    check(VecCreateSeq(PETSC_COMM_SELF, static_cast<PetscInt>(read.size()), &g.read), g.what,
          "VecCreateSeq");
    check(VecScatterCreate(g.xv, is, g.read, nullptr, &g.scatter), g.what, "VecScatterCreate");
    ISDestroy(&is);
  }
  ghost_layer_ = true;
  layer_node_.swap(nodes);
}

// [LTL87 (4.5)] One KSP solve per component of each Dirichlet set, from the warm start u. Without
// a ghost layer b is whole and the owned rows of the solution are gathered to every rank; with
// it b is this rank's part, added into PETSc's vector, and u is scattered back on the rows the
// rank reads.
void DistributedGlobalStep::solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& u) {
  const auto rows = ghost_layer_ ? static_cast<Eigen::Index>(layer_node_.size()) : num_nodes_;
  if (b.rows() != rows)
    throw Error(cat("the distributed global step (4.5): a right-hand side of ", b.rows(),
                    " rows for ", rows));
  if (u.size() == 0) u = Eigen::MatrixXd::Zero(b.rows(), b.cols());  // no warm start
  if (u.rows() != b.rows() || u.cols() != b.cols())
    throw Error(cat("the distributed global step (4.5): a warm start u of ", u.rows(), " x ",
                    u.cols(), " for ", b.rows(), " x ", b.cols(),
                    ghost_layer_ ? " (the ghost layer's rows)" : " (the mesh's nodes)"));
  const int me = mpi::rank();
  for (auto& gp : groups_) {
    Group& g = *gp;
    const int f0 = g.offset[me], own = g.offset[me + 1] - f0;
    for (std::size_t k = 0; k < g.components.size(); ++k) {
      const int c = g.components[k];
      if (ghost_layer_) {  // this rank's part of b, its other ranks' rows by the assembly
        check(VecSet(g.b, 0.0), g.what, "VecSet");
        for (std::size_t i = 0; i < g.add_row.size(); ++i) g.add_value[i] = b(g.add_at[i], c);
        check(VecSetValues(g.b, static_cast<PetscInt>(g.add_row.size()), g.add_row.data(),
                           g.add_value.data(), ADD_VALUES),
              g.what, "VecSetValues");
        check(VecAssemblyBegin(g.b), g.what, "VecAssemblyBegin");
        check(VecAssemblyEnd(g.b), g.what, "VecAssemblyEnd");
      }
      PetscScalar *pb = nullptr, *px = nullptr;
      check(VecGetArray(g.b, &pb), g.what, "VecGetArray");
      check(VecGetArray(g.xv, &px), g.what, "VecGetArray");
      if (ghost_layer_) {
        g.for_each_own_row(layer_node_, [&](int r, int at) {
          pb[r] -= scale_ * g.shift(r, k);
          px[r] = u(at, c);
        });
      } else {
        for (int r = 0; r < own; ++r) {
          const int node = g.own_node[r];
          pb[r] = b(node, c) - scale_ * g.shift(r, k);
          px[r] = u(node, c);
        }
      }
      check(VecRestoreArray(g.b, &pb), g.what, "VecRestoreArray");
      check(VecRestoreArray(g.xv, &px), g.what, "VecRestoreArray");
      const auto t0 = std::chrono::steady_clock::now();
      if (g.r) {  // inexact: the residual target from the warm start's (cg_amg.hpp), one reduction
        check(MatMult(g.A, g.xv, g.r), g.what, "MatMult");
        check(VecAYPX(g.r, -1.0, g.b), g.what, "VecAYPX");
        PetscReal r0 = 0, bn = 0;
        check(VecNormBegin(g.r, NORM_2, &r0), g.what, "VecNormBegin");
        check(VecNormBegin(g.b, NORM_2, &bn), g.what, "VecNormBegin");
        check(VecNormEnd(g.r, NORM_2, &r0), g.what, "VecNormEnd");
        check(VecNormEnd(g.b, NORM_2, &bn), g.what, "VecNormEnd");
        check(KSPSetTolerances(g.ksp, 0.0, CgAmg::target(eta_, r0, bn), PETSC_DEFAULT,
                               kMaxIterations),
              g.what, "KSPSetTolerances");
      }
      check(KSPSolve(g.ksp, g.b, g.xv), g.what, "KSPSolve");
      ksp_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      KSPConvergedReason reason;
      PetscInt its = 0;
      KSPGetConvergedReason(g.ksp, &reason);
      KSPGetIterationNumber(g.ksp, &its);
      if (reason < 0)
        throw Error(cat(g.what, ": the distributed solve failed (", KSPConvergedReasons[reason],
                        ", ", its, " iterations)"));
      iterations_ += its;
      ++solves_;
      if (ghost_layer_) {  // the rows this rank reads
        check(VecScatterBegin(g.scatter, g.xv, g.read, INSERT_VALUES, SCATTER_FORWARD), g.what,
              "VecScatterBegin");
        check(VecScatterEnd(g.scatter, g.xv, g.read, INSERT_VALUES, SCATTER_FORWARD), g.what,
              "VecScatterEnd");
        const PetscScalar* cr = nullptr;
        check(VecGetArrayRead(g.read, &cr), g.what, "VecGetArrayRead");
        for (std::size_t i = 0; i < g.read_at.size(); ++i) u(g.read_at[i], c) = cr[i];
        check(VecRestoreArrayRead(g.read, &cr), g.what, "VecRestoreArrayRead");
        for (const auto& [row, at] : layer_fixed_[c]) u(row, c) = scale_ * bc_.value[c][at];
      } else {
        const PetscScalar* cx = nullptr;
        check(VecGetArrayRead(g.xv, &cx), g.what, "VecGetArrayRead");
        g.gather_into(u, c, cx, g.whole_node, g.whole_x);
        check(VecRestoreArrayRead(g.xv, &cx), g.what, "VecRestoreArrayRead");
        bc_.impose(u, c, scale_);
      }
    }
  }
}

void DistributedGlobalStep::whole_u(Eigen::MatrixXd& u) {
  if (!ghost_layer_) return;
  if (u.rows() != static_cast<Eigen::Index>(layer_node_.size()))
    throw Error(cat("the distributed global step: u of ", u.rows(), " rows on a ghost layer of ",
                    layer_node_.size()));
  Eigen::MatrixXd whole = Eigen::MatrixXd::Zero(num_nodes_, u.cols());
  const int me = mpi::rank();
  for (auto& gp : groups_) {
    Group& g = *gp;
    std::vector<double> own(g.offset[me + 1] - g.offset[me]), x;
    std::vector<int> node;  // gathered once for the set's components, freed on return
    for (const int c : g.components) {
      g.for_each_own_row(layer_node_, [&](int r, int at) { own[r] = u(at, c); });
      g.gather_into(whole, c, own.data(), node, x);
    }
  }
  for (int c = 0; c < whole.cols(); ++c) bc_.impose(whole, c, scale_);
  u.swap(whole);
}

std::vector<DistributedGlobalStep::SetShare> DistributedGlobalStep::set_shares() const {
  std::vector<SetShare> shares;
  const int me = mpi::rank();
  for (const auto& gp : groups_) {
    const Group& g = *gp;
    SetShare s;
    s.components = static_cast<int>(g.components.size());
    s.free_rows = g.offset.back();
    s.owned = g.offset[me + 1] - g.offset[me];
    for (const PetscInt r : g.add_row) s.ghosts += r < g.offset[me] || r >= g.offset[me + 1];
    s.bytes = sizeof(int) * (g.components.size() + g.offset.size() + g.own_node.size() +
                             g.add_at.size() + g.read_at.size() + g.whole_node.size()) +
              sizeof(double) * (g.shift.size() + g.whole_x.size()) +
              sizeof(PetscInt) * g.add_row.size() + sizeof(PetscScalar) * g.add_value.size();
    shares.push_back(s);
  }
  return shares;
}

int DistributedGlobalStep::coarse_operators(int* with_products) const {
  int n = 0, held = 0;
  for (const auto& gp : groups_)
    for_each_coarse_operator(gp->ksp, gp->what, [&](Mat coarse) {
      MatProductType product = MATPRODUCT_UNSPECIFIED;
      check(MatProductGetType(coarse, &product), gp->what, "MatProductGetType");
      ++n;
      held += product != MATPRODUCT_UNSPECIFIED;
    });
  if (with_products) *with_products = held;
  return n;
}

double DistributedGlobalStep::factor_bytes() const {
  if (solver_ != Solver::Mumps) return 0;
  double bytes = 0;
  for (const auto& gp : groups_) {
    PC pc = nullptr;
    Mat F = nullptr;
    PetscInt mb = 0;
    check(KSPGetPC(gp->ksp, &pc), gp->what, "KSPGetPC");
    check(PCFactorGetMatrix(pc, &F), gp->what, "PCFactorGetMatrix");
    check(MatMumpsGetInfog(F, 18, &mb), gp->what, "MatMumpsGetInfog");
    bytes += 1e6 * static_cast<double>(mb);
  }
  return bytes;
}

#endif

long DistributedGlobalStep::owned_rows() const {
  long n = 0;
  for (const SetShare& s : set_shares()) n += s.owned;
  return n;
}

long DistributedGlobalStep::layer_ghosts() const {
  long n = 0;
  for (const SetShare& s : set_shares()) n += s.ghosts;
  return n;
}

mpi::Partition graph_cells(const Mesh& mesh, int ranks) {
  const int nc = mesh.num_cells();
  if (ranks == 1) return mpi::partition_of_ranks(std::vector<int>(nc, 0), 1);
  // Rank 0 partitions, the other ranks wait for its parts or its error (every rank throws the
  // same message): one partition of the whole graph, the same whatever the number of processes.
  // PT-Scotch over the ranks would hold a block of the graph each, but its parallel coarsening
  // takes other ranks' messages in their order of arrival.
  std::vector<int> part;
  std::string error;
  if (mpi::rank() == 0) try {
      part = scotch_parts(mesh, ranks);
    } catch (const Error& e) {
      error = e.what();
    }
  error = mpi::broadcast(error);
  if (!error.empty()) throw Error(error);
  part.resize(nc);
  mpi::broadcast(part.data(), nc);
  mpi::Partition p = mpi::partition_of_ranks(part, ranks);
  for (int r = 0; r < ranks; ++r)
    if (p.offset[r + 1] == p.offset[r])
      throw Error(cat("the graph partition of the cells (PT-Scotch) gave rank ", r, " of ", ranks,
                      " no cell of the ", nc, ": fewer ranks, or a finer mesh"));
  return p;
}

}  // namespace ltl

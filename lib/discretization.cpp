#include "discretization.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "cofactor.hpp"
#include "derived_fields.hpp"
#include "error.hpp"
#include "mpi_comm.hpp"

namespace ltl {

namespace {
/// The points of several obstacles, one after the other (ContactPoints::offset): the rows of
/// `mean` and of every per-point array stacked, `meanT_area` the columns; no one normal N.
ContactPoints stack_obstacles(const std::vector<ContactPoints>& obstacles, int nn) {
  ContactPoints all;
  const int dim = obstacles.front().dim;
  int n = 0;
  all.offset = {0};
  for (const ContactPoints& o : obstacles) all.offset.push_back(n += o.size());
  all.dim = dim;
  all.area.resize(n);
  all.centre.resize(dim, n);
  all.gap.resize(n);
  all.normals.resize(n, dim);
  std::vector<Eigen::Triplet<double>> t, tT;
  const bool facets = !obstacles.front().vertices.empty();
  if (facets) all.vertices.assign(obstacles.front().vertices.size(), Eigen::MatrixXd(dim, n));
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    const ContactPoints& o = obstacles[k];
    const int r0 = all.offset[k], m = o.size();
    all.area.segment(r0, m) = o.area;
    all.centre.middleCols(r0, m) = o.centre;
    all.gap.segment(r0, m) = o.gap;
    all.normals.middleRows(r0, m) = o.normals;
    all.nodes.insert(all.nodes.end(), o.nodes.begin(), o.nodes.end());
    if (facets && o.vertices.size() == all.vertices.size())
      for (std::size_t v = 0; v < o.vertices.size(); ++v)
        all.vertices[v].middleCols(r0, m) = o.vertices[v];
    for (int s = 0; s < m; ++s)
      for (SpMatR::InnerIterator it(o.mean, s); it; ++it)
        t.emplace_back(r0 + s, it.col(), it.value());
    for (int a = 0; a < o.meanT_area.outerSize(); ++a)
      for (SpMatR::InnerIterator it(o.meanT_area, a); it; ++it)
        tT.emplace_back(a, r0 + it.col(), it.value());
  }
  all.mean.resize(n, nn);
  all.mean.setFromTriplets(t.begin(), t.end());
  all.meanT_area.resize(nn, n);
  all.meanT_area.setFromTriplets(tT.begin(), tT.end());
  return all;
}
}  // namespace

Eigen::MatrixXd Discretization::dead_load() const {
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(num_nodes(), dim());
  add_dead_load(F, 1.0);
  return F;
}

void Discretization::add_dead_load(Eigen::MatrixXd& f, double scale) const {
  if (loads_kept_)
    throw Error(
        "the dead loads of every node are asked for on a rank that kept those of its own nodes "
        "alone after its set-up (Discretization::keep_loads): use the state on the ranks' rows");
  for (std::size_t k = 0; k < loaded_.size(); ++k) f.row(loaded_[k]) += scale * F_loaded_.row(k);
}

void Discretization::keep_loads(int n0, int n1, const std::vector<int>& owned) {
  if (!partial_) return;
  std::vector<int> kept;
  std::vector<Eigen::Index> rows;
  for (std::size_t k = 0; k < loaded_.size(); ++k) {
    const int n = loaded_[k];
    if ((n >= n0 && n < n1) || std::binary_search(owned.begin(), owned.end(), n)) {
      kept.push_back(n);
      rows.push_back(static_cast<Eigen::Index>(k));
    }
  }
  Eigen::MatrixXd F = F_loaded_(rows, Eigen::all);
  F_loaded_.swap(F);
  loaded_.swap(kept);
  loads_kept_ = true;
}

const Eigen::MatrixXd& Discretization::on_columns(const Eigen::MatrixXd& u, Eigen::MatrixXd& work,
                                                  const int* u_row) const {
  const std::vector<int>& node = cells_.node;
  if (node.empty() && !u_row) return u;
  const int* row = u_row ? u_row : node.data();
  work.resize(cells_.columns(), u.cols());
  for (Eigen::Index k = 0; k < work.rows(); ++k) work.row(k) = u.row(row[k]);
  return work;
}

Eigen::VectorXd Discretization::volume_rows() const {
  return cells_.vol.replicate(1, dim()).transpose().reshaped();
}

Discretization::Discretization(Problem problem, const std::vector<int>* held)
    : problem_(std::move(problem)) {
  const auto t0 = std::chrono::steady_clock::now();
  problem_.validate();
  const Mesh& mesh = problem_.mesh;
  const int dim = mesh.dim, nc = mesh.num_cells(), nn = mesh.num_nodes();
  partial_ = held && static_cast<int>(held->size()) != nc;

  // The split (2.5)-(2.6) of W: C1 |F|^2 in the global quadratic, the rest local. In plane strain
  // the incompressible Mooney-Rivlin C2 term is C2 (|F|^2 + 1) on det F = 1, so by default it
  // joins the global quadratic on the full gradient (DiscretizationChoice::c2_pointwise).
  split_ = problem_.material;
  if (problem_.discretization.c2_pointwise && dim == 2 && split_.incompressible()) {
    split_.C1 += split_.C2;
    split_.C2 = 0;
  }

  cells_ = cell_operators(mesh, held);
  // On some cells, the held cells as a mesh of their own (part()): the operators' columns are
  // its nodes, the held cells its rows, in their order.
  if (partial_) {
    const std::vector<int>& node = cells_.node;
    part_.dim = dim;
    part_.source = mesh.source;
    part_.X.resize(static_cast<Eigen::Index>(node.size()), dim);
    for (std::size_t j = 0; j < node.size(); ++j)
      part_.X.row(static_cast<Eigen::Index>(j)) = mesh.X.row(node[j]);
    const int nh = static_cast<int>(cells_.cell.size()), npc = mesh.nodes_per_cell();
    part_.cells.resize(nh, npc);
    for (int k = 0; k < nh; ++k)
      for (int a = 0; a < npc; ++a) {
        const int n = mesh.cells(cells_.cell[k], a);
        part_.cells(k, a) =
            static_cast<int>(std::lower_bound(node.begin(), node.end(), n) - node.begin());
      }
    std::vector<char> foreign(nn, 0);  // the nodes of the cells not held
    for (int c = 0, k = 0; c < nc; ++c) {
      if (k < nh && cells_.cell[k] == c) {
        ++k;
        continue;
      }
      for (int a = 0; a < npc; ++a) foreign[mesh.cells(c, a)] = 1;
    }
    part_shared_.resize(node.size());
    for (std::size_t j = 0; j < node.size(); ++j) part_shared_[j] = foreign[node[j]];
  }
  // |Omega| and the centroid below from every cell's volume: on some cells (a rank's) the
  // whole mesh's, made here and dropped, the operators keeping their cells' alone.
  const Eigen::VectorXd mesh_vol = partial_ ? cell_volumes(mesh) : Eigen::VectorXd();
  const Eigen::VectorXd& all_vol = partial_ ? mesh_vol : cells_.vol;
  volume_ = all_vol.sum();

  // Mean-det incompressibility (DiscretizationChoice::mean_det): the point gradients at the
  // cell quadrature points (triangles: degree 4, exact for det(delta), quadratic on affine P2
  // triangles; hexahedra: the 2x2x2 Gauss rule of mean dilatation).
  // (Not for Ogden, Gent: their local energy is not homogeneous of degree 2.)
  mean_det_ = problem_.discretization.mean_det && split_.model == MaterialModel::MooneyRivlin &&
              split_.C2 == 0;
  if (mean_det_) {
    // The reference rule alone (nodes_per_cell x dim per point, for the cell type, not per
    // cell): the point gradients are recomputed cell by cell from the nodes' positions.
    rule_ = reference_rule(mesh);
    nq_ = rule_.size();
    if (nq_ > kMaxPoints)
      throw Error(cat(mesh.source, ": ", nq_, " quadrature points per cell, at most ", kMaxPoints));
  }

  // The contact points of each obstacle, with their initial gaps to its plane (section 6), and
  // the points of all of them, one obstacle after the other (paper_notes/obstacles.md).
  const double scale = std::max(1.0, mesh.X.cwiseAbs().maxCoeff());
  Eigen::VectorXd centroid = Eigen::VectorXd::Zero(dim);
  if (!problem_.contacts.empty()) {
    for (int c = 0; c < nc; ++c) {
      Eigen::VectorXd xc = Eigen::VectorXd::Zero(dim);
      for (int a = 0; a < mesh.nodes_per_cell(); ++a)
        xc += mesh.X.row(mesh.cells(c, a)).transpose();
      centroid += all_vol(c) * xc / mesh.nodes_per_cell();
    }
    centroid /= volume_;
  }
  for (const ContactCondition& cc : problem_.contacts) {
    const Mesh::Boundary& boundary = mesh.boundary(cc.group, cc.key("group"));
    ContactPoints pts = contact_points(mesh, boundary, problem_.discretization.nodal_contact);
    pts.N = cc.plane_normal.head(dim);
    pts.normals = pts.N.transpose().replicate(pts.size(), 1);
    pts.offset = {0, pts.size()};
    // Initial gap g_s = (p0 - x_s) . N at each facet centre or node (paper_notes/section6.md).
    pts.gap.resize(pts.size());
    for (int f = 0; f < pts.size(); ++f)
      pts.gap(f) = (cc.plane_point.head(dim) - pts.centre.col(f)).dot(pts.N);
    // The body must start on the admissible side of the plane: its centroid (cell centres
    // weighted by volume) on the side N points away from. With the normal reversed the
    // contact surface is still at the plane but the body lies in the obstacle, and the
    // iteration wanders without converging.
    {
      const double side = (centroid - cc.plane_point.head(dim)).dot(pts.N);
      if (side > 1e-10 * scale) {
        std::string n, reversed;
        for (int k = 0; k < dim; ++k) {
          n += cat(k ? ", " : "", pts.N(k));
          reversed += cat(k ? ", " : "", pts.N(k) == 0 ? 0.0 : -pts.N(k));
        }
        throw Error(cat(mesh.source,
                        ": the body lies on the obstacle side of the contact plane "
                        "(its centroid is ",
                        side, " m from the plane along ", cc.key("plane_normal"), " = (", n,
                        ")): ", cc.key("plane_normal"),
                        " must point into the obstacle, away "
                        "from the body; reverse it (plane_normal = [",
                        reversed, "]) or check ", cc.key("plane_point")));
      }
    }
    for (int f = 0; f < pts.size(); ++f)
      if (pts.gap(f) < -1e-10 * scale)
        throw Error(cat(mesh.source, ": contact ",
                        problem_.discretization.nodal_contact ? "node " : "facet ", f, " of '",
                        cc.group, "' starts inside the obstacle (gap ", pts.gap(f),
                        " m at its centre): check ", cc.key("plane_point"), " and ",
                        cc.key("plane_normal"), " (the normal points into the obstacle)"));
    // Every node of the body starts on the admissible side (the contact surface was checked
    // above, facet by facet or node by node).
    for (int n = 0; n < nn; ++n) {
      const double inside = (mesh.X.row(n).transpose() - cc.plane_point.head(dim)).dot(pts.N);
      if (inside > 1e-10 * scale)
        throw Error(cat(mesh.source, ": node ", n, " of the body (at ", mesh.X.row(n),
                        ") starts inside the obstacle, ", inside, " m beyond the contact plane",
                        problem_.contacts.size() > 1 ? " of " + cc.origin : std::string(),
                        ": check ", cc.key("plane_point"), " and ", cc.key("plane_normal"),
                        " (the normal points into the obstacle)"));
    }
    face_area_.push_back(face_areas(mesh, boundary, pts));
    obstacles_.push_back(std::move(pts));
  }
  // One obstacle: its points are all the points (no copy); several: stacked.
  if (obstacles_.size() > 1) points_ = stack_obstacles(obstacles_, nn);
  if (points()) contact_area_ = points()->area.sum();
  // On some cells (a rank's), meanT_area's entries are kept by point: its row index of every
  // node goes (ContactPoints::meanT_area_of makes it again where it is read, at the set-up and at
  // the step's end).
  if (partial_) {
    const auto by_point = [](ContactPoints& p) {
      p.meanT_area_by_point = p.meanT_area;
      SpMatR().swap(p.meanT_area);
    };
    for (ContactPoints& p : obstacles_) by_point(p);
    if (points_) by_point(*points_);
  }

  // Dirichlet data per component: fixed parts, symmetry planes, prescribed displacements.
  // A node's component fixed by several conditions is listed once, with the last one's value
  // (the problem's validation refuses conditions that prescribe different values there).
  std::vector<std::vector<std::pair<int, double>>> prescribed(dim);
  for (const auto& d : problem_.dirichlet) {
    for (int node : mesh.boundary_nodes(d.group, d.origin)) {
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      x.head(dim) = mesh.X.row(node).transpose();
      const Eigen::Vector3d value = d.field(x);
      for (int c : d.components) prescribed[c].emplace_back(node, value(c));
    }
  }
  bc_.fixed.assign(dim, {});
  bc_.value.assign(dim, {});
  for (int c = 0; c < dim; ++c) {
    auto& p = prescribed[c];
    std::stable_sort(p.begin(), p.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t k = 0; k < p.size(); ++k) {
      if (k + 1 < p.size() && p[k + 1].first == p[k].first) continue;  // a later one follows
      bc_.fixed[c].push_back(p[k].first);
      bc_.value[c].push_back(p[k].second);
    }
  }

  // [LTL87 (1.2)] The consistent dead loads f and g at load factor 1.
  // Held on the loaded nodes' rows (dead_load() makes the whole array when asked).
  {
    Eigen::MatrixXd F = body_load(mesh, problem_.body_force);
    for (const auto& t : problem_.tractions)
      F += surface_load(mesh, mesh.boundary(t.group, t.origin), t.g);
    for (int i = 0; i < nn; ++i)
      if ((F.row(i).array() != 0.0).any()) loaded_.push_back(i);
    F_loaded_.resize(static_cast<Eigen::Index>(loaded_.size()), dim);
    for (std::size_t k = 0; k < loaded_.size(); ++k) F_loaded_.row(k) = F.row(loaded_[k]);
    largest_dead_load_ = F_loaded_.size() ? F_loaded_.cwiseAbs().maxCoeff() : 0.0;
  }
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// [(2.7), discretization.md] Per cell, with F_k = I + (point gradient at quadrature point k)
// and Fbar = I + (their cell mean):
//   c_e = (1/|O_e|) sum_k w_k det F_k - det Fbar,   force block p_e (cof F_k - cof Fbar),
// p_e = lambda_e : E_e / (d det E_e). In 2-D cof is linear, so c_e is the mean of det(delta_k)
// and the force block p_e cof(delta_k), delta_k = F_k - Fbar. The blocks are transposed tensors;
// det and cof commute with the transpose. With gamma, the block gains gamma (F_k - Fbar): the
// cell's part of gamma (L - GbarT_vol Gbar) u, since sum_k w_k grad_k = |O_e| Gbar_e on the
// rule that assembles L (fe.hpp).
//
// The point gradients are recomputed from the cell's nodes at each call (fe.hpp,
// ReferenceRule): with Xe, ue the cell's positions and displacements and dN_k the reference
// gradients, J_k^T = dN_k^T Xe, (grad u)^T = J_k^-T dN_k^T ue, w_k = w_ref det J_k; the force
// on node a is w_k dN_k(a, :) J_k^-1 S_k. Nothing per cell or per point is stored.
namespace {
template <int d, int npc>
struct FluctuationKernel {
  using Mat = Eigen::Matrix<double, d, d>;
  using Nodal = Eigen::Matrix<double, npc, d>;
  Eigen::Matrix<double, npc, d> dN[Discretization::kMaxPoints];
  double wref[Discretization::kMaxPoints];
  int nq = 0;
  const Eigen::MatrixXi& cells;  ///< Discretization::part()'s: row k the k-th held cell (some
  const Eigen::MatrixXd& X;      ///< cells) or cell k (every cell), on the part's nodes
  const int* node;               ///< the mesh's node of the part's node (some cells), or null
  const Eigen::VectorXd& vol;    ///< the held cells' volumes (CellOperators::vol)
  bool by_position;  ///< some cells: the part's row and vol(at) by position, else by cell
  bool E_by_cell;    ///< E and lambda whole: cell e's block at d e, else at d at

  FluctuationKernel(const ReferenceRule& rule, const Mesh& part, const int* part_node,
                    const Eigen::VectorXd& v, bool position, bool E_whole)
      : nq(rule.size()),
        cells(part.cells),
        X(part.X),
        node(part_node),
        vol(v),
        by_position(position),
        E_by_cell(E_whole) {
    for (int k = 0; k < nq; ++k) {
      dN[k] = rule.dN[k];
      wref[k] = rule.w[k];
    }
  }
  /// The part's row of cell e at position `at`.
  int row(int e, int at) const { return by_position ? at : e; }
  /// The row of u or of the force of the part's node j without a row map: the mesh's node.
  int node_row(int j) const { return node ? node[j] : j; }

  /// Cell e, at position `at` among the cells computed, whose E and lambda are the blocks at rows
  /// d e or d at (E_by_cell) and whose nodes and volume are the part's row and vol(e) or vol(at)
  /// (by_position): returns c_e; with fe, the cell's nodal force (p_e and gamma as above). u's
  /// row of the cell's node a: u_row[a], or the mesh's node (u_row null).
  double operator()(int e, int at, const Eigen::MatrixXd& u, const int* u_row,
                    const Eigen::MatrixXd* lambda, const Eigen::MatrixXd* E, double gamma,
                    double* fe) const {
    Eigen::Matrix<double, npc, 2 * d> XU;  // [Xe ue]
    const int k_e = row(e, at);
    for (int a = 0; a < npc; ++a) {
      const int n = cells(k_e, a);
      XU.row(a).template head<d>() = X.row(n);
      XU.row(a).template tail<d>() = u.row(u_row ? u_row[a] : node_row(n));
    }
    Mat G[Discretization::kMaxPoints], JTinv[Discretization::kMaxPoints];
    double w[Discretization::kMaxPoints];
    Mat Fbar = Mat::Zero();
    for (int k = 0; k < nq; ++k) {
      const Eigen::Matrix<double, d, 2 * d> H = dN[k].transpose() * XU;  // [J^T  dN^T ue]
      const Mat JT = H.template leftCols<d>();
      JTinv[k] = JT.inverse();
      w[k] = wref[k] * JT.determinant();
      G[k].noalias() = JTinv[k] * H.template rightCols<d>();
      Fbar += w[k] * G[k];
    }
    const double vol_e = vol(k_e);
    Fbar /= vol_e;
    Fbar.diagonal().array() += 1.0;
    double p = 0;
    if (lambda) {
      const int row = E_by_cell ? e : at;
      const Mat Ee = E->block<d, d>(d * row, 0);
      p = (lambda->block<d, d>(d * row, 0).cwiseProduct(Ee)).sum() / (d * Ee.determinant());
    }
    const Mat cof_bar = (d == 3 && fe) ? cofactor<d>(Fbar) : Mat::Zero();
    Eigen::Map<Nodal> force(fe ? fe : nullptr);
    if (fe) force.setZero();
    double mean_det = 0;
    for (int k = 0; k < nq; ++k) {
      Mat F = G[k];
      F.diagonal().array() += 1.0;
      Mat S;
      if constexpr (d == 2) {  // the linear term cancels exactly: det and cof of delta directly
        mean_det += w[k] * (F - Fbar).determinant();
        if (fe) S = p * cofactor<d>(F - Fbar);
      } else {
        mean_det += w[k] * F.determinant();
        if (fe) S = p * (cofactor<d>(F) - cof_bar);
      }
      if (fe) {
        if (gamma != 0) S += gamma * (F - Fbar);
        const Mat M = w[k] * (JTinv[k].transpose() * S);
        force.noalias() += dN[k] * M;
      }
    }
    return d == 2 ? mean_det / vol_e : mean_det / vol_e - Fbar.determinant();
  }
};

/// c (when non-null) and force += the cells' nodal forces (when non-null). The cells run in
/// parallel; the forces are summed onto the nodes block by block, in cell order, from a buffer of
/// kBlock cells (memory per block, not per cell). On the cells `cells` (sorted; null: all n),
/// whose rows of lambda and E and entries of c are their positions in the list.
template <int d, int npc>
void fluctuation_loop(const FluctuationKernel<d, npc>& kernel, const Eigen::MatrixXd& u,
                      const Eigen::MatrixXd* lambda, const Eigen::MatrixXd* E, double gamma,
                      Eigen::VectorXd* c, Eigen::MatrixXd* force, std::vector<double>& buffer,
                      std::vector<int>& rows, const std::vector<int>* cells, int n,
                      const int* row_of) {
  constexpr int kBlock = 2048, kNodal = npc * d;
  if (force) buffer.resize(static_cast<std::size_t>(kBlock) * kNodal);
  if (force && row_of) rows.resize(static_cast<std::size_t>(kBlock) * npc);
  if (cells) n = static_cast<int>(cells->size());
  // With row_of, the rows of u and of the force of the k-th cell's nodes: row_of[j], j the node of
  // the part (the operators' column: the node itself when every cell is held).
  const auto rows_of = [&](int e, int k, int* row) {
    for (int a = 0; a < npc; ++a) row[a] = row_of[kernel.cells(kernel.row(e, k), a)];
  };
  for (int b0 = 0; b0 < n; b0 += kBlock) {
    const int b1 = std::min(n, b0 + kBlock);
#pragma omp parallel for schedule(static)
    for (int k = b0; k < b1; ++k) {
      const int e = cells ? (*cells)[k] : k;
      int alone[npc];  // the rows, kept for the scatter below when there is a force
      int* row = force && row_of ? rows.data() + static_cast<std::size_t>(k - b0) * npc : alone;
      if (row_of) rows_of(e, k, row);
      double* fe = force ? buffer.data() + static_cast<std::size_t>(k - b0) * kNodal : nullptr;
      const double ce = kernel(e, k, u, row_of ? row : nullptr, lambda, E, gamma, fe);
      if (c) (*c)(k) = ce;
    }
    if (!force) continue;
    for (int k = b0; k < b1; ++k) {
      const Eigen::Map<const Eigen::Matrix<double, npc, d>> fe(
          buffer.data() + static_cast<std::size_t>(k - b0) * kNodal);
      const int e = cells ? (*cells)[k] : k;
      const int* row = row_of ? rows.data() + static_cast<std::size_t>(k - b0) * npc : nullptr;
      for (int a = 0; a < npc; ++a)
        force->row(row ? row[a] : kernel.node_row(kernel.cells(kernel.row(e, k), a))) += fe.row(a);
    }
  }
}
}  // namespace

void Discretization::fluctuation(const Eigen::MatrixXd& u, const Eigen::MatrixXd* lambda,
                                 const Eigen::MatrixXd* E, Eigen::VectorXd* c,
                                 Eigen::MatrixXd* force, double gamma,
                                 const std::vector<int>* cells, const int* row_of) const {
  // The point gradients are recomputed per cell from the nodes' positions (no per-cell or
  // per-point table: memory per cell, not speed, limits the 3-D problems).
  // On some cells, their own list (their nodes and volumes are held by position, part()); row_of
  // by the part's node, the operators' column.
  if (partial_ && !cells) cells = &cells_.cell;
  if (partial_ && cells != &cells_.cell && *cells != cells_.cell)
    throw Error("fluctuation: a discretization of some cells computes the held cells' list");
  const Mesh& mesh = part();
  const int* node = partial_ ? cells_.node.data() : nullptr;
  // E and lambda whole (cell_row), or in the order of `cells`.
  const bool E_by_cell = E && whole_field(*E);
  if (dim() == 2)
    fluctuation_loop<2, 6>(
        FluctuationKernel<2, 6>(rule_, mesh, node, cells_.vol, partial_, E_by_cell), u, lambda, E,
        gamma, c, force, buffer_, rows_, cells, num_cells(), row_of);
  else if (mesh.nodes_per_cell() == 10)
    fluctuation_loop<3, 10>(
        FluctuationKernel<3, 10>(rule_, mesh, node, cells_.vol, partial_, E_by_cell), u, lambda, E,
        gamma, c, force, buffer_, rows_, cells, num_cells(), row_of);
  else
    fluctuation_loop<3, 8>(
        FluctuationKernel<3, 8>(rule_, mesh, node, cells_.vol, partial_, E_by_cell), u, lambda, E,
        gamma, c, force, buffer_, rows_, cells, num_cells(), row_of);
}

Eigen::VectorXd Discretization::fluctuation_det(const Eigen::MatrixXd& u, const int* u_row) const {
  Eigen::VectorXd c = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(held_cells().size()));
  if (mean_det_) fluctuation(u, nullptr, nullptr, &c, nullptr, 0.0, nullptr, u_row);
  return c;
}

Eigen::MatrixXd Discretization::fluctuation_force(const State& s) const {
  Eigen::MatrixXd force = Eigen::MatrixXd::Zero(num_nodes(), dim());
  if (!mean_det_) return force;
  // Every cell here, or on some cells (a rank's) the held cells' part, summed over the ranks
  // (collective); E and lambda whole or on the held cells' rows (cell_row).
  fluctuation(s.u, &s.lambda, &s.E, nullptr, &force, 0.0);
  if (partial_) mpi::sum(force.data(), force.size());
  return force;
}

Eigen::MatrixXd Discretization::piola(const State& s) const {
  return 2 * split_.C1 * s.E - s.lambda;
}

Eigen::MatrixXd Discretization::cauchy(const State& s) const {
  const int d = dim(), nc = static_cast<int>(s.E.rows() / d);  // whole, or the held cells' rows
  const Eigen::MatrixXd P = piola(s);
  Eigen::MatrixXd sigma(d * nc, d);
  for (int c = 0; c < nc; ++c) {
    const Eigen::MatrixXd Eb = s.E.block(d * c, 0, d, d), Pb = P.block(d * c, 0, d, d);
    sigma.block(d * c, 0, d, d) = Eb.transpose() * Pb / Eb.determinant();  // (P E^T)^T / det E
  }
  return sigma;
}

// (1.5) in plane strain: sigma33 from the law at F33 = 1 and the cell's pressure; the mean stress
// counts it, so that the pressure is the same in 2-D and 3-D.
Discretization::Stresses Discretization::stresses(const State& s) const {
  const int d = dim(), nc = static_cast<int>(s.E.rows() / d);  // whole, or the held cells' rows
  Stresses out;
  out.P = piola(s);
  out.sigma = cauchy(s);
  out.pressure.resize(nc);
  if (d == 2) out.sigma33.resize(nc);
  for (int c = 0; c < nc; ++c) {
    double trace = out.sigma.block(d * c, 0, d, d).trace();
    if (out.sigma33.size()) {
      const Eigen::Matrix2d E = s.E.block<2, 2>(2 * c, 0).transpose();
      const Eigen::Matrix2d P = out.P.block<2, 2>(2 * c, 0).transpose();
      out.sigma33(c) = problem_.material.plane_strain_sigma33(E, P);
      trace += out.sigma33(c);
    }
    out.pressure(c) = -trace / 3;
  }
  return out;
}

Eigen::VectorXd Discretization::normal_component(const Eigen::MatrixXd& v) const {
  const ContactPoints* pts = points();
  if (!pts) return Eigen::VectorXd(0);
  if (pts->N.size()) return v * pts->N;  // one obstacle
  return v.cwiseProduct(pts->normals).rowwise().sum();
}

Eigen::VectorXd Discretization::contact_pressure(const State& s) const {
  const ContactPoints* pts = points();
  if (!pts) return Eigen::VectorXd(0);
  // -lambda_c . N_k per contact point: the nominal contact pressure (Pa), before any reading.
  Eigen::VectorXd p = normal_component(s.lambda_c);
  p = -p;
  if (pts->nodes.empty()) return p;
  // Nodal contact: read consistently on P2 triangle faces (derived_fields.hpp), per obstacle.
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const int r0 = pts->offset[k], m = obstacles_[k].size();
    p.segment(r0, m) =
        consistent_nodal_pressure(problem_.mesh, problem_.mesh.boundary(problem_.contacts[k].group),
                                  face_area_[k], obstacles_[k], p.segment(r0, m));
  }
  return p;
}

Eigen::VectorXd Discretization::contact_forces(const State& s) const {
  const ContactPoints* pts = points();
  if (!pts) return Eigen::VectorXd(0);
  return pts->area.cwiseProduct(-normal_component(s.lambda_c));
}

Eigen::VectorXd Discretization::contact_gap(const State& s) const {
  const ContactPoints* pts = points();
  if (!pts) return {};
  return pts->gap - normal_component(s.e);
}

double Discretization::elastic_energy(const State& s, const Eigen::MatrixXd& F) const {
  const int d = dim();
  const Material& m = split_;
  double J = 0;  // over the held cells (E whole or on their rows, cell_row)
  const std::vector<int>& held = held_cells();
  Eigen::MatrixXd work;
  const Eigen::MatrixXd& uc = on_columns(s.u, work);  // on the operators' columns
  const Eigen::MatrixXd GU = cells_.Gbar * uc;        // the held cells' rows
  double mean2 = 0;
  for (int at = 0; at < static_cast<int>(held.size()); ++at) {
    const Eigen::Index r = cell_row(s.E, held[at], at);
    const double vol = cells_.vol(at);
    if (d == 2)
      J += vol * m.W(Eigen::Matrix2d(s.E.block<2, 2>(r, 0).transpose()));
    else
      J += vol * m.W(Eigen::Matrix3d(s.E.block<3, 3>(r, 0).transpose()));
    mean2 += vol * GU.middleRows(static_cast<Eigen::Index>(d) * at, d).squaredNorm();
  }
  const double grad2 = (uc.transpose() * (cells_.laplacian * uc)).trace();
  if (partial_) {  // the held cells' parts summed over the ranks
    double parts[3] = {J, grad2, mean2};
    mpi::sum(parts, 3);
    return parts[0] + m.C1 * (parts[1] - parts[2]) -
           (F.size() ? (F.array() * s.u.array()).sum() : 0.0);
  }
  return J + m.C1 * (grad2 - mean2) - (F.size() ? (F.array() * s.u.array()).sum() : 0.0);
}

Eigen::MatrixXd Discretization::held_cell_forces_on_columns(
    const Eigen::MatrixXd& u,
    const std::function<void(int c0, int n, int at, Eigen::MatrixXd& T)>& stress,
    const State* less_fluctuation, const int* u_row) const {
  const int d = dim();
  Eigen::MatrixXd work;
  const Eigen::MatrixXd& uc = on_columns(u, work, u_row);  // on the operators' columns
  Eigen::MatrixXd f = 2 * split_.C1 * (cells_.laplacian * uc);
  Eigen::MatrixXd T;
  mpi::for_each_run(held_cells(), [&](int c0, int n, int at) {
    T.noalias() = cells_.Gbar.middleRows(d * at, d * n) * uc;
    stress(c0, n, at, T);
    add_cell_forces(cells_, n, at, T, f, nullptr);
  });
  if (less_fluctuation && mean_det_) {  // f - force as -(-f + force): negation is exact
    const State& s = *less_fluctuation;
    // On some cells u and the force by column (row_of the identity on the columns).
    std::vector<int> column;
    if (partial_) {
      column.resize(cells_.node.size());
      for (std::size_t j = 0; j < column.size(); ++j) column[j] = static_cast<int>(j);
    }
    f = -f;
    fluctuation(uc, &s.lambda, &s.E, nullptr, &f, 0.0, nullptr,
                column.empty() ? nullptr : column.data());
    f = -f;
  }
  return f;
}

Eigen::MatrixXd Discretization::held_cell_forces(
    const Eigen::MatrixXd& u,
    const std::function<void(int c0, int n, int at, Eigen::MatrixXd& T)>& stress,
    const State* less_fluctuation) const {
  Eigen::MatrixXd f = held_cell_forces_on_columns(u, stress, less_fluctuation);
  if (cells_.node.empty()) return f;  // every cell: the columns are the nodes
  // Column j's force goes to its node's row.
  Eigen::MatrixXd whole = Eigen::MatrixXd::Zero(num_nodes(), dim());
  for (std::size_t j = 0; j < cells_.node.size(); ++j)
    whole.row(cells_.node[j]) = f.row(static_cast<Eigen::Index>(j));
  f = Eigen::MatrixXd();
  if (partial_) mpi::sum(whole.data(), whole.size());
  return whole;
}

Eigen::MatrixXd Discretization::energy_gradient(const Eigen::MatrixXd& u,
                                                const Eigen::MatrixXd& F) const {
  const int d = dim(), nc = num_cells();
  const Material& m = split_;
  // P_e = dW(I + Gbar_e u)^T in the rows of Gbar_e u, for n cells.
  auto piola = [&](int n, const Eigen::MatrixXd& GU, Eigen::MatrixXd& P) {
    for (int k = 0; k < n; ++k) {
      if (d == 2) {
        const Eigen::Matrix2d Fc =
            Eigen::Matrix2d::Identity() + GU.block<2, 2>(2 * k, 0).transpose();
        P.block<2, 2>(2 * k, 0) = m.dW(Fc).transpose();
      } else {
        const Eigen::Matrix3d Fc =
            Eigen::Matrix3d::Identity() + GU.block<3, 3>(3 * k, 0).transpose();
        P.block<3, 3>(3 * k, 0) = m.dW(Fc).transpose();
      }
    }
  };
  Eigen::MatrixXd g;
  if (partial_) {  // the held cells' part, run by run (no GbarT_vol), summed over the ranks
    Eigen::MatrixXd P;
    g = held_cell_forces(u, [&](int, int n, int, Eigen::MatrixXd& T) {
      P.resize(T.rows(), T.cols());
      piola(n, T, P);
      T = P - 2 * m.C1 * T;
    });
    g -= F;
  } else {
    const Eigen::MatrixXd GU = cells_.Gbar * u;
    Eigen::MatrixXd P(d * nc, d);
    piola(nc, GU, P);
    g = cells_.GbarT_vol * P + 2 * m.C1 * (cells_.laplacian * u - cells_.GbarT_vol * GU) - F;
  }
  for (int c = 0; c < d; ++c)
    for (int i : bc_.fixed[c]) g(i, c) = 0;
  return g;
}

}  // namespace ltl

#include "admissibility.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "error.hpp"
#include "measures.hpp"
#include "mpi_comm.hpp"
#include "signed_svd.hpp"

namespace ltl {

namespace {

std::string position(const Eigen::MatrixXd& X, int n) {
  std::string s = "(";
  for (int k = 0; k < X.cols(); ++k) s += cat(k ? ", " : "", X(n, k));
  return s + ")";
}

/// Cell c and its reference centroid (the mean of its nodes), read on the part of the rank
/// that holds it (Discretization::part()) and summed over the ranks on some cells (collective:
/// every rank asks for the same cell).
std::string cell_where(const Discretization& d, int c) {
  const Mesh& part = d.part();
  Eigen::RowVectorXd x = Eigen::RowVectorXd::Zero(part.dim);
  const std::vector<int>& held = d.held_cells();
  const auto it = std::lower_bound(held.begin(), held.end(), c);
  if (it != held.end() && *it == c) {
    const int k = d.part_row(c, static_cast<int>(it - held.begin()));
    for (int a = 0; a < part.nodes_per_cell(); ++a) x += part.X.row(part.cells(k, a));
    x /= part.nodes_per_cell();
  }
  if (d.partial()) mpi::sum(x.data(), x.size());
  return cat("cell ", c, " (centre ", position(x, 0), ")");
}

/// The rotation of the polar decomposition A = R U (U symmetric positive definite when
/// det A > 0; otherwise the rotation closest to A), as a 3x3 rotation (2-D: about x3).
Eigen::Matrix3d polar_rotation(const Eigen::MatrixXd& A) {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (A.rows() == 2) {
    // 2-D closed form: R(theta) maximizes tr(R^T A), theta = atan2(A21 - A12, A11 + A22).
    const double t = std::atan2(A(1, 0) - A(0, 1), A(0, 0) + A(1, 1));
    R.topLeftCorner<2, 2>() << std::cos(t), -std::sin(t), std::sin(t), std::cos(t);
  } else {
    // [LTL87 (5.4)] A = Q diag(d) P^T with Q, P rotations: R = Q P^T.
    Eigen::Matrix3d Q, P;
    Eigen::Vector3d d;
    signed_svd(Eigen::Matrix3d(A), Q, d, P);
    R = Q * P.transpose();
  }
  return R;
}

/// The angle (degrees) of the rotation R1^T R2, acos((tr(R1^T R2) - 1) / 2).
double angle_between(const Eigen::Matrix3d& R1, const Eigen::Matrix3d& R2) {
  const double c = ((R1.transpose() * R2).trace() - 1) / 2;
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180 / M_PI;
}

/// Keeps (v, cell) if `value` at `c` is more extreme (the smaller, or with `largest` the larger;
/// a NaN wins over any number): a loop over cells in increasing order keeps the first cell of
/// the extreme.
void keep_extreme(double value, int c, double& v, int& cell, bool largest) {
  const bool more = largest ? value > v : value < v;
  if (more || (std::isnan(value) && !std::isnan(v))) v = value, cell = c;
}

/// A discretization of some cells (a rank's, d.partial()): each rank's extreme (v, cell) over
/// its cells made the extreme over all ranks, on every rank (collective). The ranks' extremes are
/// folded by keep_extreme in the order of their cells, from a rank that kept none (its v is the
/// starting value, cell -1) or else from the first: the extreme and the cell that the loop over
/// every cell in increasing order keeps (the first NaN, else the first cell of the extreme).
void extreme_over_ranks(const Discretization& d, double& v, int& cell, bool largest) {
  if (!d.partial()) return;
  const int P = mpi::size(), me = mpi::rank();
  std::vector<double> all(2 * static_cast<std::size_t>(P), 0.0);  // (cell, v) of every rank
  all[2 * me] = cell, all[2 * me + 1] = v;
  mpi::sum(all.data(), static_cast<long>(all.size()));
  std::vector<std::pair<int, double>> kept(P);
  for (int r = 0; r < P; ++r) kept[r] = {static_cast<int>(all[2 * r]), all[2 * r + 1]};
  std::sort(kept.begin(), kept.end(),
            [](const auto& x, const auto& y) { return x.first < y.first; });
  cell = kept[0].first, v = kept[0].second;
  for (int r = 1; r < P; ++r)
    if (kept[r].first >= 0) keep_extreme(kept[r].second, kept[r].first, v, cell, largest);
}

/// The sum over the ranks of a count (a discretization of some cells; collective).
int count_over_ranks(const Discretization& d, int n) {
  double x = n;
  if (d.partial()) mpi::sum(&x, 1);
  return static_cast<int>(x);
}

}  // namespace

double min_det_F(const Discretization& d, const Eigen::MatrixXd& u, int* cell, int* cells_inverted,
                 const std::vector<int>* u_nodes) {
  const Mesh& part = d.part();  // the held cells' nodes and positions
  const int dim = part.dim, npc = part.nodes_per_cell();
  double worst = std::numeric_limits<double>::infinity();
  int inverted = 0, worst_cell = -1;
  Eigen::MatrixXd Uc(npc, dim), F(dim, dim);
  const auto row_of = [&](int j) {  // u's row of the part's node j
    const int n = d.part_node(j), row = u_nodes ? mpi::position_in(*u_nodes, n) : n;
    if (row < 0) throw Error(cat("min_det_F: node ", n, " is not one of u's rows"));
    return row;
  };
  const std::vector<int>& held = d.held_cells();  // every cell, or a rank's (reduced below)
  for (int at = 0; at < static_cast<int>(held.size()); ++at) {
    const int c = held[at], k = d.part_row(c, at);
    for (int a = 0; a < npc; ++a) Uc.row(a) = u.row(row_of(part.cells(k, a)));
    double cell_min = std::numeric_limits<double>::infinity();
    for_each_quadrature_point(part, k, [&](const Eigen::MatrixXd& grad, double) {
      // grad u = sum_a u_a (x) grad phi_a = Uc^T grad; F = I + grad u.
      F.noalias() = Uc.transpose() * grad;
      F.diagonal().array() += 1.0;
      cell_min = std::min(cell_min, F.determinant());
    });
    if (!(cell_min > 0)) ++inverted;
    keep_extreme(cell_min, c, worst, worst_cell, false);
  }
  extreme_over_ranks(d, worst, worst_cell, false);
  inverted = count_over_ranks(d, inverted);
  if (cell && worst_cell >= 0) *cell = worst_cell;
  if (cells_inverted) *cells_inverted = inverted;
  return worst;
}

AdmissibilityReport check_admissibility(const Discretization& d, const State& s,
                                        const IterateRows* at) {
  AdmissibilityReport r;
  const Problem& pb = d.problem();
  const Mesh& mesh = pb.mesh;
  const int dim = mesh.dim, nc = mesh.num_cells(), nn = mesh.num_nodes();
  // Every node against the obstacles needs every node's position: with u whole, the mesh's X,
  // which the ranks of a distributed run release after their set-up (Mesh::release_X; every
  // rank alike), keeping it on their layers' rows (IterateRows::X).
  if (mesh.X.rows() == 0 && nn > 0 && !(at && at->X))
    throw Error(cat("check_admissibility: a whole state on rank ", mpi::rank(),
                    ", which released the mesh's positions after its set-up: check the state on "
                    "the ranks' rows (Solver::state_rows)"));
  r.h = std::pow(d.volume() / std::max(1, nc), 1.0 / dim);
  // "node n at reference X, deformed x = X + u", made where it is read (no #nodes x dim copy:
  // it was the step's end's largest transient on a rank, paper_notes/mpi.md); with `at` n's rows
  // of u and X (the mesh's, or IterateRows::X once a rank has released it) from the ranks whose
  // layer holds it (collective: every rank asks for the same node).
  const auto node_at = [&](int n) {
    const Eigen::MatrixXd Xn = X_at_nodes(mesh, {n}, at), un = u_at_nodes(s, {n}, at);
    return cat("node ", n, " at reference ", position(Xn, 0), ", deformed ",
               position(Eigen::MatrixXd(Xn + un), 0));
  };
  // The nodes this rank checks against the planes and their rows of u: every node, or with `at`
  // those it owns (each node on one rank), in increasing order.
  std::vector<int> own_nodes, own_rows;
  if (at) {
    for (int row : *at->owned) own_nodes.push_back((*at->nodes)[row]), own_rows.push_back(row);
  } else {
    own_nodes.resize(nn);
    for (int n = 0; n < nn; ++n) own_nodes[n] = n;
  }

  // 1. Obstacle: every node of the body on the admissible side of the plane. The contact
  // surface is held by the discretization at its contact points only (its nodes, or its facet
  // means with discretization.contact = "facet-mean", whose P2 nodes may zig-zag about the plane,
  // section8.md), and there through e (e . N <= g), which u meets up to the constraint residual
  // ubar - e of the converged iterate: there the contact points are checked, each with that
  // residual allowed; every other node is checked against the plane.
  // Several obstacles: every node against every plane, each obstacle's points against its own.
  double worst_excess = -std::numeric_limits<double>::infinity();
  std::string worst;
  for (int k = 0; k < static_cast<int>(pb.contacts.size()); ++k) {
    const ContactCondition& cc = pb.contacts[k];
    const Eigen::VectorXd N = cc.plane_normal.head(dim);
    const Eigen::VectorXd p0 = cc.plane_point.head(dim);
    r.inside_tol = kInsideTolerance * r.h;
    std::vector<char> on_surface(nn, 0);
    const ContactPoints* pts = d.points();
    const bool points = pts && s.e.rows() == pts->size();
    const int r0 = points && !pts->offset.empty() ? pts->offset[k] : 0;
    const int r1 = points && !pts->offset.empty() ? pts->offset[k + 1] : points ? pts->size() : 0;
    if (points)
      for (int n : mesh.boundary_nodes(cc.group)) on_surface[n] = 1;
    // A point inside beyond its tolerance: counted, and described if it is the deepest so far.
    const auto record = [&](double depth, double tol, const auto& where) {
      if (depth <= tol) return;
      ++r.nodes_inside;
      if (!(depth - tol <= worst_excess)) worst_excess = depth - tol, worst = where();
    };
    // The nodes off the contact surface, in increasing order: the deepest (the first of the
    // deepest) and the deepest beyond the tolerance, over the ranks' nodes with `at`.
    double max_inside = -std::numeric_limits<double>::infinity(), excess = max_inside;
    int max_node = -1, excess_node = -1, inside = 0;
    for (std::size_t j = 0; j < own_nodes.size(); ++j) {
      const int n = own_nodes[j];
      const Eigen::Index row = at ? own_rows[j] : n;
      double depth = 0;  // (x - p0) . N
      for (int c = 0; c < dim; ++c)
        depth += (X_at(mesh, at, n, row, c) + s.u(row, c) - p0(c)) * N(c);
      if (depth > max_inside || std::isnan(depth)) max_inside = depth, max_node = n;
      if (!on_surface[n] && depth > r.inside_tol) {
        ++inside;
        if (!(depth - r.inside_tol <= excess)) excess = depth - r.inside_tol, excess_node = n;
      }
    }
    if (at) {
      extreme_over_ranks(d, max_inside, max_node, true);
      extreme_over_ranks(d, excess, excess_node, true);
      inside = count_over_ranks(d, inside);
    }
    if (max_inside > r.max_inside || std::isnan(max_inside))
      r.max_inside = max_inside, r.inside_node = max_node;
    r.nodes_inside += inside;
    if (excess_node >= 0 && !(excess <= worst_excess)) {
      const int n = excess_node;
      const double depth = excess + r.inside_tol;
      worst_excess = excess;
      worst = cat(node_at(n), ", ", depth, " m inside");
    }
    if (points) {
      const Eigen::MatrixXd ubar = point_means(*pts, s, at);  // #points x dim
      const Eigen::MatrixXd xbar = point_reference(*pts, mesh, at) + ubar;
      const bool nodal = !pts->nodes.empty();
      for (int i = r0; i < r1; ++i) {
        const double depth = (xbar.row(i).transpose() - p0).dot(N);
        const double residual = std::abs((ubar.row(i) - s.e.row(i)).dot(N));
        record(depth, r.inside_tol + (std::isfinite(residual) ? residual : 0.0), [&] {
          const std::string where =
              nodal ? node_at(pts->nodes[i])
                    : cat("contact facet ", i, " (mean of its nodes at reference ",
                          position(pts->centre.transpose(), i), ", deformed ", position(xbar, i),
                          ")");
          return cat(where, ", ", depth, " m inside (constraint residual ", residual, " m)");
        });
      }
    }
  }
  if (!pb.contacts.empty()) {
    if (r.nodes_inside > 0) {
      r.failures.push_back(cat(r.nodes_inside, " points of the body are inside the obstacle",
                               pb.contacts.size() > 1 ? "s" : "", " ((x - p0) . N > ", r.inside_tol,
                               " m); the deepest is ", worst));
      r.remedies.push_back(
          "the body went through the obstacle (the unilateral condition (1.1) holds on the "
          "contact surface only, and a dead load admits equilibria turned through the plane): "
          "apply the load progressively ([load] ramp = \"linear\", ramp_time, more time.steps) "
          "or try algorithm.acceleration = \"anderson\"; check that contact.plane_normal points "
          "into the obstacle");
    }
  }

  // 2. Orientation: det F > 0 at every quadrature point, det E_e > 0.
  r.det_F_min = min_det_F(d, s.u, &r.det_F_cell, &r.cells_inverted, at ? at->nodes : nullptr);
  // E whole, or on the held cells' rows (a rank's state between steps, Discretization::cell_row).
  const std::vector<int>& held = d.held_cells();
  const int nh = static_cast<int>(held.size());
  const auto E_of = [&](int at) -> Eigen::MatrixXd {  // the tensor of held cell held[at]
    return s.E.block(d.cell_row(s.E, held[at], at), 0, dim, dim).transpose();
  };
  const bool E_held = s.E.cols() == dim && (d.whole_field(s.E) || s.E.rows() == dim * nh);
  if (E_held) {
    for (int at = 0; at < nh; ++at)
      keep_extreme(E_of(at).determinant(), held[at], r.det_E_min, r.det_E_cell, false);
    extreme_over_ranks(d, r.det_E_min, r.det_E_cell, false);
  }
  const bool inverted = r.cells_inverted > 0, E_inverted = !(r.det_E_min > 0);
  if (inverted)
    r.failures.push_back(cat("det F <= 0 at a quadrature point of ", r.cells_inverted,
                             " cells: the smallest, det F = ", r.det_F_min, ", is in ",
                             cell_where(d, r.det_F_cell)));
  if (E_inverted)
    r.failures.push_back(cat("the cell strain E has det E = ", r.det_E_min, " <= 0 in ",
                             cell_where(d, r.det_E_cell)));
  if (inverted || E_inverted)
    r.remedies.push_back(
        "a cell is turned inside out: refine the mesh where it is, or apply the load "
        "progressively ([load] ramp = \"linear\", more time.steps)");

  // 3. Rotated branch: the polar rotation of each cell's E against its neighbours' (the cells
  // sharing a node with it). Per cell the angle that more than half of the neighbours exceed
  // (sorted angles a_0 <= ... <= a_{n-1}: a_{n - floor(n/2) - 1}); above kRotationJumpDegrees
  // the cell is flipped against the majority of its neighbours. A discretization of some cells
  // (a rank's) checks its cells, against neighbours on any rank, and the counts and the worst
  // cell are reduced over the ranks.
  if (nc > 1 && E_held) {
    // The neighbours from the held cells' own mesh (Discretization::part(): a rank's part,
    // numbered locally), and on some cells the other ranks' cells that share a node with it.
    const Mesh& part = d.part();
    const int npc = part.nodes_per_cell();
    // The rotations: the held cells' by position (their rows of the part), then (some cells)
    // the other ranks' cells that share a node with a cell of another rank, exchanged with
    // their nodes; first[i] .. first[i + 1] - 1 in `slots` are those at the part's node i.
    std::vector<Eigen::Matrix3d> R(nh);
    for (int k = 0; k < nh; ++k) R[k] = polar_rotation(E_of(k));
    std::vector<int> first, slots;
    if (d.partial()) {
      const std::vector<char>& shared = d.part_shared();
      const int per = 9 + npc;  // the cell's rotation's 9 entries, its nodes
      std::vector<double> mine;
      for (int k = 0; k < nh; ++k) {
        bool on_interface = false;
        for (int a = 0; a < npc; ++a) on_interface = on_interface || shared[part.cells(k, a)];
        if (!on_interface) continue;
        mine.insert(mine.end(), R[k].data(), R[k].data() + 9);
        for (int a = 0; a < npc; ++a) mine.push_back(d.part_node(part.cells(k, a)));
      }
      const int P = mpi::size(), me = mpi::rank();
      std::vector<double> counts(P, 0.0);
      counts[me] = static_cast<double>(mine.size());
      mpi::sum(counts.data(), P);
      std::vector<int> offset(P + 1, 0);
      for (int q = 0; q < P; ++q) offset[q + 1] = offset[q] + static_cast<int>(counts[q]);
      std::vector<double> all(offset[P]);
      std::copy(mine.begin(), mine.end(), all.begin() + offset[me]);
      std::vector<double>().swap(mine);
      mpi::gather(all.data(), offset);
      std::vector<std::pair<int, int>> node_slot;  // (the part's node, a foreign cell's slot)
      for (int q = 0; q < P; ++q) {
        if (q == me) continue;  // this rank's own
        for (int k = offset[q]; k < offset[q + 1]; k += per) {
          const int slot = static_cast<int>(R.size());
          R.push_back(Eigen::Map<const Eigen::Matrix3d>(all.data() + k));
          for (int a = 0; a < npc; ++a) {
            const int j = mpi::position_in(d.cells().node, static_cast<int>(all[k + 9 + a]));
            if (j >= 0) node_slot.emplace_back(j, slot);
          }
        }
      }
      std::sort(node_slot.begin(), node_slot.end());
      first.assign(part.num_nodes() + 1, 0);
      for (const auto& [j, slot] : node_slot) ++first[j + 1], slots.push_back(slot);
      for (int j = 0; j < part.num_nodes(); ++j) first[j + 1] += first[j];
    }
    const NodeCells of = node_cells(part);  // the part's cells of each of its nodes
    std::vector<int> nbr;
    std::vector<double> angles;
    for (int i = 0; i < nh; ++i) {
      const int c = held[i], row = d.part_row(c, i);
      of.around(part, row, nbr);  // the held cells' slots are their rows of the part
      if (!first.empty())
        for (int a = 0; a < npc; ++a) {
          const int j = part.cells(row, a);
          nbr.insert(nbr.end(), slots.begin() + first[j], slots.begin() + first[j + 1]);
        }
      std::sort(nbr.begin(), nbr.end());
      nbr.erase(std::unique(nbr.begin(), nbr.end()), nbr.end());
      if (nbr.empty()) continue;
      angles.clear();
      for (int o : nbr) angles.push_back(angle_between(R[row], R[o]));
      const std::size_t n = angles.size(), k = n - n / 2 - 1;
      std::nth_element(angles.begin(), angles.begin() + static_cast<std::ptrdiff_t>(k),
                       angles.end());
      const double jump = angles[k];
      if (jump > kRotationJumpDegrees || std::isnan(jump)) ++r.cells_rotated;
      keep_extreme(jump, c, r.rotation_jump, r.rotation_cell, true);
    }
    r.cells_rotated = count_over_ranks(d, r.cells_rotated);
    extreme_over_ranks(d, r.rotation_jump, r.rotation_cell, true);
    if (r.cells_rotated > 0) {
      // tr E of the worst cell, from the rank that holds it.
      const int k = mpi::position_in(held, r.rotation_cell);
      double trace = k >= 0 ? E_of(k).trace() : 0.0;
      if (d.partial()) mpi::sum(&trace, 1);
      r.failures.push_back(
          cat(r.cells_rotated,
              " cells are on the rotated branch of the local strain step (4.6): "
              "their polar rotation differs by more than ",
              kRotationJumpDegrees, " degrees from most of their neighbours'; the worst is ",
              cell_where(d, r.rotation_cell), ", ", r.rotation_jump, " degrees, tr E = ", trace));
      const AlgorithmParams& a = pb.algorithm;
      r.remedies.push_back(cat(
          "R q = ", a.R * a.q, " Pa = ", a.R * a.q / d.split().C1,
          " C1 is too small for the local stresses (paper_notes/section3-4.md: R q above 4 C1 in "
          "3-D, 2.6 C1 in plane strain, more under contact pressures above 2 C1): raise "
          "algorithm.R (x2)"));
    }
  }

  // 4. Contact: no tension where there is no glue, 0 <= beta <= 1.
  if (const ContactPoints* pts = d.points();
      !pb.contacts.empty() && pts && pts->size() > 0 && s.lambda_c.rows() == pts->size()) {
    const Eigen::VectorXd p = d.contact_pressure(s);
    // The glue of each point's obstacle.
    Eigen::VectorXd kappa_of =
        Eigen::VectorXd::Constant(pts->size(), pb.contacts[0].adhesion.kappa);
    for (int k = 0; k + 1 < static_cast<int>(pts->offset.size()); ++k)
      kappa_of.segment(pts->offset[k], pts->offset[k + 1] - pts->offset[k])
          .setConstant(pb.contacts[k].adhesion.kappa);
    const bool has_beta = s.beta.size() == pts->size();
    const double load = d.largest_dead_load();
    const double p_ref =
        std::max({p.cwiseAbs().maxCoeff(), load / pts->area.minCoeff(), 1e-3 * d.split().C1});
    r.pressure_tol = kPressureTolerance * p_ref;
    for (int i = 0; i < pts->size(); ++i) {
      const bool glued = kappa_of(i) > 0 && has_beta && s.beta(i) > kBetaTolerance;
      if (glued) continue;
      if (p(i) < r.pressure_min || (std::isnan(p(i)) && !std::isnan(r.pressure_min)))
        r.pressure_min = p(i), r.pressure_point = i;
    }
    if (r.pressure_point >= 0 && !(r.pressure_min >= -r.pressure_tol)) {
      const int i = r.pressure_point;
      r.failures.push_back(
          cat("the contact pressure is ", r.pressure_min, " Pa (a tension; tolerance ",
              r.pressure_tol, " Pa) at contact point ", i, " (reference ",
              position(pts->centre.transpose(), i), "), where there is no glue to carry it"));
      r.remedies.push_back(
          "the contact multiplier has not settled: lower algorithm.tol; if it persists, check "
          "contact.plane_normal (it points into the obstacle)");
    }
    if (has_beta) {
      r.beta_min = s.beta.minCoeff();
      r.beta_max = s.beta.maxCoeff();
      for (int i = 0; i < s.beta.size(); ++i)
        if (!(s.beta(i) >= -kBetaTolerance && s.beta(i) <= 1 + kBetaTolerance)) {
          r.beta_point = i;
          break;
        }
      if (r.beta_point >= 0) {
        const int i = r.beta_point;
        r.failures.push_back(cat("the adhesion intensity beta = ", s.beta(i),
                                 " is outside [0, 1] at contact point ", i, " (reference ",
                                 position(pts->centre.transpose(), i), ")"));
        r.remedies.push_back(
            "beta left [0, 1] (Anderson extrapolates it with algorithm.accelerate = \"all\"): "
            "try algorithm.accelerate = \"strains-multipliers\"");
      }
    }
  }
  return r;
}

std::string AdmissibilityReport::message() const {
  if (failures.empty()) return "";
  std::string m = "the state is not admissible: ";
  for (std::size_t i = 0; i < failures.size(); ++i) m += (i ? "; " : "") + failures[i];
  m += ". What to try: ";
  for (std::size_t i = 0; i < remedies.size(); ++i) m += (i ? "; " : "") + remedies[i];
  return m;
}

std::vector<StoredMeasure> stored_measures(const AdmissibilityReport& r) {
  std::vector<StoredMeasure> out = {
      {"det_F_min", r.det_F_min, "1",
       "smallest det F = det(I + grad u) over the quadrature points of every cell (plane strain: "
       "in-plane block); > 0 for an admissible state"},
      {"det_E_min", r.det_E_min, "1", "smallest det E over the cells"},
      {"rotation_jump", r.rotation_jump, "degree",
       cat("max over cells of the angle between the polar rotation of E and those of the cells "
           "sharing a node with it, exceeded by more than half of them; above ",
           kRotationJumpDegrees, ": a cell on the rotated branch")}};
  if (r.inside_node >= 0)
    out.push_back({"max_inside", r.max_inside, "m",
                   "max over the body's nodes of (x - p0) . N (> 0: inside the obstacle)"});
  if (r.pressure_point >= 0)
    out.push_back({"pressure_min_unglued", r.pressure_min, "Pa",
                   "smallest contact pressure over the contact points without glue"});
  return out;
}

}  // namespace ltl

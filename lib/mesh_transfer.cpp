#include "mesh_transfer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "error.hpp"
#include "fe.hpp"

namespace ltl {

namespace {

bool simplex(const Mesh& mesh) {
  return mesh.dim == 2 || mesh.nodes_per_cell() == 10;
}

/// The reference cell's centre.
Eigen::Vector3d centre(const Mesh& mesh) {
  if (!simplex(mesh)) return Eigen::Vector3d::Zero();
  const double c = mesh.dim == 2 ? 1.0 / 3 : 1.0 / 4;
  Eigen::Vector3d xi = Eigen::Vector3d::Constant(c);
  if (mesh.dim == 2) xi(2) = 0;
  return xi;
}

/// The Euclidean projection of xi onto the reference cell: the cube [-1, 1]^3, or the simplex
/// {xi >= 0, sum xi <= 1} (dim entries), by the sort of Held, Wolfe and Crowder (1974).
Eigen::Vector3d clamp_reference(const Mesh& mesh, Eigen::Vector3d xi) {
  const int d = mesh.dim;
  if (!simplex(mesh)) return xi.cwiseMax(-1.0).cwiseMin(1.0);
  Eigen::Vector3d y = xi.cwiseMax(0.0);
  if (d == 2) y(2) = 0;
  if (y.head(d).sum() <= 1) return y;
  // Onto the face sum = 1, xi >= 0: xi_i - theta, clipped at 0, with theta from the sorted xi.
  std::vector<double> s(xi.data(), xi.data() + d);
  std::sort(s.rbegin(), s.rend());
  double cum = 0, theta = 0;
  for (int k = 0; k < d; ++k) {
    cum += s[k];
    const double t = (cum - 1) / (k + 1);
    if (s[k] - t > 0) theta = t;
  }
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (int k = 0; k < d; ++k) out(k) = std::max(xi(k) - theta, 0.0);
  return out;
}

bool in_reference(const Mesh& mesh, const Eigen::Vector3d& xi, double tol) {
  const int d = mesh.dim;
  if (!simplex(mesh)) return xi.cwiseAbs().maxCoeff() <= 1 + tol;
  return xi.head(d).minCoeff() >= -tol && xi.head(d).sum() <= 1 + tol;
}

}  // namespace

PointLocator::PointLocator(const Mesh& mesh) : mesh_(mesh), dim_(mesh.dim) {
  const int d = dim_, nc = mesh.num_cells();
  if (nc == 0) throw Error(cat(mesh.source, ": no cells to locate points in"));
  Eigen::MatrixXd lo(nc, d), hi(nc, d);
  size_.resize(nc);
  for (int c = 0; c < nc; ++c) {
    lo.row(c) = mesh.X.row(mesh.cells(c, 0));
    hi.row(c) = lo.row(c);
    for (int a = 1; a < mesh.nodes_per_cell(); ++a) {
      lo.row(c) = lo.row(c).cwiseMin(mesh.X.row(mesh.cells(c, a)));
      hi.row(c) = hi.row(c).cwiseMax(mesh.X.row(mesh.cells(c, a)));
    }
    size_(c) = (hi.row(c) - lo.row(c)).norm();
  }
  const double margin = box_margin(mesh);
  box_lo_ = lo.array().colwise() - margin * size_.array();
  box_hi_ = hi.array().colwise() + margin * size_.array();
  const Eigen::RowVectorXd glo = lo.colwise().minCoeff(), ghi = hi.colwise().maxCoeff();
  // About one cell per bucket: the bucket edge h with (box volume) / h^d = #cells.
  const Eigen::RowVectorXd extent = (ghi - glo).cwiseMax(1e-12 * (ghi - glo).maxCoeff());
  const double h = std::pow(extent.prod() / nc, 1.0 / d);
  for (int k = 0; k < d; ++k) {
    lo_(k) = glo(k);
    n_(k) = std::clamp(static_cast<int>(std::ceil(extent(k) / h)), 1, 1 << 12);
    h_(k) = extent(k) / n_(k);
  }
  // The cells of each bucket (compressed rows): count, then fill.
  const long nb = static_cast<long>(n_(0)) * n_(1) * n_(2);
  start_.assign(nb + 1, 0);
  auto for_buckets = [&](int c, auto&& f) {
    const Eigen::Vector3i a = bucket_of(lo.row(c).transpose()),
                          b = bucket_of(hi.row(c).transpose());
    for (int i = a(0); i <= b(0); ++i)
      for (int j = a(1); j <= b(1); ++j)
        for (int k = a(2); k <= b(2); ++k) f(bucket({i, j, k}));
  };
  for (int c = 0; c < nc; ++c) for_buckets(c, [&](int b) { ++start_[b + 1]; });
  for (long b = 0; b < nb; ++b) start_[b + 1] += start_[b];
  cells_.resize(start_[nb]);
  std::vector<int> next(start_.begin(), start_.end() - 1);
  for (int c = 0; c < nc; ++c) for_buckets(c, [&](int b) { cells_[next[b]++] = c; });
}

int PointLocator::bucket(const Eigen::Vector3i& ijk) const {
  return (ijk(2) * n_(1) + ijk(1)) * n_(0) + ijk(0);
}

Eigen::Vector3i PointLocator::bucket_of(const Eigen::VectorXd& x) const {
  Eigen::Vector3i ijk = Eigen::Vector3i::Zero();
  for (int k = 0; k < dim_; ++k)
    ijk(k) = std::clamp(static_cast<int>(std::floor((x(k) - lo_(k)) / h_(k))), 0, n_(k) - 1);
  return ijk;
}

PointLocator::Hit PointLocator::project(int c, const Eigen::VectorXd& x) const {
  const Mesh& m = mesh_;
  const int d = dim_, npc = m.nodes_per_cell();
  Eigen::MatrixXd Xe(npc, d);
  for (int a = 0; a < npc; ++a) Xe.row(a) = m.X.row(m.cells(c, a));
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  Hit hit;
  hit.cell = c;
  hit.size = size_(c);
  Eigen::Vector3d xi = centre(m);
  Eigen::VectorXd r(d);
  auto residual = [&] {
    reference_shape(m, xi, N, dN);
    r = x.head(d) - Xe.transpose() * N;
  };
  // Newton on x(xi) = x (the reference point may lie outside the reference cell: kept in a box
  // three times its size, where the map of a valid cell stays invertible enough to iterate).
  for (int it = 0; it < 30; ++it) {
    residual();
    const Eigen::MatrixXd J = Xe.transpose() * dN;
    const Eigen::VectorXd step = J.partialPivLu().solve(r);
    if (!step.allFinite()) break;
    xi.head(d) += step;
    xi = xi.cwiseMax(-3.0).cwiseMin(3.0);
    if (step.norm() < 1e-14) break;
  }
  if (in_reference(m, xi, 1e-10)) {  // inside (a point on a face may be 1e-10 beyond it)
    residual();
    hit.in_cell = r.norm() <= 1e-9 * hit.size;
    hit.xi = xi;
    hit.distance = r.norm();
    return hit;
  }
  // Outside: the closest reference point by projected Gauss-Newton steps from the clamped one.
  xi = clamp_reference(m, xi);
  for (int it = 0; it < 30; ++it) {
    residual();
    const Eigen::MatrixXd J = Xe.transpose() * dN;
    Eigen::Vector3d next = xi;
    // On the reference cube (H8) a coordinate at a bound that the descent direction J^T r pushes
    // outward stays there, and the Gauss-Newton step is taken in the others: clamping the full
    // step instead stops short of the closest point of a distorted cell.
    const Eigen::VectorXd g = J.transpose() * r;
    std::vector<int> free;
    for (int i = 0; i < d; ++i)
      if (simplex(m) || !((xi(i) >= 1 && g(i) > 0) || (xi(i) <= -1 && g(i) < 0))) free.push_back(i);
    if (free.empty()) break;  // a corner of the cube, pushed outward in every coordinate
    Eigen::MatrixXd Jf(d, static_cast<Eigen::Index>(free.size()));
    for (std::size_t i = 0; i < free.size(); ++i) Jf.col(i) = J.col(free[i]);
    const Eigen::VectorXd step = (Jf.transpose() * Jf).ldlt().solve(Jf.transpose() * r);
    for (std::size_t i = 0; i < free.size(); ++i) next(free[i]) += step(i);
    next = clamp_reference(m, next);
    if (!next.allFinite() || (next - xi).norm() < 1e-13) break;
    xi = next;
  }
  residual();
  hit.xi = xi;
  hit.distance = r.norm();
  return hit;
}

PointLocator::Hit PointLocator::locate(const Eigen::VectorXd& x) const {
  const Eigen::Vector3i b = bucket_of(x);
  Hit best;
  best.distance = std::numeric_limits<double>::infinity();
  // The cell that holds x is one of its bucket's (its box covers x's bucket) and its widened box
  // holds x: those cells first, in the bucket's order, so that the answer is the one of the full
  // search below; the projections onto the others (each a Newton iteration) only when x lies in
  // no cell (outside the mesh: the closest cell).
  const int d = dim_;
  for (int k = start_[bucket(b)]; k < start_[bucket(b) + 1]; ++k) {
    const int c = cells_[k];
    if (((x.head(d).transpose().array() < box_lo_.row(c).array()) ||
         (x.head(d).transpose().array() > box_hi_.row(c).array()))
            .any())
      continue;
    const Hit h = project(c, x);
    if (h.inside()) return h;
  }
  // x is in no cell: the closest one. A cell no nearer to x than its widened box (which holds it)
  // is not projected onto when that box is already as far as the best so far.
  auto consider = [&](int bk) {
    for (int k = start_[bk]; k < start_[bk + 1]; ++k) {
      const int c = cells_[k];
      const double gap = (box_lo_.row(c).transpose() - x.head(d))
                             .cwiseMax(x.head(d) - box_hi_.row(c).transpose())
                             .cwiseMax(0.0)
                             .norm();
      if (gap >= best.distance) continue;
      const Hit h = project(c, x);
      if (h.distance < best.distance) best = h;
      if (best.inside()) return true;
    }
    return false;
  };
  if (consider(bucket(b))) return best;
  // Not inside a cell of its bucket: the surrounding ring of buckets, widened while none of
  // them holds a cell.
  const int widest = n_.maxCoeff();
  for (int ring = 1; ring <= widest; ++ring) {
    const Eigen::Vector3i lo = (b.array() - ring).max(0),
                          hi = (b.array() + ring).min(n_.array() - 1);
    for (int i = lo(0); i <= hi(0); ++i)
      for (int j = lo(1); j <= hi(1); ++j)
        for (int k = lo(2); k <= hi(2); ++k)
          if ((Eigen::Vector3i(i, j, k) - b).cwiseAbs().maxCoeff() == ring &&
              consider(bucket({i, j, k})))
            return best;
    if (best.cell >= 0) return best;
  }
  return best;
}

Eigen::RowVectorXd PointLocator::evaluate(const Eigen::MatrixXd& field, const Hit& hit) const {
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  reference_shape(mesh_, hit.xi, N, dN);
  Eigen::RowVectorXd v = Eigen::RowVectorXd::Zero(field.cols());
  for (int a = 0; a < mesh_.nodes_per_cell(); ++a) v += N(a) * field.row(mesh_.cells(hit.cell, a));
  return v;
}

}  // namespace ltl

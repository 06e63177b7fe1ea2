// Signed SVD [LTL87 (5.4)] (see signed_svd.hpp). Performance (paper_notes/performance.md): the
// 3x3 fast path costs ~150 ns (a latency-bound chain of square roots and divisions); the
// fallbacks run only when its round-off check fails.
#include "signed_svd.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>

namespace ltl {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();

/// One Jacobi rotation zeroing S(p,q) of the symmetric 3x3 S, accumulated in V (S <- J^T S J).
inline void jacobi_rotate(Eigen::Matrix3d& S, Eigen::Matrix3d& V, int p, int q) {
  const double apq = S(p, q);
  if (apq == 0.0) return;
  const double theta = (S(q, q) - S(p, p)) / (2.0 * apq);
  double t;
  if (std::abs(theta) > 1e150) {
    t = 0.5 / theta;
  } else {
    t = 1.0 / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
    if (theta < 0.0) t = -t;
  }
  const double c = 1.0 / std::sqrt(t * t + 1.0);
  const double s = t * c;
  S(p, p) -= t * apq;
  S(q, q) += t * apq;
  S(p, q) = S(q, p) = 0.0;
  const int r = 3 - p - q;
  const double srp = S(r, p), srq = S(r, q);
  S(r, p) = S(p, r) = c * srp - s * srq;
  S(r, q) = S(q, r) = s * srp + c * srq;
  for (int k = 0; k < 3; ++k) {
    const double vkp = V(k, p), vkq = V(k, q);
    V(k, p) = c * vkp - s * vkq;
    V(k, q) = s * vkp + c * vkq;
  }
}

/// Givens rotation on rows p, q of R zeroing R(q, col), accumulated in U so that U R is kept.
inline void givens_rows(Eigen::Matrix3d& R, Eigen::Matrix3d& U, int p, int q, int col) {
  const double a = R(p, col), b = R(q, col);
  if (b == 0.0) return;
  const double r = std::sqrt(a * a + b * b);
  const double c = a / r, s = b / r;
  for (int k = 0; k < 3; ++k) {
    const double rp = R(p, k), rq = R(q, k);
    R(p, k) = c * rp + s * rq;
    R(q, k) = -s * rp + c * rq;
    const double up = U(k, p), uq = U(k, q);
    U(k, p) = c * up + s * uq;
    U(k, q) = -s * up + c * uq;
  }
  R(q, col) = 0.0;
}

/// Swaps the first two signed singular triplets when d[1] > d[0] (a round-off tie); the
/// swap negates one column of Q and R so that both stay rotations.
inline void order_two_largest(Eigen::Matrix3d& Q, Eigen::Vector3d& d, Eigen::Matrix3d& R) {
  if (!(d[1] > d[0])) return;
  std::swap(d[0], d[1]);
  Q.col(0).swap(Q.col(1));
  R.col(0).swap(R.col(1));
  Q.col(0) = -Q.col(0);
  R.col(0) = -R.col(0);
}

}  // namespace

/// [LTL87 (5.4)] 2x2 signed SVD in closed form: A = e Rot(a2) + f Refl(a1) (rotation part
/// plus reflection part), then A = Rot(phi) diag(e + f, e - f) Rot(theta)^T with
/// phi = (a1 + a2) / 2, theta = (a1 - a2) / 2. Half angles from unit vectors without atan2.
void signed_svd(const Eigen::Matrix2d& A, Eigen::Matrix2d& Q, Eigen::Vector2d& d,
                Eigen::Matrix2d& R) {
  const double E = 0.5 * (A(0, 0) + A(1, 1)), F = 0.5 * (A(0, 0) - A(1, 1));
  const double G = 0.5 * (A(1, 0) + A(0, 1)), H = 0.5 * (A(1, 0) - A(0, 1));
  const double e = std::sqrt(E * E + H * H), f = std::sqrt(F * F + G * G);
  double c2 = 1.0, s2 = 0.0, c1 = 1.0, s1 = 0.0;
  if (e > 0.0) {
    c2 = E / e;
    s2 = H / e;
  }
  if (f > 0.0) {
    c1 = F / f;
    s1 = G / f;
  }
  const double cs = c1 * c2 - s1 * s2, ss = s1 * c2 + c1 * s2;  // cos, sin of a1 + a2
  double cp, sp;  // half angle (up to a sign, which Q and R then share)
  if (cs >= 0.0) {
    cp = 1.0 + cs;
    sp = ss;
  } else {
    cp = ss;
    sp = 1.0 - cs;
  }
  const double n = std::sqrt(cp * cp + sp * sp);
  cp /= n;
  sp /= n;
  const double ct = cp * c2 + sp * s2, st = sp * c2 - cp * s2;  // theta = phi - a2
  Q << cp, -sp, sp, cp;
  R << ct, -st, st, ct;
  d << e + f, e - f;
}

namespace {

/// Given R (a rotation) with A R ~ orthogonal columns, finish the signed SVD: columns sorted
/// by norm, Givens QR A R = Q T, the lower 2x2 block of T by the closed-form 2x2 SVD. Returns
/// false when T(0,1) or T(0,2) is not at round-off (R was not accurate enough).
bool finish_svd3(const Eigen::Matrix3d& A, Eigen::Matrix3d& Q, Eigen::Vector3d& d,
                 Eigen::Matrix3d& R, double offtol) {
  Eigen::Matrix3d B = A * R;
  // sort columns by decreasing norm; a transposition negates one column to keep det R = +1
  double n0 = B.col(0).squaredNorm(), n1 = B.col(1).squaredNorm(), n2 = B.col(2).squaredNorm();
  auto swap_cols = [&](int i, int j, double& ni, double& nj) {
    B.col(i).swap(B.col(j));
    R.col(i).swap(R.col(j));
    B.col(j) = -B.col(j);
    R.col(j) = -R.col(j);
    std::swap(ni, nj);
  };
  if (n0 < n1) swap_cols(0, 1, n0, n1);
  if (n1 < n2) swap_cols(1, 2, n1, n2);
  if (n0 < n1) swap_cols(0, 1, n0, n1);
  Q.setIdentity();
  givens_rows(B, Q, 0, 1, 0);
  givens_rows(B, Q, 0, 2, 0);
  givens_rows(B, Q, 1, 2, 1);
  // B is now upper triangular; B(0,1), B(0,2) must be O(eps |A|): they are dropped
  if (std::abs(B(0, 1)) + std::abs(B(0, 2)) > offtol * std::abs(B(0, 0))) return false;
  Eigen::Matrix2d M, Q2, R2;
  Eigen::Vector2d d2;
  M << B(1, 1), B(1, 2), 0.0, B(2, 2);
  signed_svd(M, Q2, d2, R2);
  const Eigen::Matrix<double, 3, 2> Qb = Q.rightCols<2>() * Q2;
  const Eigen::Matrix<double, 3, 2> Rb = R.rightCols<2>() * R2;
  Q.rightCols<2>() = Qb;
  R.rightCols<2>() = Rb;
  d << B(0, 0), d2[0], d2[1];
  if (d[0] < 0.0) {
    d[0] = -d[0];
    d[2] = -d[2];
    Q.col(0) = -Q.col(0);
    Q.col(2) = -Q.col(2);
  }
  order_two_largest(Q, d, R);
  return true;
}

/// (n, b1, b2) a right-handed orthonormal basis, for a unit vector n (Duff et al., "Building an
/// orthonormal basis, revisited", JCGT 2017): orthonormal to a few eps, one division.
inline void complete_basis(const Eigen::Vector3d& n, Eigen::Vector3d& b1, Eigen::Vector3d& b2) {
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z());
  const double b = n.x() * n.y() * a;
  b1 << 1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x();
  b2 << b, sign + n.y() * n.y() * a, -n.y();
}

/// Fast path of the 3x3 signed SVD (performance.md): only the eigenvector r1 of the largest
/// eigenvalue of S = A^T A is computed (closed-form eigenvalue, cross products of the rows of
/// S - lambda_1 I), completed to a rotation R = [r1 r2 r3]; b1 = A r1 = sigma_1 q1 is completed
/// to a rotation [q1 q2 q3]; then [q1 q2 q3]^T A R is [sigma_1 0; 0 M] up to its entries
/// (0,1), (0,2), which must be at round-off (checked: r1 accurate enough), and the 2x2 block M
/// gets the closed-form signed 2x2 SVD. Returns false when the check fails (the caller then
/// takes the robust path).
bool signed_svd_fast(const Eigen::Matrix3d& A, Eigen::Matrix3d& Q, Eigen::Vector3d& d,
                     Eigen::Matrix3d& R, double offtol) {
  const Eigen::Matrix3d S = A.transpose() * A;
  // largest eigenvalue of S (trigonometric form of the cubic)
  const double q = S.trace() / 3.0;
  const double s00 = S(0, 0) - q, s11 = S(1, 1) - q, s22 = S(2, 2) - q;
  const double off2 = S(0, 1) * S(0, 1) + S(0, 2) * S(0, 2) + S(1, 2) * S(1, 2);
  const double p2 = (s00 * s00 + s11 * s11 + s22 * s22 + 2.0 * off2) / 6.0;
  Eigen::Vector3d r1(1.0, 0.0, 0.0);
  if (p2 > 0.0) {
    const double pp = std::sqrt(p2);
    const double det = s00 * (s11 * s22 - S(1, 2) * S(1, 2)) -
                       S(0, 1) * (S(0, 1) * s22 - S(1, 2) * S(0, 2)) +
                       S(0, 2) * (S(0, 1) * S(1, 2) - s11 * S(0, 2));
    const double r = std::clamp(det / (2.0 * pp * p2), -1.0, 1.0);
    const double lambda = q + 2.0 * pp * std::cos(std::acos(r) / 3.0);
    // eigenvector: the largest cross product of two rows of S - lambda I
    Eigen::Matrix3d M = S;
    M.diagonal().array() -= lambda;
    const Eigen::Vector3d c0 = M.row(0).cross(M.row(1)), c1 = M.row(0).cross(M.row(2)),
                          c2 = M.row(1).cross(M.row(2));
    const double n0 = c0.squaredNorm(), n1 = c1.squaredNorm(), n2 = c2.squaredNorm();
    const double rows =
        std::max({M.row(0).squaredNorm(), M.row(1).squaredNorm(), M.row(2).squaredNorm()});
    const double nmax = std::max({n0, n1, n2});
    if (nmax > 1e-16 * rows * rows) {
      r1 = (n0 >= n1 && n0 >= n2 ? c0 : n1 >= n2 ? c1 : c2) / std::sqrt(nmax);
    } else if (rows > 0.0) {  // rank 1: any unit vector orthogonal to the largest row
      int k = 0;
      for (int i = 1; i < 3; ++i)
        if (M.row(i).squaredNorm() > M.row(k).squaredNorm()) k = i;
      Eigen::Vector3d w = M.row(k).transpose().normalized(), u, v;
      complete_basis(w, u, v);
      r1 = u;
    }
  }
  Eigen::Vector3d r2, r3, q2, q3;
  complete_basis(r1, r2, r3);
  const Eigen::Vector3d b0 = A * r1;
  const double sigma = b0.norm();
  if (!(sigma > 0.0)) {  // A = 0
    if (A.cwiseAbs().maxCoeff() != 0.0) return false;
    Q.setIdentity();
    R.setIdentity();
    d.setZero();
    return true;
  }
  const Eigen::Vector3d q1 = b0 / sigma;
  complete_basis(q1, q2, q3);
  const Eigen::Vector3d b1 = A * r2, b2 = A * r3;
  if (std::abs(q1.dot(b1)) + std::abs(q1.dot(b2)) > offtol * sigma) return false;
  Eigen::Matrix2d M2, Q2, R2;
  Eigen::Vector2d d2;
  M2 << q2.dot(b1), q2.dot(b2), q3.dot(b1), q3.dot(b2);
  signed_svd(M2, Q2, d2, R2);
  Q.col(0) = q1;
  Q.col(1) = Q2(0, 0) * q2 + Q2(1, 0) * q3;
  Q.col(2) = Q2(0, 1) * q2 + Q2(1, 1) * q3;
  R.col(0) = r1;
  R.col(1) = R2(0, 0) * r2 + R2(1, 0) * r3;
  R.col(2) = R2(0, 1) * r2 + R2(1, 1) * r3;
  d << sigma, d2[0], d2[1];
  order_two_largest(Q, d, R);  // round-off tie of the two largest
  return true;
}

}  // namespace

/// [LTL87 (5.4)] 3x3 signed SVD. Fast path first (signed_svd_fast: one eigenvector of A^T A,
/// completed to rotations, the remaining 2x2 block by the closed-form 2x2 SVD). If its
/// round-off check fails: R from the eigenvectors of A^T A (closed form, Eigen's
/// computeDirect); B = A R, columns sorted by norm; Givens QR B = Q T; T is diagonal up to
/// O(eps |A|) except its lower 2x2 block, which gets the closed-form 2x2 SVD. When the
/// closed-form eigenvectors are not accurate enough (close eigenvalues: T(0,1), T(0,2) not at
/// round-off), R comes from cyclic Jacobi on A^T A instead. Backward stable on every path:
/// |A - Q diag(d) R^T| = O(eps |A|).
void signed_svd(const Eigen::Matrix3d& A, Eigen::Matrix3d& Q, Eigen::Vector3d& d,
                Eigen::Matrix3d& R) {
  const double offtol = 4.0 * kEps;
  if (signed_svd_fast(A, Q, d, R, offtol)) return;
  Eigen::Matrix3d S = A.transpose() * A;
  {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(S);
    // orthonormalize to round-off (the closed-form vectors are not, for close eigenvalues):
    // the largest first, then Gram-Schmidt, then the cross product (det R = +1)
    const Eigen::Matrix3d& V = es.eigenvectors();
    R.col(2) = V.col(2).normalized();
    R.col(1) = (V.col(1) - R.col(2).dot(V.col(1)) * R.col(2)).normalized();
    R.col(0) = R.col(1).cross(R.col(2));
    if (finish_svd3(A, Q, d, R, offtol)) return;
  }
  R.setIdentity();
  const double tol = 1e-18 * S.trace();
  for (int sweep = 0; sweep < 30; ++sweep) {
    if (std::abs(S(0, 1)) + std::abs(S(0, 2)) + std::abs(S(1, 2)) <= tol) break;
    jacobi_rotate(S, R, 0, 1);
    jacobi_rotate(S, R, 0, 2);
    jacobi_rotate(S, R, 1, 2);
  }
  finish_svd3(A, Q, d, R, kInf);
}

}  // namespace ltl

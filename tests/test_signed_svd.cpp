// Tests of the signed SVD [LTL87 (5.4)] (lib/signed_svd.cpp), the first step of the local strain
// problem (4.6): reconstruction A = Q diag(d) R^T to round-off, Q and R rotations (orthogonal,
// det = +1), |d| sorted decreasing with the sign of det A on the smallest value only, on generic
// matrices and on the degenerate ones (zero, rank 1 and 2, repeated and graded singular values,
// rotations, reflections) where the closed forms and the fallbacks of the 3x3 path are exercised.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "signed_svd.hpp"
#include "testing.hpp"

namespace {

template <int n>
using Mat = Eigen::Matrix<double, n, n>;
template <int n>
using Vec = Eigen::Matrix<double, n, 1>;

using ltl::testing::random_rotation;

/// Q1 diag(s) Q2 with random rotations: a matrix whose signed singular values are known.
template <int n>
Mat<n> with_values(std::mt19937_64& g, const Vec<n>& s) {
  return random_rotation<n>(g) * s.asDiagonal() * random_rotation<n>(g);
}

/// Generic matrices (I + noise, both signs of det, several scales) and the degenerate ones.
template <int n>
std::vector<Mat<n>> matrices(std::mt19937_64& g, int generic) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<Mat<n>> As;
  for (int k = 0; k < generic; ++k) {
    Mat<n> A = Mat<n>::Identity();
    for (int i = 0; i < n * n; ++i) A(i) += 0.5 * U(g);
    if (k % 2) A.col(0) = -A.col(0);
    As.push_back(std::pow(10.0, 6.0 * U(g)) * A);
  }
  As.push_back(Mat<n>::Zero());
  As.push_back(Mat<n>::Identity());
  As.push_back(-Mat<n>::Identity());
  As.push_back(2.5 * random_rotation<n>(g));
  for (double s : {1.0, -1.0}) {
    Vec<n> d = Vec<n>::Constant(1.4);  // repeated largest values
    d[n - 1] = s * 0.7;
    As.push_back(with_values<n>(g, d));
    d.setConstant(0.6);  // repeated smallest values
    d[0] = 1.5;
    d[n - 1] *= s;
    As.push_back(with_values<n>(g, d));
    d.setConstant(1.0);  // all equal: a rotation or a rotation times a reflection
    d[n - 1] = s;
    As.push_back(with_values<n>(g, d));
  }
  Vec<n> d = Vec<n>::Zero();  // rank 1
  d[0] = 3.0;
  As.push_back(with_values<n>(g, d));
  if constexpr (n == 3) {  // rank 2, and a rank 2 with two equal values
    As.push_back(with_values<3>(g, Vec<3>(2.0, 1.0, 0.0)));
    As.push_back(with_values<3>(g, Vec<3>(2.0, 2.0, 0.0)));
  }
  Mat<n> A = Mat<n>::Zero();  // one non-zero entry
  A(n - 1, 0) = -7.0;
  As.push_back(A);
  return As;
}

template <int n>
void check_signed_svd(const Mat<n>& A) {
  Mat<n> Q, R;
  Vec<n> d;
  ltl::signed_svd(A, Q, d, R);
  const double scale = std::max(A.norm(), 1e-300);
  EXPECT_LT((Q * d.asDiagonal() * R.transpose() - A).norm(), 8e-16 * n * scale) << A;
  EXPECT_LT((Q.transpose() * Q - Mat<n>::Identity()).norm(), 1e-15 * n);
  EXPECT_LT((R.transpose() * R - Mat<n>::Identity()).norm(), 1e-15 * n);
  EXPECT_NEAR(Q.determinant(), 1.0, 1e-15 * n);  // rotations, not reflections
  EXPECT_NEAR(R.determinant(), 1.0, 1e-15 * n);
  for (int i = 0; i + 1 < n; ++i) {  // |d| decreasing, only the last one may be negative
    EXPECT_GE(d[i], 0.0);
    EXPECT_GE(d[i], std::abs(d[i + 1]) - 1e-15 * scale);
  }
  const double det = A.determinant();
  if (std::abs(det) > 1e-10 * std::pow(scale, n)) {
    EXPECT_EQ(d[n - 1] < 0.0, det < 0.0) << A;
  }
  // |d| are the singular values (Eigen's Jacobi SVD, an independent algorithm)
  const Eigen::VectorXd ref = Eigen::JacobiSVD<Eigen::MatrixXd>(A).singularValues();
  EXPECT_LT((d.cwiseAbs() - ref).norm(), 1e-14 * scale) << A;
}

TEST(SignedSvd, Eq5_4_ReconstructsWithRotationsAndSignOnSmallest2D) {
  std::mt19937_64 g(10);
  for (const Mat<2>& A : matrices<2>(g, 300)) check_signed_svd<2>(A);
  // exact values: diag(1, -3) has signed singular values (3, -1)
  Mat<2> Q, R;
  Eigen::Vector2d d;
  ltl::signed_svd(Mat<2>(Eigen::Vector2d(1.0, -3.0).asDiagonal()), Q, d, R);
  EXPECT_NEAR(d[0], 3.0, 1e-15);
  EXPECT_NEAR(d[1], -1.0, 1e-15);
}

TEST(SignedSvd, Eq5_4_ReconstructsWithRotationsAndSignOnSmallest3D) {
  std::mt19937_64 g(11);
  for (const Mat<3>& A : matrices<3>(g, 300)) check_signed_svd<3>(A);
  for (double s : {1e-12, 1e12}) {  // strongly graded singular values
    const Mat<3> A = random_rotation<3>(g) * Eigen::Vector3d(1.0, s, 1.0 / s).asDiagonal() *
                     random_rotation<3>(g);
    check_signed_svd<3>(A);
  }
  Mat<3> Q, R;
  Eigen::Vector3d d;
  ltl::signed_svd(Mat<3>(Eigen::Vector3d(-2.0, 5.0, 1.0).asDiagonal()), Q, d, R);
  EXPECT_NEAR(d[0], 5.0, 1e-14);
  EXPECT_NEAR(d[1], 2.0, 1e-14);
  EXPECT_NEAR(d[2], -1.0, 1e-14);
}

TEST(SignedSvd, Eq5_4_SignedValuesOfKnownFactorizations) {
  // Q1 diag(s) Q2 with rotations Q1, Q2 and s sorted with the sign last: the signed values
  // come back exactly (to round-off), for distinct, repeated and zero values.
  std::mt19937_64 g(12);
  for (const Vec<3>& s : {Vec<3>(3.0, 2.0, 1.0), Vec<3>(3.0, 2.0, -1.0), Vec<3>(2.0, 2.0, -2.0),
                          Vec<3>(5.0, 1.0, 1.0), Vec<3>(4.0, 0.0, 0.0), Vec<3>(1e8, 1.0, -1e-8)}) {
    for (int k = 0; k < 20; ++k) {
      Mat<3> Q, R;
      Vec<3> d;
      ltl::signed_svd(with_values<3>(g, s), Q, d, R);
      EXPECT_LT((d - s).norm(), 1e-14 * s.norm()) << s.transpose() << " -> " << d.transpose();
    }
  }
  for (const Vec<2>& s :
       {Vec<2>(3.0, 1.0), Vec<2>(3.0, -1.0), Vec<2>(2.0, -2.0), Vec<2>(1.0, 0.0)}) {
    for (int k = 0; k < 20; ++k) {
      Mat<2> Q, R;
      Vec<2> d;
      ltl::signed_svd(with_values<2>(g, s), Q, d, R);
      EXPECT_LT((d - s).norm(), 1e-14 * s.norm()) << s.transpose() << " -> " << d.transpose();
    }
  }
}

TEST(SignedSvd, Eq5_4_ZeroMatrixGivesIdentityFactors) {
  Mat<3> Q, R;
  Vec<3> d;
  ltl::signed_svd(Mat<3>::Zero(), Q, d, R);
  EXPECT_EQ(d, Vec<3>::Zero());
  EXPECT_LT((Q.transpose() * Q - Mat<3>::Identity()).norm(), 1e-15);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-15);
  Mat<2> Q2, R2;
  Vec<2> d2;
  ltl::signed_svd(Mat<2>::Zero(), Q2, d2, R2);
  EXPECT_EQ(d2, Vec<2>::Zero());
  EXPECT_NEAR(Q2.determinant(), 1.0, 1e-15);
}

}  // namespace

// The fit's covariance (fit/src/determination.hpp, parameter_covariance) against a pseudo-inverse
// computed another way: Eigen's singular value decomposition of the unit-norm columns, with the
// same cut (singular values squared below 1e-14 of the largest count as zero). Well-conditioned
// columns take the covariance's Cholesky path, nearly dependent ones its eigen-decomposition,
// and a column the data cannot see (zero, or a copy of another) an infinite variance.

#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "determination.hpp"  // fit/src

namespace skinspec {
namespace {

constexpr int kRows = 60;

std::vector<std::size_t> all_columns(const Eigen::MatrixXd& j) {
  std::vector<std::size_t> all(static_cast<std::size_t>(j.cols()));
  for (std::size_t k = 0; k < all.size(); ++k) all[k] = k;
  return all;
}

// sigma^2 (J^T J)^+ by the SVD of J's unit-norm columns.
Eigen::MatrixXd reference_covariance(const Eigen::MatrixXd& j, double cost) {
  const Eigen::VectorXd norms = j.colwise().norm().transpose();
  const Eigen::MatrixXd unit = j * norms.cwiseInverse().asDiagonal();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(unit, Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Zero(j.cols(), j.cols());
  for (Eigen::Index e = 0; e < s.size(); ++e)
    if (s(e) * s(e) > 1e-14 * s(0) * s(0))
      inverse += svd.matrixV().col(e) * svd.matrixV().col(e).transpose() / (s(e) * s(e));
  const double sigma2 = 2 * cost / static_cast<double>(j.rows() - j.cols());
  return sigma2 * norms.cwiseInverse().asDiagonal() * inverse * norms.cwiseInverse().asDiagonal();
}

// Columns of very different scales (1e-3 to 1e3), correlated but far from dependent.
Eigen::MatrixXd spread_columns(int cols, unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution normal(0.0, 1.0);
  Eigen::MatrixXd j(kRows, cols);
  for (int c = 0; c < cols; ++c)
    for (int r = 0; r < kRows; ++r) j(r, c) = normal(random) + (c > 0 ? 0.5 * j(r, c - 1) : 0.0);
  for (int c = 0; c < cols; ++c) j.col(c) *= std::pow(10.0, -3 + 6.0 * c / std::max(1, cols - 1));
  return j;
}

void expect_matrices_near(const detail::SmallMatrix& ours, const Eigen::MatrixXd& reference, double relative) {
  ASSERT_EQ(ours.rows(), reference.rows());
  for (Eigen::Index a = 0; a < ours.rows(); ++a)
    for (Eigen::Index b = 0; b < ours.cols(); ++b)
      EXPECT_NEAR(ours(a, b), reference(a, b), relative * std::sqrt(std::abs(reference(a, a) * reference(b, b))))
          << "(" << a << "," << b << ")";
}

TEST(Covariance, WellConditionedColumnsGiveTheInverse) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Eigen::MatrixXd j = spread_columns(7, seed);
    expect_matrices_near(detail::parameter_covariance(j, all_columns(j), 0.37), reference_covariance(j, 0.37), 1e-10);
  }
}

// Two columns apart by 3e-7 of their length: the least eigenvalue of the unit columns' normal
// matrix is some 2e-14 of the largest, under the Cholesky path's bound (1e-12 / k) but above
// the cut, so the eigen-decomposition decides and keeps it.
TEST(Covariance, NearlyDependentColumnsKeepTheirFiniteVariances) {
  Eigen::MatrixXd j = spread_columns(5, 11);
  j.col(4) = j.col(3) / j.col(3).norm() + 3e-7 * spread_columns(1, 12).col(0).normalized();
  const auto ours = detail::parameter_covariance(j, all_columns(j), 0.5);
  for (Eigen::Index a = 0; a < ours.rows(); ++a) EXPECT_TRUE(std::isfinite(ours(a, a))) << a;
  // The inverse of so ill-conditioned a matrix carries its condition number times the rounding.
  expect_matrices_near(ours, reference_covariance(j, 0.5), 1e-2);
}

// A zero column and an exact copy are in the null space: infinite variances, NaN covariances,
// and the other parameters as in the problem without them (with one of the copies).
TEST(Covariance, ColumnsTheDataCannotSeeGetInfiniteVariances) {
  const Eigen::MatrixXd base = spread_columns(4, 21);
  Eigen::MatrixXd j(kRows, 6);
  j << base, Eigen::VectorXd::Zero(kRows), base.col(2);
  const auto ours = detail::parameter_covariance(j, all_columns(j), 0.5);
  for (const Eigen::Index unseen : {2, 4, 5}) {
    EXPECT_EQ(ours(unseen, unseen), std::numeric_limits<double>::infinity()) << unseen;
    for (Eigen::Index other = 0; other < 6; ++other)
      if (other != unseen) {
        EXPECT_TRUE(std::isnan(ours(unseen, other))) << unseen << "," << other;
      }
  }
  // The visible parameters as in the problem of `base` (one of the copies), whose sigma^2
  // divides by 4 fewer than the rows where this one divides by 6 fewer.
  const Eigen::MatrixXd reference = reference_covariance(base, 0.5 * (kRows - 4.0) / (kRows - 6.0));
  for (const Eigen::Index a : {0, 1, 3})
    for (const Eigen::Index b : {0, 1, 3})
      EXPECT_NEAR(ours(a, b), reference(a, b), 1e-8 * std::sqrt(reference(a, a) * reference(b, b))) << a << "," << b;
}

// Two columns apart by 1e-7 of their length: the least eigenvalue is some 2.5e-15 of the
// largest, under the cut, although Cholesky would factor the matrix (its pivot, about 1e-14,
// is far above the rounding). The bound sends it to the eigen-decomposition, which finds the
// null space: the two parameters' variances are infinite, not merely large.
TEST(Covariance, ColumnsDependentWithinTheCutAreInTheNullSpace) {
  Eigen::MatrixXd j = spread_columns(4, 41);
  j.col(3) = j.col(2) / j.col(2).norm() + 1e-7 * spread_columns(1, 42).col(0).normalized();
  const auto ours = detail::parameter_covariance(j, all_columns(j), 0.5);
  EXPECT_EQ(ours(2, 2), std::numeric_limits<double>::infinity());
  EXPECT_EQ(ours(3, 3), std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isfinite(ours(0, 0)));
  EXPECT_TRUE(std::isfinite(ours(1, 1)));
}

TEST(Covariance, SelectsTheFreeColumnsInTheirOrder) {
  const Eigen::MatrixXd j = spread_columns(6, 31);
  const std::vector<std::size_t> free{5, 1, 3};
  const Eigen::MatrixXd chosen = j(Eigen::all, std::vector<Eigen::Index>{5, 1, 3});
  expect_matrices_near(detail::parameter_covariance(j, free, 2.0), reference_covariance(chosen, 2.0), 1e-10);
}

}  // namespace
}  // namespace skinspec

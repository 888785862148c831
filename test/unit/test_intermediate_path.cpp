// Intermediate path estimate (Lee, Kim and Chung 2010, sec. IV) against hand-computed cases:
// the end-pose error is shared among the increments in proportion to their variances.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "rbpf_slam/core/filters/intermediate_path.h"

namespace rbpf_slam {
namespace core {
namespace {

Eigen::Matrix3d diag(double xx, double yy, double tt) {
  return Eigen::Vector3d(xx, yy, tt).asDiagonal();
}

// Two straight 1 m increments, variances q and 3q along x, end 0.2 m further than odometry
// says. By hand (x is linear here): d_1x = 1 + 0.2 q / (q + 3q) = 1.05, and
// var(x_1) = q - q^2 / 4q = 0.75 q; y and heading stay 0.
TEST(IntermediatePath, StraightChainSharesTheErrorByVariance) {
  const double q = 0.01;
  const IntermediatePath path =
      estimateIntermediatePath(Pose2(0, 0, 0), Pose2(2.2, 0, 0), {Pose2(1, 0, 0), Pose2(1, 0, 0)},
                               {diag(q, q, 0.001), diag(3 * q, 3 * q, 0.003)});
  ASSERT_EQ(path.means.size(), 1u);
  EXPECT_TRUE(path.converged);
  EXPECT_NEAR(path.means[0].x(), 1.05, 1e-9);
  EXPECT_NEAR(path.means[0].y(), 0.0, 1e-9);
  EXPECT_NEAR(path.means[0].z(), 0.0, 1e-9);
  EXPECT_NEAR(path.covariances[0](0, 0), 0.75 * q, 1e-9);
  EXPECT_NEAR(path.covariances[0](0, 1), 0.0, 1e-9);
}

// The same chain in a frame rotated by 90 degrees and shifted: x of the robot is y of the map.
TEST(IntermediatePath, RotatedFrame) {
  const double q = 0.01;
  const IntermediatePath path = estimateIntermediatePath(
      Pose2(1, 2, M_PI / 2), Pose2(1, 4.2, M_PI / 2), {Pose2(1, 0, 0), Pose2(1, 0, 0)},
      {diag(q, q, 0.001), diag(3 * q, 3 * q, 0.003)});
  ASSERT_EQ(path.means.size(), 1u);
  EXPECT_NEAR(path.means[0].x(), 1.0, 1e-9);
  EXPECT_NEAR(path.means[0].y(), 3.05, 1e-9);
  EXPECT_NEAR(path.means[0].z(), M_PI / 2, 1e-9);
  EXPECT_NEAR(path.covariances[0](1, 1), 0.75 * q, 1e-9);
}

// Three equal increments with a heading error at the end: by symmetry each increment takes a
// third of the 0.3 rad; the intermediate headings are 0.1 and 0.2 rad off dead reckoning.
TEST(IntermediatePath, HeadingErrorSplitsEvenlyOverEqualIncrements) {
  const Eigen::Matrix3d c = diag(1e-4, 1e-4, 0.01);
  const IntermediatePath path =
      estimateIntermediatePath(Pose2(0, 0, 0), Pose2(0, 0, 0.3),
                               {Pose2(0, 0, 0), Pose2(0, 0, 0), Pose2(0, 0, 0)}, {c, c, c});
  ASSERT_EQ(path.means.size(), 2u);
  EXPECT_NEAR(path.means[0].z(), 0.1, 1e-9);
  EXPECT_NEAR(path.means[1].z(), 0.2, 1e-9);
  // var of the sum of the first k of n equal variances v given the total: v k (n - k) / n.
  EXPECT_NEAR(path.covariances[0](2, 2), 0.01 * 1 * 2 / 3.0, 1e-9);
  EXPECT_NEAR(path.covariances[1](2, 2), 0.01 * 2 * 1 / 3.0, 1e-9);
}

// Ends consistent with odometry along a curve: the estimate is the dead-reckoned path.
TEST(IntermediatePath, ConsistentEndsGiveTheOdometryPath) {
  const std::vector<Pose2> increments{Pose2(0.5, 0.0, 0.3), Pose2(0.4, 0.1, -0.2),
                                      Pose2(0.6, -0.05, 0.5), Pose2(0.3, 0.0, 0.1)};
  std::vector<Eigen::Matrix3d> covariances(4, diag(0.01, 0.02, 0.005));
  const Pose2 start(2.0, -1.0, 2.5);
  std::vector<Pose2> dead_reckoning{start};
  for (const Pose2& d : increments) dead_reckoning.push_back(compose(dead_reckoning.back(), d));
  const IntermediatePath path =
      estimateIntermediatePath(start, dead_reckoning.back(), increments, covariances);
  ASSERT_EQ(path.means.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(path.means[k].isApprox(dead_reckoning[k + 1], 1e-9)) << k;
    EXPECT_GT(path.covariances[k].determinant(), 0.0);
  }
}

// A curved chain with a large end error converges (iterated EKF) and meets the end exactly.
TEST(IntermediatePath, NonlinearCaseMeetsBothEnds) {
  const std::vector<Pose2> increments(6, Pose2(0.5, 0.0, 0.25));
  std::vector<Eigen::Matrix3d> covariances(6, diag(0.02, 0.02, 0.01));
  const Pose2 start(0, 0, 0);
  Pose2 end = start;
  for (const Pose2& d : increments) end = compose(end, d);
  end += Pose2(0.4, -0.3, 0.2);
  const IntermediatePath path = estimateIntermediatePath(start, end, increments, covariances);
  EXPECT_TRUE(path.converged);
  ASSERT_EQ(path.means.size(), 5u);
  // The last intermediate pose plus an increment near the odometry reaches the end: check the
  // implied last increment deviates less than the raw end error.
  const Pose2 last = between(path.means.back(), end);
  EXPECT_LT((last - increments.back()).head<2>().norm(), 0.3);
}

// The iterated estimate is the constrained least-squares optimum, not just a path that meets
// the end: minimising sum_k (d_k - u_k)^T P_k^-1 (d_k - u_k) over the increments d subject to
// chain(start, d) = end, the optimum has d - u = P H^T lambda for some lambda, H the Jacobian
// of the chain's end with respect to d (Lagrange). Checked with H by central differences, on a
// strongly curved case with unequal covariances and an end 0.6 m and 0.35 rad off.
TEST(IntermediatePath, IteratedEstimateIsTheConstrainedOptimum) {
  const std::vector<Pose2> u{{0.5, 0.0, 0.4}, {0.7, 0.1, -0.2}, {0.4, 0.0, 0.6},
                             {0.6, -0.1, 0.3}, {0.5, 0.0, -0.5}};
  const std::vector<Eigen::Matrix3d> p{diag(0.02, 0.01, 0.01), diag(0.05, 0.02, 0.03),
                                       diag(0.01, 0.01, 0.02), diag(0.03, 0.04, 0.01),
                                       diag(0.02, 0.02, 0.05)};
  const Pose2 start(1.0, -2.0, 0.3);
  const auto chainEnd = [&](const std::vector<Pose2>& d) {
    Pose2 x = start;
    for (const Pose2& step : d) x = compose(x, step);
    return x;
  };
  const Pose2 end = chainEnd(u) + Pose2(0.5, -0.33, 0.35);
  const IntermediatePath path = estimateIntermediatePath(start, end, u, p, 50);
  ASSERT_TRUE(path.converged) << path.iterations;
  ASSERT_EQ(path.means.size(), u.size() - 1);
  // The increments the estimate implies, the last one reaching the end.
  std::vector<Pose2> d;
  Pose2 previous = start;
  for (const Pose2& mean : path.means) {
    d.push_back(between(previous, mean));
    previous = mean;
  }
  d.push_back(between(previous, end));
  const int n = static_cast<int>(u.size());
  Eigen::VectorXd deviation(3 * n);
  Eigen::MatrixXd p_ht(3 * n, 3);  // P H^T, H by central differences at d
  for (int k = 0; k < n; ++k) {
    Pose2 dev = d[k] - u[k];
    dev.z() = wrapAngle(dev.z());
    deviation.segment<3>(3 * k) = dev;
    Eigen::Matrix3d h_k;
    for (int c = 0; c < 3; ++c) {
      std::vector<Pose2> plus = d, minus = d;
      plus[k](c) += 1e-6;
      minus[k](c) -= 1e-6;
      Pose2 diff = chainEnd(plus) - chainEnd(minus);
      diff.z() = wrapAngle(diff.z());
      h_k.col(c) = diff / 2e-6;
    }
    p_ht.block<3, 3>(3 * k, 0) = p[k] * h_k.transpose();
  }
  const Eigen::Vector3d lambda = p_ht.colPivHouseholderQr().solve(deviation);
  EXPECT_GT(deviation.norm(), 0.1);  // far from the odometry: the case is not trivial
  EXPECT_LT((p_ht * lambda - deviation).norm(), 1e-6 * deviation.norm())
      << "d - u is not in the range of P H^T: not the constrained optimum";
  // One iteration (the plain EKF step) is not the optimum on this curved case.
  const IntermediatePath once = estimateIntermediatePath(start, end, u, p, 1);
  EXPECT_GT((once.means.back() - path.means.back()).head<2>().norm(), 1e-3);
}

TEST(IntermediatePath, ComposeJacobiansMatchFiniteDifferences) {
  const Pose2 a(1.0, -0.5, 0.8), b(0.4, 0.3, -0.2);
  const double h = 1e-6;
  Eigen::Matrix3d first, second;
  for (int i = 0; i < 3; ++i) {
    Pose2 da = Pose2::Zero();
    da(i) = h;
    first.col(i) = (compose(a + da, b) - compose(a - da, b)) / (2 * h);
    second.col(i) = (compose(a, b + da) - compose(a, b - da)) / (2 * h);
  }
  EXPECT_TRUE(composeJacobianFirst(a, b).isApprox(first, 1e-6));
  EXPECT_TRUE(composeJacobianSecond(a).isApprox(second, 1e-6));
}

TEST(IntermediatePath, RejectsMismatchedInput) {
  EXPECT_THROW(estimateIntermediatePath(Pose2::Zero(), Pose2::Zero(), {}, {}),
               std::invalid_argument);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

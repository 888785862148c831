// The moments every filter's estimate() reports (core/filters/pose_moments.h).

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "rbpf_slam/core/filters/pose_moments.h"

namespace rbpf_slam {
namespace core {
namespace {

TEST(PoseMoments, HeadingMeanAcrossPiIsCircular) {
  // Headings of +179 and -179 deg: the mean is 180 deg, not 0, and the spread is 1 deg.
  const double d = M_PI / 180.0;
  const std::vector<Pose2> poses{Pose2(1.0, 0.0, M_PI - d), Pose2(3.0, 2.0, -M_PI + d)};
  const PoseEstimate e = poseMoments(poses, {0.5, 0.5});
  EXPECT_NEAR(e.mean.x(), 2.0, 1e-12);
  EXPECT_NEAR(e.mean.y(), 1.0, 1e-12);
  EXPECT_NEAR(std::fabs(e.mean.z()), M_PI, 1e-12);
  EXPECT_NEAR(e.covariance(2, 2), d * d, 1e-12);
  EXPECT_NEAR(e.covariance(0, 0), 1.0, 1e-12);
  EXPECT_NEAR(e.covariance(0, 1), 1.0, 1e-12);  // x and y move together
  EXPECT_NEAR(e.covariance(0, 2), d, 1e-12);  // the one further along x turned left of the mean
}

TEST(PoseMoments, WeightsPullTheMeanAndMixturesAddTheirComponents) {
  const std::vector<Pose2> means{Pose2(0.0, 0.0, 0.0), Pose2(4.0, 0.0, 0.0)};
  const PoseEstimate e = poseMoments(means, {0.75, 0.25});
  EXPECT_NEAR(e.mean.x(), 1.0, 1e-12);
  EXPECT_NEAR(e.covariance(0, 0), 0.75 * 1.0 + 0.25 * 9.0, 1e-12);
  const std::vector<Eigen::Matrix3d> components{Eigen::Matrix3d::Identity(),
                                                3.0 * Eigen::Matrix3d::Identity()};
  const PoseEstimate m = mixtureMoments(means, components, {0.75, 0.25});
  EXPECT_NEAR(m.mean.x(), 1.0, 1e-12);
  EXPECT_NEAR(m.covariance(0, 0), e.covariance(0, 0) + 1.5, 1e-12);
  EXPECT_NEAR(m.covariance(2, 2), 1.5, 1e-12);
  const PoseEstimate none = poseMoments({}, {});
  EXPECT_TRUE(none.mean.isZero());
  EXPECT_TRUE(none.covariance.isZero());
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

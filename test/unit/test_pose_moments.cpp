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

// Clusters as amcl forms them: cells that touch (also across the heading's wrap) join, a gap of
// a cell splits.
TEST(PoseMoments, ClustersJoinTouchingCellsAcrossTheHeadingWrap) {
  const double deg = M_PI / 180.0;
  const std::vector<Pose2> poses{Pose2(0.05, 0.05, 179 * deg),
                                 Pose2(0.15, 0.05, -179 * deg),  // neighbours across +-180
                                 Pose2(0.25, 0.05, -179 * deg),  // the next cell along x
                                 Pose2(0.45, 0.05, -179 * deg),  // a cell further: apart
                                 Pose2(0.05, 0.05, 90 * deg),    // same place, turned: apart
                                 Pose2(std::nan(""), 0.0, 0.0)};
  int count = 0;
  const std::vector<int> c = poseClusters(poses, 0.1, 10 * deg, &count);
  EXPECT_EQ(count, 3);
  EXPECT_EQ(c[0], c[1]);
  EXPECT_EQ(c[1], c[2]);
  EXPECT_NE(c[3], c[0]);
  EXPECT_NE(c[4], c[0]);
  EXPECT_NE(c[4], c[3]);
  EXPECT_EQ(c[5], -1);
  // Cells by floor, not truncation: -0.15 and 0.05 are two cells apart (truncated: neighbours).
  poseClusters({Pose2(-0.15, 0.0, 0.0), Pose2(0.05, 0.0, 0.0)}, 0.1, 10 * deg, &count);
  EXPECT_EQ(count, 2);
  // A heading cell that does not divide the turn: the last, narrower cell still meets the first.
  poseClusters({Pose2(0.0, 0.0, 3.1), Pose2(0.0, 0.0, -3.1)}, 0.1, 0.5, &count);
  EXPECT_EQ(count, 1);
}

// Two hypotheses (a look-alike place): the heavier one's mean is reported, not the point between
// them, with the whole cloud's second moment about it; one hypothesis gives poseMoments exactly.
TEST(PoseMoments, TheHeaviestClusterIsReportedWithTheWholeSpread) {
  std::vector<Pose2> poses;
  std::vector<double> weights;
  for (int i = 0; i < 10; ++i) {
    poses.push_back(Pose2(1.0 + 0.01 * i, 2.0, 0.1));  // 0.6 of the weight
    weights.push_back(0.06);
    poses.push_back(Pose2(-3.0 - 0.01 * i, 2.0, 0.1 + M_PI));  // its mirror image, 0.4
    weights.push_back(0.04);
  }
  const PoseEstimate all = poseMoments(poses, weights);
  const PoseEstimate e = heaviestClusterMoments(poses, weights, 0.5, 10 * M_PI / 180.0);
  EXPECT_NEAR(e.mean.x(), 1.045, 1e-9);
  EXPECT_NEAR(e.mean.y(), 2.0, 1e-9);
  EXPECT_NEAR(e.mean.z(), 0.1, 1e-9);
  const double dx = all.mean.x() - e.mean.x();
  EXPECT_NEAR(e.covariance(0, 0), all.covariance(0, 0) + dx * dx, 1e-9);
  EXPECT_GT(std::sqrt(e.covariance(0, 0)), 1.9);  // still says the cloud is spread
  // The heading's second moment about the reported heading, differences wrapped: the mirror
  // image is half a turn off.
  EXPECT_NEAR(e.covariance(2, 2), 0.4 * M_PI * M_PI, 1e-9);
  // Where the circular mean of all is not the reported heading's mirror: 0.4 of the weight at
  // 3 rad, 5 m on. The second moment about (0, 0, 0) is 0.4 * 9 and 0.4 * 25, not the cloud's
  // covariance plus the offset (3.10 in heading).
  const PoseEstimate turned = heaviestClusterMoments({Pose2(0.0, 0.0, 0.0), Pose2(5.0, 0.0, 3.0)},
                                                     {0.6, 0.4}, 0.5, 10 * M_PI / 180.0);
  EXPECT_NEAR(turned.mean.norm(), 0.0, 1e-12);
  EXPECT_NEAR(turned.covariance(2, 2), 3.6, 1e-9);
  EXPECT_NEAR(turned.covariance(0, 0), 10.0, 1e-9);
  EXPECT_NEAR(turned.covariance(0, 2), 6.0, 1e-9);
  for (double& w : weights) w = w > 0.05 ? 0.04 : 0.06;  // the mirror now the heavier
  EXPECT_NEAR(heaviestClusterMoments(poses, weights, 0.5, 10 * M_PI / 180.0).mean.x(), -3.045,
              1e-9);
  // Half and half: neither holds more than half, the whole cloud's mean.
  std::vector<double> halves(poses.size(), 1.0 / poses.size());
  EXPECT_EQ(heaviestClusterMoments(poses, halves, 0.5, 10 * M_PI / 180.0).mean,
            poseMoments(poses, halves).mean);
  // Three places, none holding half the weight: no place stands out, the whole cloud's mean.
  std::vector<Pose2> three = poses;
  std::vector<double> thirds;
  for (int i = 0; i < 10; ++i) three.push_back(Pose2(1.0 + 0.01 * i, -4.0, 0.1));
  for (size_t i = 0; i < three.size(); ++i) thirds.push_back(1.0 / three.size());
  const PoseEstimate none_stands_out =
      heaviestClusterMoments(three, thirds, 0.5, 10 * M_PI / 180.0);
  EXPECT_EQ(none_stands_out.mean, poseMoments(three, thirds).mean);
  std::vector<Pose2> one(poses.begin(), poses.begin() + 1);
  for (int i = 0; i < 10; ++i) one.push_back(Pose2(1.0 + 0.01 * i, 2.0, 0.1 + 0.001 * i));
  const std::vector<double> equal(one.size(), 1.0 / one.size());
  const PoseEstimate single = heaviestClusterMoments(one, equal, 0.5, 10 * M_PI / 180.0);
  const PoseEstimate plain = poseMoments(one, equal);
  EXPECT_EQ(single.mean, plain.mean);
  EXPECT_EQ(single.covariance, plain.covariance);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

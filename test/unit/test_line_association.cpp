// The pure functions of the line-based multi-filter SMC SLAM (Yuen and MacDonald): WAD (eqs.
// 13, 14), the Hausdorff distance (eq. 15), ToGlobalFrame (eqs. 9 to 12), the association with
// new-obstacle detection, and one landmark (parameter) filter converging on a synthetic line.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "rbpf_slam/core/filters/line_association.h"
#include "rbpf_slam/core/filters/multifilter_smc.h"

namespace rbpf_slam {
namespace core {
namespace {

const WadAssociationOptions kPaper;  // h = 1.0, c_w1 = 1.0, c_w2 = 1.5

TEST(LineAssociation, WadOnHandComputedCases) {
  // |2.0 - 1.5| + 1.5 * |0.3 - 0.1| = 0.5 + 0.3
  EXPECT_NEAR(weightedAbsoluteDifference({2.0, 0.3}, {1.5, 0.1}, 1.0, 1.5), 0.8, 1e-12);
  // Across the +-pi seam the angle difference is the short way round (eq. 13): 0.2 rad.
  EXPECT_NEAR(weightedAbsoluteDifference({1.0, M_PI - 0.1}, {1.0, -M_PI + 0.1}, 1.0, 1.5), 0.3,
              1e-12);
  // Opposite normals: delta theta = pi.
  EXPECT_NEAR(weightedAbsoluteDifference({3.0, 0.5}, {1.0, 0.5 - M_PI}, 2.0, 1.0), 4.0 + M_PI,
              1e-12);
  EXPECT_NEAR(angleDifference(0.1, 2.0 * M_PI + 0.3), 0.2, 1e-12);
  EXPECT_NEAR(angleDifference(-3.0, 3.0), 2.0 * M_PI - 6.0, 1e-12);
  EXPECT_DOUBLE_EQ(weightedAbsoluteDifference({1.2, -0.7}, {1.2, -0.7}, 1.0, 1.5), 0.0);
}

// compare_at "robot": |delta rho| is what the robot would see, whatever the origin. The wall
// x = 1 beside a robot at (0, 100), and the same wall turned 0.02 rad about the point beside
// the robot: in map-frame rho they are 2 m apart (the turn times the distance from the origin),
// seen from the robot 0.0002 m.
TEST(LineAssociation, ComparedAtTheRobotTheWadDoesNotGrowWithTheDistanceFromTheOrigin) {
  const Eigen::Vector2d robot(0.0, 100.0);
  const Eigen::Vector2d a(1.0, 0.0);
  const Eigen::Vector2d b(std::cos(0.02) + 100.0 * std::sin(0.02), 0.02);
  EXPECT_NEAR(lineSeenFrom(a, robot).x(), 1.0, 1e-12);
  EXPECT_NEAR(lineSeenFrom(b, robot).x(), std::cos(0.02), 1e-9);
  WadAssociationOptions at_robot = kPaper;
  at_robot.compare_at = "robot";
  const double seen = (1.0 - std::cos(0.02)) + 1.5 * 0.02;
  EXPECT_TRUE(wadCentre(at_robot, robot).isApprox(robot));
  EXPECT_TRUE(wadCentre(kPaper, robot).isZero());  // the paper's WAD: rho from the origin
  EXPECT_NEAR(featureDissimilarity(LandmarkType::kLine, a, b, at_robot, wadCentre(at_robot, robot)),
              seen, 1e-9);
  EXPECT_GT(featureDissimilarity(LandmarkType::kLine, a, b, kPaper, wadCentre(kPaper, robot)), 2.0);
  // Moving the origin (robot and lines together) does not change it.
  const Eigen::Vector2d shift(-37.0, 12.0);
  const Eigen::Vector2d a2(a.x() + shift.x() * std::cos(a.y()) + shift.y() * std::sin(a.y()),
                           a.y());
  const Eigen::Vector2d b2(b.x() + shift.x() * std::cos(b.y()) + shift.y() * std::sin(b.y()),
                           b.y());
  EXPECT_NEAR(featureDissimilarity(LandmarkType::kLine, a2, b2, at_robot, robot + shift), seen,
              1e-9);
  // The origin given as the centre is the paper's WAD.
  EXPECT_DOUBLE_EQ(featureDissimilarity(LandmarkType::kLine, a, b, at_robot, Eigen::Vector2d::Zero()),
                   lineWad(a, b, 1.0, 1.5));
  // Points are compared by their distance either way.
  EXPECT_NEAR(featureDissimilarity(LandmarkType::kPoint, {1, 1}, {4, 5}, at_robot, robot), 5.0,
              1e-12);
}

TEST(LineAssociation, LineWadTreatsBothNormalFormsAsOneLine) {
  // y = 0.05 and y = -0.03 seen with opposite normals: (0.05, pi/2) and (0.03, -pi/2) are
  // (0.05, pi/2) and (-0.03, pi/2): 0.08 apart, where the plain WAD says 0.02 + 1.5 pi.
  const Eigen::Vector2d a(0.05, M_PI / 2), b(0.03, -M_PI / 2);
  EXPECT_NEAR(weightedAbsoluteDifference(a, b, 1.0, 1.5), 0.02 + 1.5 * M_PI, 1e-12);
  EXPECT_NEAR(lineWad(a, b, 1.0, 1.5), 0.08, 1e-12);
  // Far from the origin the two agree.
  EXPECT_NEAR(lineWad({2.0, 0.3}, {1.5, 0.1}, 1.0, 1.5), 0.8, 1e-12);
  EXPECT_NEAR(featureDissimilarity(LandmarkType::kPoint, {1.0, 1.0}, {4.0, 5.0}, kPaper, {0.0, 0.0}), 5.0,
              1e-12);
}

TEST(LineAssociation, HausdorffOnHandComputedCases) {
  auto wad = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return weightedAbsoluteDifference(a, b, 1.0, 1.5);
  };
  const std::vector<Eigen::Vector2d> a = {{1.0, 0.0}, {4.0, 1.0}};
  const std::vector<Eigen::Vector2d> b = {{1.2, 0.0}, {2.0, 1.0}, {5.0, 1.2}};
  // a0: min(0.2, 1 + 1.5, 4 + 1.8) = 0.2; a1: min(3.2, 2.0, 1 + 0.3) = 1.3.
  EXPECT_NEAR(hausdorffDistance(a, b, wad), 1.3, 1e-12);
  // b0 -> 0.2, b1 -> min(1 + 1.5, 2) = 2.0, b2 -> min(4 + 1.8, 1.3) = 1.3: directed, not symmetric.
  EXPECT_NEAR(hausdorffDistance(b, a, wad), 2.0, 1e-12);
  EXPECT_EQ(hausdorffDistance({}, b, wad), 0.0);
  EXPECT_TRUE(std::isinf(hausdorffDistance(a, {}, wad)));
}

/// The map-frame line through a robot-frame segment, by the foot of the perpendicular from
/// the origin (the paper's construction, without slopes).
Eigen::Vector2d footOfPerpendicular(const Pose2& pose, const Eigen::Vector2d& p1,
                                    const Eigen::Vector2d& p2) {
  const double c = std::cos(pose.z()), s = std::sin(pose.z());
  const Eigen::Vector2d a(pose.x() + c * p1.x() - s * p1.y(), pose.y() + s * p1.x() + c * p1.y());
  const Eigen::Vector2d b(pose.x() + c * p2.x() - s * p2.y(), pose.y() + s * p2.x() + c * p2.y());
  const Eigen::Vector2d d = b - a;
  const Eigen::Vector2d foot = a - a.dot(d) / d.squaredNorm() * d;
  return Eigen::Vector2d(foot.norm(), std::atan2(foot.y(), foot.x()));
}

TEST(LineAssociation, ToGlobalFrameMatchesTheFootOfThePerpendicular) {
  Rng rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    const Pose2 pose(sampleGaussian(rng, 5.0), sampleGaussian(rng, 5.0),
                     wrapAngle(sampleGaussian(rng, 3.0)));
    LineFeature line;
    line.start << sampleGaussian(rng, 4.0), sampleGaussian(rng, 4.0);
    line.end = line.start + Eigen::Vector2d(sampleGaussian(rng, 3.0), sampleGaussian(rng, 3.0));
    if ((line.end - line.start).norm() < 0.1) continue;
    const Eigen::Vector2d expected = footOfPerpendicular(pose, line.start, line.end);
    if (expected.x() < 1e-3) continue;  // through the origin: theta undefined
    const Eigen::Vector2d got = toGlobalFrame(line, pose);
    EXPECT_NEAR(got.x(), expected.x(), 1e-9) << "trial " << trial;
    EXPECT_NEAR(wrapAngle(got.y() - expected.y()), 0.0, 1e-9) << "trial " << trial;
  }
  // Vertical and horizontal map lines (infinite slope in eqs. 9 to 12).
  LineFeature wall;
  wall.start << 2.0, -1.0;
  wall.end << 2.0, 1.0;
  Eigen::Vector2d g = toGlobalFrame(wall, Pose2(1.0, 0.0, 0.0));  // x = 3
  EXPECT_NEAR(g.x(), 3.0, 1e-12);
  EXPECT_NEAR(g.y(), 0.0, 1e-12);
  g = toGlobalFrame(wall, Pose2(0.0, 0.0, M_PI / 2));  // y = 2
  EXPECT_NEAR(g.x(), 2.0, 1e-12);
  EXPECT_NEAR(g.y(), M_PI / 2, 1e-12);
  // A degenerate segment falls back to the feature's own (rho, theta).
  LineFeature dot;
  dot.rho = 1.5;
  dot.theta = 0.0;
  g = toGlobalFrame(dot, Pose2(1.0, 2.0, M_PI / 2));  // robot x axis = map y: y = 3.5
  EXPECT_NEAR(g.x(), 3.5, 1e-12);
  EXPECT_NEAR(g.y(), M_PI / 2, 1e-12);
}

TEST(LineAssociation, AssociationAndNewObstacleDetection) {
  std::vector<GlobalFeature> features(3);
  features[0].value << 2.05, 0.02;  // WAD 0.08 to map 0
  features[1].value << 6.0, 1.0;    // far from everything: new
  features[2].type = LandmarkType::kPoint;
  features[2].value << 1.0, 1.0;  // 0.5 m from map point 2
  const std::vector<LandmarkType> types = {LandmarkType::kLine, LandmarkType::kLine,
                                           LandmarkType::kPoint};
  const std::vector<Eigen::Vector2d> map = {{2.0, 0.0}, {4.0, -1.5}, {1.3, 1.4}};
  WadAssociation a = associateByWad(features, types, map, kPaper, Eigen::Vector2d::Zero());
  EXPECT_EQ(a.map_to_feature, (std::vector<int>{0, -1, 2}));
  EXPECT_EQ(a.feature_to_map, (std::vector<int>{0, -1, 2}));
  EXPECT_EQ(a.new_features, (std::vector<int>{1}));
  // min over map for feature 1: min(4 + 1.5, 2 + 1.5 * 2.5) = 5.5.
  EXPECT_NEAR(a.hausdorff, 5.5, 1e-12);

  // Everything explained: the Hausdorff distance stays below h and nothing is new.
  features.erase(features.begin() + 1);
  a = associateByWad(features, types, map, kPaper, Eigen::Vector2d::Zero());
  EXPECT_TRUE(a.new_features.empty());
  EXPECT_LT(a.hausdorff, kPaper.h_similar_feature);

  // An empty map: every feature is new.
  a = associateByWad(features, {}, {}, kPaper, Eigen::Vector2d::Zero());
  EXPECT_EQ(a.new_features.size(), features.size());
}

TEST(LandmarkParticleFilter, ConvergesOnASyntheticLine) {
  const Eigen::Vector2d truth(3.0, 0.7);
  MultiFilterOptions options;  // 200 particles, c_m2 = 0.2
  for (unsigned seed : {1u, 2u, 3u}) {
    Rng rng(seed);
    const Eigen::Vector2d detection = truth + Eigen::Vector2d(0.12, -0.04);
    LandmarkParticleFilter filter(0, LandmarkType::kLine, detection,
                                  Eigen::Vector2d(options.init_sigma_m, options.init_sigma_rad),
                                  options.line_particles, rng);
    const double initial_wad = weightedAbsoluteDifference(filter.centroid(), truth, 1.0, 1.5);
    for (int k = 0; k < 40; ++k) {
      const Eigen::Vector2d z =
          truth + Eigen::Vector2d(sampleGaussian(rng, 0.03), sampleGaussian(rng, 0.01));
      ASSERT_TRUE(filter.update(z, Eigen::Vector2d::Zero(), kPaper, options, rng));
    }
    const Eigen::Vector2d c = filter.centroid();
    EXPECT_NEAR(c.x(), truth.x(), 0.03) << "seed " << seed;
    EXPECT_NEAR(wrapAngle(c.y() - truth.y()), 0.0, 0.015) << "seed " << seed;
    EXPECT_LT(weightedAbsoluteDifference(c, truth, 1.0, 1.5), 0.5 * initial_wad);
    EXPECT_EQ(filter.observations(), 41);
    EXPECT_EQ(static_cast<int>(filter.particles().size()), options.line_particles);
  }
}

// A new line filter's theta spread turns the line about the point nearest seen_from (the
// robot), not about the map origin's foot point: seen from a robot 50 m along the wall x = 100
// from that foot point, the spread stays the rho spread instead of 50 m x the theta spread.
TEST(LandmarkParticleFilter, ALineSpreadIsDrawnAsSeenFromTheRobot) {
  const Eigen::Vector2d wall(100.0, 0.0), robot(99.0, 50.0);
  const Eigen::Vector2d sigma(0.1, 0.03);
  const auto spreadAtRobot = [&](const Eigen::Vector2d& seen_from) {
    Rng rng(3);
    LandmarkParticleFilter filter(0, LandmarkType::kLine, wall, sigma, 400, rng, seen_from);
    double sum = 0.0, sum2 = 0.0;
    for (const Eigen::Vector2d& p : filter.particles()) {
      const double rho = lineSeenFrom(p, robot).x();  // where the particle's line passes
      sum += rho;
      sum2 += rho * rho;
    }
    const double n = filter.particles().size();
    // The wall is 1 m from the robot (checked where the spread is small enough to tell).
    if (seen_from == robot) {
      EXPECT_NEAR(sum / n, 1.0, 0.05);
    }
    return std::sqrt(sum2 / n - (sum / n) * (sum / n));
  };
  EXPECT_LT(spreadAtRobot(robot), 0.13);
  EXPECT_GT(spreadAtRobot(Eigen::Vector2d::Zero()), 1.0);  // 50 m x 0.03 rad, the paper's draw
}

// A loaded landmark: drawn from its whole covariance, centred on its mean; a covariance whose
// printed digits left it slightly indefinite still gives its spread, a non-finite one none.
TEST(LandmarkParticleFilter, RedrawKeepsTheMeanAndTheCorrelation) {
  const Eigen::Vector2d mean(20.0, 0.4);
  Eigen::Matrix2d tied;
  tied << 2.25, 0.0450001, 0.0450001, 0.0009;  // rho-theta correlation just above 1
  Rng rng(5);
  LandmarkParticleFilter filter(0, LandmarkType::kLine, mean, Eigen::Vector2d::Zero(), 2000, rng);
  filter.redraw(mean, tied, rng);
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : filter.particles()) sum += p;
  EXPECT_TRUE((sum / 2000.0).isApprox(mean, 1e-9));
  double rr = 0.0, rt = 0.0;
  for (const Eigen::Vector2d& p : filter.particles()) {
    rr += (p.x() - mean.x()) * (p.x() - mean.x());
    rt += (p.x() - mean.x()) * (p.y() - mean.y());
  }
  EXPECT_NEAR(rr / 2000.0, 2.25, 0.25);
  EXPECT_NEAR(rt / 2000.0, 0.045, 0.006);  // the correlation kept
  Eigen::Matrix2d broken = tied;
  broken(0, 1) = std::numeric_limits<double>::quiet_NaN();
  filter.redraw(mean, broken, rng);
  for (const Eigen::Vector2d& p : filter.particles()) EXPECT_TRUE(p.isApprox(mean));
}

TEST(LandmarkParticleFilter, PlainSirSettlesNearTheLineWithoutRoughening) {
  // The shipped config's plain SIR (no jitter): the particles can only be resampled, so the
  // centroid moves from the detection towards the truth within the first draws' spread.
  const Eigen::Vector2d truth(-2.0, 0.3);  // a line with its normal flipped: rho < 0
  MultiFilterOptions options;
  options.roughening_m = 0.0;
  options.roughening_rad = 0.0;
  Rng rng(11);
  const Eigen::Vector2d detection(2.08, 0.3 + M_PI + 0.03);  // the same line, rho >= 0
  LandmarkParticleFilter filter(0, LandmarkType::kLine, detection,
                                Eigen::Vector2d(options.init_sigma_m, options.init_sigma_rad),
                                options.line_particles, rng);
  for (int k = 0; k < 30; ++k) {
    const Eigen::Vector2d z(2.0 + sampleGaussian(rng, 0.02),
                            wrapAngle(0.3 + M_PI + sampleGaussian(rng, 0.01)));
    ASSERT_TRUE(filter.update(z, Eigen::Vector2d::Zero(), kPaper, options, rng));
  }
  const double before = lineWad(detection, truth, 1.0, 1.5);
  const double after = lineWad(filter.centroid(), truth, 1.0, 1.5);
  EXPECT_LT(after, 0.5 * before);
  EXPECT_GE(filter.centroid().x(), 0.0);  // reported in normal form
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

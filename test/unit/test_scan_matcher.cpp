// Point-to-line ICP on synthetic scans of a room with a known motion between them.

#include <gtest/gtest.h>

#include <cmath>

#include "rbpf_slam/core/features/scan_matcher.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {
namespace {

/// Ray-casts a 10 m x 8 m room with an inner box from pose, 1 degree beams over 180 degrees.
std::vector<Eigen::Vector2d> roomScan(const Pose2& pose, double noise, Rng* rng,
                                      bool corridor = false) {
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls;
  if (corridor) {
    walls = {{{-50, -1}, {50, -1}}, {{-50, 1}, {50, 1}}};
  } else {
    walls = {{{-5, -4}, {5, -4}}, {{5, -4}, {5, 4}}, {{5, 4}, {-5, 4}}, {{-5, 4}, {-5, -4}},
             {{1, -1}, {2, -1}},  {{2, -1}, {2, 1}},  {{2, 1}, {1, 1}}};
  }
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i <= 180; ++i) {
    const double a = pose.z() - M_PI / 2 + i * M_PI / 180;
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    double best = INFINITY;
    for (const auto& [p, q] : walls) {
      const Eigen::Vector2d e = q - p;
      const double den = d.x() * e.y() - d.y() * e.x();
      if (std::fabs(den) < 1e-12) continue;
      const Eigen::Vector2d w = p - pose.head<2>();
      const double t = (w.x() * e.y() - w.y() * e.x()) / den;
      const double u = (w.x() * d.y() - w.y() * d.x()) / den;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    if (!std::isfinite(best) || best > 15) continue;
    const double r = best + sampleGaussian(*rng, noise);
    points.emplace_back(r * std::cos(a - pose.z()), r * std::sin(a - pose.z()));
  }
  return points;
}

TEST(ScanMatcher, RecoversKnownMotionFromPoorOdometry) {
  Rng rng(4);
  const Pose2 first(-2.0, 0.5, 0.1), motion(0.6, 0.1, 0.25);
  const auto reference = roomScan(first, 0.01, &rng);
  const auto current = roomScan(compose(first, motion), 0.01, &rng);
  ScanMatcherOptions options;
  options.enabled = true;
  const ScanMatcher matcher(options);
  // Odometry off by 20 cm and 0.12 rad, as between the sparse scans of the Intel log.
  const ScanMatchResult r = matcher.match(reference, current, Pose2(0.45, 0.2, 0.13));
  ASSERT_TRUE(r.ok);
  EXPECT_LT((r.delta.head<2>() - motion.head<2>()).norm(), 0.02) << r.delta.transpose();
  EXPECT_LT(std::fabs(wrapAngle(r.delta.z() - motion.z())), 0.005);
  EXPECT_GT(r.inlier_ratio, 0.8);
}

TEST(ScanMatcher, CorridorKeepsOdometryAlongTheAxis) {
  Rng rng(5);
  const Pose2 first(0.0, 0.0, 0.0), motion(1.0, 0.05, 0.02);
  const auto reference = roomScan(first, 0.005, &rng, true);
  const auto current = roomScan(compose(first, motion), 0.005, &rng, true);
  ScanMatcherOptions options;
  options.enabled = true;
  const ScanMatcher matcher(options);
  const Pose2 odometry(0.8, 0.0, 0.0);  // 20 cm short along the corridor
  const ScanMatchResult r = matcher.match(reference, current, odometry);
  ASSERT_TRUE(r.ok);
  EXPECT_TRUE(r.degenerate);
  EXPECT_NEAR(r.delta.x(), 0.8, 0.05);   // along the axis: odometry, not wherever it slid
  EXPECT_NEAR(r.delta.y(), 0.05, 0.02);  // across it: the walls
  EXPECT_NEAR(r.delta.z(), 0.02, 0.01);
}

// Odometry with a glitch (the Intel log's repeated and out-of-order stamps put it metres off
// between two scans): no start near it converges or passes max_correction, so the matcher
// starts again from rest instead of handing the broken odometry to the filter.
TEST(ScanMatcher, RecoversFromAnOdometryGlitchByStartingFromRest) {
  Rng rng(6);
  const Pose2 first(-2.0, 0.5, 0.1), motion(0.6, -0.1, -0.3);
  const auto reference = roomScan(first, 0.01, &rng);
  const auto current = roomScan(compose(first, motion), 0.01, &rng);
  ScanMatcherOptions options;
  options.enabled = true;
  const ScanMatcher matcher(options);
  const ScanMatchResult r = matcher.match(reference, current, Pose2(4.5, -2.4, -0.05));
  ASSERT_TRUE(r.ok);
  EXPECT_TRUE(r.from_rest);
  EXPECT_LT((r.delta.head<2>() - motion.head<2>()).norm(), 0.02) << r.delta.transpose();
  EXPECT_LT(std::fabs(wrapAngle(r.delta.z() - motion.z())), 0.005);
  // Good odometry is still the first start.
  const ScanMatchResult good = matcher.match(reference, current, Pose2(0.55, -0.05, -0.25));
  ASSERT_TRUE(good.ok);
  EXPECT_FALSE(good.from_rest);
  // From rest, a corridor leaves the motion along it unmeasured: rejected, not zero.
  const auto corridor_ref = roomScan(Pose2::Zero(), 0.005, &rng, true);
  const auto corridor_cur = roomScan(Pose2(0.8, 0.05, 0.02), 0.005, &rng, true);
  EXPECT_FALSE(matcher.match(corridor_ref, corridor_cur, Pose2(5.0, 0.0, 0.0)).ok);
}

// Wheel odometry 15-25 deg off over one in-place turn (Intel, ACES): from a start that far
// off, ICP ends in a wrong minimum that still pairs part of the points. A poor match is
// retried from a fan of rotations within max_correction_rad, and the best one kept.
TEST(ScanMatcher, RotationSearchRecoversATurnThatOdometryGotWrong) {
  Rng rng(7);
  const Pose2 first(-2.5, -1.0, 0.4), motion(0.05, 0.02, 0.55);
  const auto reference = roomScan(first, 0.01, &rng);
  const auto current = roomScan(compose(first, motion), 0.01, &rng);
  const Pose2 odometry(0.05, 0.02, 0.55 - 0.35);  // 20 deg short of the turn
  ScanMatcherOptions options;
  options.enabled = true;
  options.rotation_guess_rad = 0.0;  // only the start at odometry
  const ScanMatchResult plain = ScanMatcher(options).match(reference, current, odometry);
  // Without the search the turn is not recovered (the test's premise).
  EXPECT_TRUE(!plain.ok || std::fabs(wrapAngle(plain.delta.z() - motion.z())) > 0.05)
      << plain.delta.transpose();
  options.search_below_inlier_ratio = 0.6;
  options.search_step_rad = 0.1;
  const ScanMatchResult r = ScanMatcher(options).match(reference, current, odometry);
  ASSERT_TRUE(r.ok);
  EXPECT_FALSE(r.from_rest);
  EXPECT_LT((r.delta.head<2>() - motion.head<2>()).norm(), 0.02) << r.delta.transpose();
  EXPECT_LT(std::fabs(wrapAngle(r.delta.z() - motion.z())), 0.005);
  EXPECT_GT(r.inlier_ratio, 0.7);
  // The search stays within max_correction_rad of odometry.
  options.max_correction_rad = 0.25;
  const ScanMatchResult bounded = ScanMatcher(options).match(reference, current, odometry);
  EXPECT_TRUE(!bounded.ok || std::fabs(wrapAngle(bounded.delta.z() - odometry.z())) <= 0.25);
}

// Session 53: an odometry glitch comes with a wrong turn too (Intel's: 5.4 m and -0.68 rad
// between two scans), so the match from rest searches the same fan of rotations as the one from
// odometry; matchFromRest (the start after an odometry jump) is that match alone (its refusal of
// a degenerate match: SlamPipeline.AnOdometryJumpDoesNotSeedTheScanMatch).
TEST(ScanMatcher, TheMatchFromRestSearchesRotationsToo) {
  Rng rng(8);
  const Pose2 first(-2.5, -1.0, 0.4), motion(0.3, 0.05, 0.55);
  const auto reference = roomScan(first, 0.01, &rng);
  const auto current = roomScan(compose(first, motion), 0.01, &rng);
  const Pose2 glitch(4.5, -2.4, -0.05);
  ScanMatcherOptions options;
  options.enabled = true;
  options.rotation_guess_rad = 0.0;
  // Without the search the start at rest does not reach the turn (the test's premise).
  const ScanMatchResult plain = ScanMatcher(options).match(reference, current, glitch);
  EXPECT_TRUE(!plain.ok || std::fabs(wrapAngle(plain.delta.z() - motion.z())) > 0.05)
      << plain.delta.transpose();
  options.search_below_inlier_ratio = 0.6;
  options.search_step_rad = 0.1;
  const ScanMatcher matcher(options);
  for (const ScanMatchResult& r :
       {matcher.match(reference, current, glitch), matcher.matchFromRest(reference, current)}) {
    ASSERT_TRUE(r.ok);
    EXPECT_TRUE(r.from_rest);
    EXPECT_LT((r.delta.head<2>() - motion.head<2>()).norm(), 0.02) << r.delta.transpose();
    EXPECT_LT(std::fabs(wrapAngle(r.delta.z() - motion.z())), 0.005);
  }
}

TEST(ScanMatcher, RejectsTooFewPointsAndInvalidOptions) {
  ScanMatcherOptions options;
  const ScanMatcher matcher(options);
  EXPECT_FALSE(matcher.match({}, {}, Pose2::Zero()).ok);
  options.min_correspondence_m = 2.0;  // above max_correspondence_m
  EXPECT_THROW(validate(options), std::invalid_argument);
  try {
    options.min_correspondence_m = 0.1;
    options.noise_scale = -1.0;
    validate(options);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("scan_matching.noise_scale"), std::string::npos);
  }
  try {
    options.noise_scale = 0.3;
    options.degenerate_noise_scale = 0.0;
    validate(options);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("scan_matching.degenerate_noise_scale"),
              std::string::npos);
  }
}

// The filter's motion noise for a matched increment: noise_scale for a match that fixes every
// direction, degenerate_noise_scale for one whose weak direction came from odometry (1, the
// code default: odometry's noise; laser_fastslam2.yaml 0.5).
TEST(ScanMatcher, NoiseScaleFollowsWhetherADirectionCameFromOdometry) {
  Rng rng(8);
  const auto room_ref = roomScan(Pose2(-2.0, 0.5, 0.1), 0.01, &rng);
  const auto room_cur = roomScan(compose(Pose2(-2.0, 0.5, 0.1), Pose2(0.5, 0.0, 0.1)), 0.01, &rng);
  const auto corridor_ref = roomScan(Pose2::Zero(), 0.005, &rng, true);
  const auto corridor_cur = roomScan(Pose2(1.0, 0.05, 0.02), 0.005, &rng, true);
  ScanMatcherOptions options;
  options.enabled = true;
  options.noise_scale = 0.2;
  const ScanMatchResult room =
      ScanMatcher(options).match(room_ref, room_cur, Pose2(0.45, 0.05, 0.08));
  ASSERT_TRUE(room.ok);
  ASSERT_FALSE(room.degenerate);
  const ScanMatchResult corridor =
      ScanMatcher(options).match(corridor_ref, corridor_cur, Pose2(0.8, 0, 0));
  ASSERT_TRUE(corridor.ok);
  ASSERT_TRUE(corridor.degenerate);
  for (const double degenerate_scale : {1.0, 0.7, 3.0}) {
    options.degenerate_noise_scale = degenerate_scale;
    const ScanMatcher matcher(options);
    EXPECT_EQ(matcher.noiseScale(room), 0.2);
    EXPECT_EQ(matcher.noiseScale(corridor), degenerate_scale);
  }
}

TEST(ScanMatcher, ScanPointsSkipInvalidBeams) {
  RangeScan scan;
  scan.angle_min = -0.1;
  scan.angle_increment = 0.1;
  scan.range_min = 0.1;
  scan.range_max = 10.0;
  scan.ranges = {1.0f, NAN, INFINITY, 0.0f, 0.05f, 20.0f, 2.0f};
  scan.sensor_pose = Pose2(0.5, 0.0, 0.0);
  const auto points = scanPointsInBase(scan, 15.0);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_NEAR(points[0].x(), 0.5 + std::cos(-0.1), 1e-9);
  EXPECT_NEAR(points[1].x(), 0.5 + 2.0 * std::cos(0.5), 1e-6);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

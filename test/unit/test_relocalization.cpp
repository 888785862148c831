// Re-association after drift (relocalization.h): the pose correction search against a known
// map, and FastSLAM 2.0 recovering from an odometry glitch larger than its proposal covers.

#include <gtest/gtest.h>

#include <cmath>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/landmark_map.h"
#include "rbpf_slam/core/filters/relocalization.h"
#include "synthetic_world.h"

namespace rbpf_slam {
namespace core {
namespace {

/// The world's walls and posts as a map (what a filter that never drifted would hold).
LandmarkMap mapOf(const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& walls,
                  const std::vector<Eigen::Vector2d>& posts) {
  LandmarkMap map;
  for (const auto& [a, b] : walls) {
    Landmark lm;
    lm.type = LandmarkType::kLine;
    lm.mean = lineThrough(a, b);
    lm.covariance = Eigen::Vector2d(0.01 * 0.01, 0.005 * 0.005).asDiagonal();
    lm.extent_min = std::min(alongLine(lm.mean, a), alongLine(lm.mean, b));
    lm.extent_max = std::max(alongLine(lm.mean, a), alongLine(lm.mean, b));
    lm.id = map.size();
    map.add(lm);
  }
  for (const auto& p : posts) {
    Landmark lm;
    lm.type = LandmarkType::kPoint;
    lm.mean = p;
    lm.covariance = Eigen::Matrix2d::Identity() * 0.01 * 0.01;
    lm.id = map.size();
    map.add(lm);
  }
  return map;
}

std::vector<Observation> observe(const SyntheticWorld& world, const Pose2& truth, unsigned seed) {
  Rng rng(seed);
  FilterOptions options;
  int rejected = 0;
  return prepareObservations(world.observe(truth, rng, 0.01, 0.003), options, &rejected);
}

TEST(Relocalization, FindsTheCorrectionOfADriftedPoseInARoom) {
  SyntheticWorld world;
  const LandmarkMap map = mapOf(world.walls, world.posts);
  const Pose2 truth(-2.0, -1.0, 0.3);
  const std::vector<Observation> obs = observe(world, truth, 3);
  RelocalizationOptions options;
  for (const Pose2& drift : {Pose2(0.7, -0.4, 0.09), Pose2(-1.2, 0.8, -0.15), Pose2(0.3, 0.3, 0.0)}) {
    const Pose2 drifted(truth.x() + drift.x(), truth.y() + drift.y(), truth.z() + drift.z());
    const PoseCorrection c = searchPoseCorrection(map, drifted, obs, options, 1.0);
    ASSERT_TRUE(c.found) << "drift " << drift.transpose();
    EXPECT_LT((c.pose.head<2>() - truth.head<2>()).norm(), 0.1) << "drift " << drift.transpose();
    EXPECT_LT(std::fabs(wrapAngle(c.pose.z() - truth.z())), 0.01) << "drift " << drift.transpose();
    EXPECT_GE(c.support, static_cast<int>(obs.size()) - 2);
  }
}

TEST(Relocalization, LeavesTheShiftAlongACorridorAtZero) {
  // Two long parallel walls: heading and the offset across the corridor are observable, the
  // position along it is not, and the search must not invent one.
  SyntheticWorld corridor;
  corridor.walls = {{{-20, -1}, {20, -1}}, {{20, 1}, {-20, 1}}};
  corridor.posts.clear();
  const LandmarkMap map = mapOf(corridor.walls, {});
  SyntheticWorld seen = corridor;  // the robot sees 10 m of each wall
  seen.walls = {{{-5, -1}, {5, -1}}, {{5, 1}, {-5, 1}}};
  const Pose2 truth(0.0, 0.0, 0.0);
  const std::vector<Observation> obs = observe(seen, truth, 4);
  RelocalizationOptions options;
  options.min_matches = 2;
  const Pose2 drifted(0.8, 0.35, 0.06);
  const PoseCorrection c = searchPoseCorrection(map, drifted, obs, options, 1.0);
  ASSERT_TRUE(c.found);
  EXPECT_NEAR(c.pose.y(), truth.y(), 0.05);
  EXPECT_NEAR(wrapAngle(c.pose.z() - truth.z()), 0.0, 0.01);
  EXPECT_NEAR(c.pose.x(), drifted.x(), 1e-9);  // along the corridor: unchanged
}

// min_information: along a corridor the walls say nothing, so a correction along it rests on
// the points alone. One point is refused at 2 (a wrong pairing would move the robot along the
// corridor unopposed), two are accepted; without the condition one does.
TEST(Relocalization, MinInformationWantsTwoPointsAlongACorridor) {
  SyntheticWorld corridor;
  corridor.walls = {{{-20, -1}, {20, -1}}, {{20, 1}, {-20, 1}}};
  corridor.posts = {{3.0, 0.5}, {-2.0, -0.5}};
  const LandmarkMap map = mapOf(corridor.walls, corridor.posts);
  SyntheticWorld seen = corridor;  // 10 m of each wall, one or both posts
  seen.walls = {{{-5, -1}, {5, -1}}, {{5, 1}, {-5, 1}}};
  const Pose2 truth(0.0, 0.0, 0.0), drifted(0.8, 0.35, 0.06);
  RelocalizationOptions options;
  options.min_matches = 2;
  const auto search = [&](size_t posts, double min_information) {
    seen.posts.assign(corridor.posts.begin(), corridor.posts.begin() + posts);
    options.min_information = min_information;
    return searchPoseCorrection(map, drifted, observe(seen, truth, 4), options, 1.0);
  };
  for (size_t posts : {size_t(1), size_t(2)}) {
    const PoseCorrection c = search(posts, 0.0);
    ASSERT_TRUE(c.found) << posts << " post(s), no condition";
    EXPECT_NEAR(c.pose.x(), truth.x(), 0.1) << posts << " post(s): fixed along the corridor";
  }
  EXPECT_FALSE(search(1, 2.0).found) << "one post";
  const PoseCorrection two = search(2, 2.0);
  ASSERT_TRUE(two.found) << "two posts";
  EXPECT_NEAR(two.pose.x(), truth.x(), 0.1);
  EXPECT_NEAR(two.pose.y(), truth.y(), 0.2);  // a candidate shift, walls within 0.15 m of it
}

TEST(Relocalization, SearchesOnlyWithinItsWindow) {
  SyntheticWorld world;
  const LandmarkMap map = mapOf(world.walls, world.posts);
  const Pose2 truth(1.0, 0.5, -0.2);
  const std::vector<Observation> obs = observe(world, truth, 5);
  RelocalizationOptions options;  // 2 m, 0.2 rad
  const Pose2 turned_too_far(truth.x(), truth.y(), truth.z() + 0.4);
  const PoseCorrection c = searchPoseCorrection(map, turned_too_far, obs, options, 1.0);
  EXPECT_FALSE(c.found && std::fabs(wrapAngle(c.pose.z() - truth.z())) < 0.05)
      << "a 0.4 rad error is outside the 0.2 rad window";
  EXPECT_FALSE(searchPoseCorrection(LandmarkMap(), truth, obs, options, 1.0).found);
  EXPECT_FALSE(searchPoseCorrection(map, truth, {}, options, 1.0).found);
}

/// Anchors a map at truth, then reports an odometry increment off by `glitch` for a true
/// motion of 0.5 m forward; returns the filter's position error after the next update.
double errorAfterGlitch(bool relocalize, long* relocalizations) {
  SyntheticWorld world;
  FilterOptions options;
  options.particles = 20;
  options.seed = 7;
  options.relocalization.enabled = relocalize;
  // The tight noise of a scan-matched increment (laser config: noise_scale 0.1).
  options.motion.alpha1 = options.motion.alpha2 = options.motion.alpha3 = 0.001;
  options.motion.alpha4 = 0.001;
  options.motion.min_sigma_xy_m = 0.01;
  options.motion.min_sigma_theta_rad = 0.005;
  FastSlam2 filter(options);
  Rng rng(2);
  Pose2 truth(-2.0, -1.0, 0.3);
  filter.reset(truth);
  filter.update(world.observe(truth, rng, 0.01, 0.003));
  const Pose2 delta(0.5, 0.0, 0.0);
  truth = compose(truth, delta);
  MotionInput motion;
  motion.delta = Pose2(delta.x() + 0.9, 0.4, 0.12);  // wheel slip and a bad turn reading
  filter.predict(motion);
  filter.update(world.observe(truth, rng, 0.01, 0.003));
  *relocalizations = filter.stats().relocalizations;
  return (filter.estimate().mean.head<2>() - truth.head<2>()).norm();
}

TEST(FastSlam2, RelocalizesAfterAnOdometryGlitchLargerThanItsProposal) {
  long off = 0, on = 0;
  const double error_without = errorAfterGlitch(false, &off);
  const double error_with = errorAfterGlitch(true, &on);
  EXPECT_EQ(off, 0);
  EXPECT_GT(on, 0);
  EXPECT_GT(error_without, 0.5);  // the glitch is outside every particle's gate
  EXPECT_LT(error_with, 0.1);
}

/// Spread (std of x over the particles) after one update from a common pose.
double spreadAfterOneUpdate(double sample_scale) {
  SyntheticWorld world;
  FilterOptions options;
  options.particles = 200;
  options.seed = 3;
  options.proposal_sample_scale = sample_scale;
  FastSlam2 filter(options);
  Rng rng(4);
  const Pose2 start(-2.0, -1.0, 0.3);
  filter.reset(start);
  filter.update(world.observe(start, rng, 0.01, 0.003));
  MotionInput motion;
  motion.delta = Pose2(0.5, 0.0, 0.05);
  filter.predict(motion);
  filter.update(world.observe(compose(start, motion.delta), rng, 0.01, 0.003));
  double sum = 0.0, sum_sq = 0.0;
  const auto particles = filter.particles();
  for (const auto& p : particles) {
    sum += p.pose.x();
    sum_sq += p.pose.x() * p.pose.x();
  }
  const double n = static_cast<double>(particles.size());
  return std::sqrt(std::max(0.0, sum_sq / n - (sum / n) * (sum / n)));
}

TEST(FastSlam2, ProposalSampleScaleNarrowsTheDrawBySqrtScale) {
  const double full = spreadAfterOneUpdate(1.0), quarter = spreadAfterOneUpdate(0.25);
  ASSERT_GT(full, 0.0);
  EXPECT_NEAR(quarter / full, 0.5, 0.15);  // covariance x 0.25: standard deviation x 0.5
}

TEST(Relocalization, OptionsAreValidated) {
  RelocalizationOptions o;
  EXPECT_NO_THROW(validate(o));
  o.search_theta_rad = 2.0;
  EXPECT_THROW(validate(o), std::invalid_argument);
  o = RelocalizationOptions();
  o.min_unmatched_ratio = std::nan("");
  EXPECT_THROW(validate(o), std::invalid_argument);
  o = RelocalizationOptions();
  o.min_information = -1.0;
  EXPECT_THROW(validate(o), std::invalid_argument);
  FilterOptions f;
  f.proposal_sample_scale = 0.0;
  EXPECT_THROW(validate(f), std::invalid_argument);
  f.proposal_sample_scale = 0.25;
  f.relocalization.search_xy_m = -1.0;
  EXPECT_THROW(validate(f), std::invalid_argument);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

// The multi-filter SMC (Yuen and MacDonald) and EKF-SLAM variants through the SlamFilter
// interface: bad features are skipped and counted, both beat odometry on simulated runs of
// worlds/test_small.yaml, the EKF is consistent on a synthetic loop, maps round-trip.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <string>

#include "rbpf_slam/core/filters/ekf_slam.h"
#include "rbpf_slam/core/filters/multifilter_smc.h"
#include "rbpf_slam/core/sim/simulator.h"
#include "rbpf_slam/core/slam/slam_pipeline.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/io/world_yaml.h"

namespace rbpf_slam {
namespace core {
namespace {

const std::string kRoot = RBPF_SOURCE_DIR;

FilterOptions optionsFor(const std::string& variant) {
  FilterOptions o = io::loadSlamConfig(kRoot + "/config/laser_" +
                                       (variant == "ekf_slam" ? "ekf" : "multifilter") + ".yaml")
                        .filter;
  o.particles = 300;
  return o;
}

/// The walls of a 10 m x 8 m room and one diagonal wall, as map-frame segments.
const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> kWalls = {
    {{0, 0}, {10, 0}}, {{10, 0}, {10, 8}}, {{10, 8}, {0, 8}}, {{0, 8}, {0, 0}}, {{3, 5}, {6, 3}}};

/// Every wall seen from `pose`, as a robot-frame line feature with noise on (rho, theta)
/// and end points projected onto the noisy line.
FeatureSet observeWalls(const Pose2& pose, Rng& rng, double sigma_rho, double sigma_theta) {
  FeatureSet set;
  const Pose2 to_robot = inverse(pose);
  for (const auto& wall : kWalls) {
    const Eigen::Vector2d a = transformPoint(to_robot, wall.first);
    const Eigen::Vector2d b = transformPoint(to_robot, wall.second);
    const Eigen::Vector2d d = (b - a).normalized();
    Eigen::Vector2d n(-d.y(), d.x());
    double rho = n.dot(a), theta = std::atan2(n.y(), n.x());
    normalizeLine(rho, theta);
    LineFeature f;
    f.rho = rho + sampleGaussian(rng, sigma_rho);
    f.theta = wrapAngle(theta + sampleGaussian(rng, sigma_theta));
    f.covariance = Eigen::Vector2d(sigma_rho * sigma_rho, sigma_theta * sigma_theta).asDiagonal();
    const Eigen::Vector2d nn(std::cos(f.theta), std::sin(f.theta)), dd(-nn.y(), nn.x());
    f.start = f.rho * nn + dd.dot(a) * dd;
    f.end = f.rho * nn + dd.dot(b) * dd;
    set.lines.push_back(f);
  }
  return set;
}

struct LoopResult {
  double filter_error_m = 0.0;    // mean position error over the run
  double odometry_error_m = 0.0;  // same for dead reckoning
  double max_nees = 0.0;          // EKF: largest pose NEES over the run
  double mean_nees = 0.0;
};

/// Two laps of a 6 m x 4 m rectangle inside the room, odometry with a heading bias.
LoopResult runSyntheticLoop(SlamFilter* filter, unsigned seed) {
  Rng rng(seed);
  Pose2 truth(2.0, 2.0, 0.0), odometry = truth;
  filter->reset(truth);
  filter->update(observeWalls(truth, rng, 0.02, 0.01));
  LoopResult r;
  int steps = 0;
  for (int lap = 0; lap < 2; ++lap) {
    for (int side = 0; side < 4; ++side) {
      const int moves = side % 2 == 0 ? 12 : 8;
      for (int k = 0; k <= moves; ++k) {
        const Pose2 delta = k < moves ? Pose2(0.5, 0.0, 0.0) : Pose2(0.0, 0.0, M_PI / 2);
        truth = compose(truth, delta);
        Pose2 measured = delta;
        measured.x() += sampleGaussian(rng, 0.02) + 0.03 * delta.x();
        measured.z() += sampleGaussian(rng, 0.01) + 0.02 * delta.x() + 0.03 * delta.z();
        odometry = compose(odometry, measured);
        MotionInput motion;
        motion.delta = measured;
        motion.dt = 1.0;
        filter->predict(motion);
        filter->update(observeWalls(truth, rng, 0.02, 0.01));
        const PoseEstimate e = filter->estimate();
        r.filter_error_m += (e.mean.head<2>() - truth.head<2>()).norm();
        r.odometry_error_m += (odometry.head<2>() - truth.head<2>()).norm();
        Eigen::Vector3d err = e.mean - truth;
        err.z() = wrapAngle(err.z());
        const double nees = err.dot(e.covariance.inverse() * err);
        r.max_nees = std::max(r.max_nees, nees);
        r.mean_nees += nees;
        ++steps;
      }
    }
  }
  r.filter_error_m /= steps;
  r.odometry_error_m /= steps;
  r.mean_nees /= steps;
  return r;
}

TEST(LineSlam, FactoryBuildsBothVariants) {
  for (const std::string variant : {"multifilter_smc", "ekf_slam"}) {
    FilterOptions o = optionsFor(variant);
    o.variant = variant;
    const auto filter = createFilter(o);
    EXPECT_EQ(filter->variant(), variant);
  }
  FilterOptions bad = optionsFor("multifilter_smc");
  bad.multifilter.c_m1 = 0.0;
  EXPECT_THROW(createFilter(bad), std::invalid_argument);
}

TEST(LineSlam, NonFiniteFeaturesAreSkippedAndCounted) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const std::string variant : {"multifilter_smc", "ekf_slam"}) {
    SCOPED_TRACE(variant);
    auto filter = createFilter(optionsFor(variant));
    Rng rng(5);
    FeatureSet set = observeWalls(Pose2(2.0, 2.0, 0.0), rng, 0.02, 0.01);
    const int good = set.lines.size();
    LineFeature bad_line = set.lines[0];
    bad_line.rho = nan;
    set.lines.push_back(bad_line);
    bad_line = set.lines[1];
    bad_line.start.x() = inf;
    set.lines.push_back(bad_line);
    PointFeature bad_point;
    bad_point.range = nan;
    set.points.push_back(bad_point);
    bad_point.range = 2.0;
    bad_point.bearing = inf;
    set.points.push_back(bad_point);
    filter->reset(Pose2(2.0, 2.0, 0.0));
    const UpdateStats s = filter->update(set);
    EXPECT_EQ(s.features_in, good + 4);
    EXPECT_EQ(s.features_rejected, 4);
    EXPECT_EQ(static_cast<int>(filter->landmarks().size()), good);
    for (const auto& l : filter->landmarks()) EXPECT_TRUE(l.mean.allFinite());
    MotionInput motion;
    motion.delta << nan, 0.0, 0.0;
    filter->predict(motion);  // a non-finite increment is ignored
    filter->update(set);
    EXPECT_TRUE(filter->estimate().mean.allFinite());
    EXPECT_TRUE(filter->estimate().covariance.allFinite());
    EXPECT_EQ(static_cast<int>(filter->landmarks().size()), good);
  }
}

TEST(LineSlam, LinesCarryTheirObservedExtent) {
  for (const std::string variant : {"multifilter_smc", "ekf_slam"}) {
    SCOPED_TRACE(variant);
    auto filter = createFilter(optionsFor(variant));
    Rng rng(9);
    filter->reset(Pose2(2.0, 2.0, 0.0));
    filter->update(observeWalls(Pose2(2.0, 2.0, 0.0), rng, 0.001, 0.0005));
    const auto landmarks = filter->landmarks();
    ASSERT_EQ(landmarks.size(), kWalls.size());
    for (size_t i = 0; i < kWalls.size(); ++i) {
      const auto& l = landmarks[i];
      const double direct = (l.start - kWalls[i].first).norm() + (l.end - kWalls[i].second).norm();
      const double swapped = (l.start - kWalls[i].second).norm() + (l.end - kWalls[i].first).norm();
      EXPECT_LT(std::min(direct, swapped), 0.1) << "wall " << i;
    }
    // The map round-trips through loadMap.
    auto other = createFilter(optionsFor(variant));
    other->reset(Pose2(2.0, 2.0, 0.0));
    ASSERT_TRUE(other->loadMap(landmarks));
    ASSERT_EQ(other->landmarks().size(), landmarks.size());
    for (size_t i = 0; i < landmarks.size(); ++i) {
      EXPECT_EQ(other->landmarks()[i].id, landmarks[i].id);
      EXPECT_LT(featureDissimilarity(landmarks[i].type, other->landmarks()[i].mean,
                                     landmarks[i].mean, WadAssociationOptions(),
                                     Eigen::Vector2d::Zero()),
                0.05);
    }
  }
}

// One wall, two mapped lines 0.4 m apart (both within h_similar_feature of it): only the line the
// feature is most similar to is updated. The multi-filter used to update every landmark whose
// most similar feature it was, so the phantom line at y = 2.4 was pulled onto the wall.
TEST(LineSlam, AFeatureUpdatesOnlyTheLandmarkItIsMostSimilarTo) {
  for (const std::string variant : {"multifilter_smc", "ekf_slam"}) {
    SCOPED_TRACE(variant);
    auto filter = createFilter(optionsFor(variant));
    filter->reset(Pose2(2.0, 0.0, 0.0));
    std::vector<LandmarkEstimate> map(2);
    for (int k = 0; k < 2; ++k) {
      map[k].id = k;
      map[k].type = LandmarkType::kLine;
      map[k].mean = Eigen::Vector2d(2.0 + 0.4 * k, M_PI / 2);
      map[k].covariance = Eigen::Vector2d(0.01, 1e-4).asDiagonal();
      map[k].start = Eigen::Vector2d(0.0, map[k].mean.x());
      map[k].end = Eigen::Vector2d(4.0, map[k].mean.x());
      map[k].observations = 10;
    }
    ASSERT_TRUE(filter->loadMap(map));
    Rng rng(4);
    for (int step = 0; step < 30; ++step) {
      FeatureSet set;
      LineFeature wall;  // y = 2 seen from (2, 0, 0)
      wall.rho = 2.0 + sampleGaussian(rng, 0.005);
      wall.theta = M_PI / 2 + sampleGaussian(rng, 0.002);
      wall.covariance = Eigen::Vector2d(0.005 * 0.005, 0.002 * 0.002).asDiagonal();
      wall.start = Eigen::Vector2d(-1.0, wall.rho);
      wall.end = Eigen::Vector2d(1.0, wall.rho);
      set.lines.push_back(wall);
      filter->predict(MotionInput());
      const UpdateStats stats = filter->update(set);
      EXPECT_EQ(stats.associated, 1) << "step " << step;
    }
    const auto landmarks = filter->landmarks();
    ASSERT_GE(landmarks.size(), 2u);
    EXPECT_NEAR(landmarks[0].mean.x(), 2.0, 0.05);
    EXPECT_GT(landmarks[1].mean.x(), 2.35) << "the phantom line moved onto the wall";
  }
}

/// A line through (almost) the map origin whose estimate crosses it: its normal turns over
/// (rho < 0 made positive), and positions along the line change sign, so the extent must turn
/// too. Before session 12 the EKF's and the multi-filter's did not: the wall was mirrored
/// through the origin (x in [-3, 1] instead of [-1, 3]).
TEST(LineSlam, AnExtentTurnsWithItsLinesNormal) {
  for (const std::string variant : {"ekf_slam", "multifilter_smc"}) {
    SCOPED_TRACE(variant);
    FilterOptions o = optionsFor(variant);
    o.motion.alpha1 = o.motion.alpha2 = o.motion.alpha3 = o.motion.alpha4 = 0.0;
    o.motion.min_sigma_xy_m = 0.0;
    o.motion.min_sigma_theta_rad = 0.0;
    auto filter = createFilter(o);
    const Pose2 robot(1.0, -2.0, 0.0);
    filter->reset(robot);
    // The wall y = wall_y, x in [-1, 3], seen from below: rho = wall_y + 2, theta = pi / 2.
    auto wallAt = [&](double wall_y, double sigma_rho) {
      FeatureSet set;
      LineFeature f;
      f.rho = wall_y - robot.y();
      f.theta = M_PI / 2;
      f.covariance = Eigen::Vector2d(sigma_rho * sigma_rho, 1e-6).asDiagonal();
      f.start = Eigen::Vector2d(-1.0 - robot.x(), f.rho);
      f.end = Eigen::Vector2d(3.0 - robot.x(), f.rho);
      set.lines.push_back(f);
      return set;
    };
    filter->update(wallAt(0.02, 0.1));  // a loose first sighting: rho 0.02 in the map
    MotionInput still;
    still.dt = 1.0;
    for (int k = 0; k < 5; ++k) {
      filter->predict(still);
      filter->update(wallAt(-0.03, 0.002));  // precise ones across the origin
    }
    const auto landmarks = filter->landmarks();
    ASSERT_EQ(landmarks.size(), 1u);
    const auto& wall = landmarks[0];
    // The estimate crossed the origin: rho ~ 0.03 with the normal turned to -pi / 2.
    EXPECT_NEAR(wall.mean.x(), 0.03, 0.02);
    EXPECT_NEAR(std::fabs(wrapAngle(wall.mean.y() + M_PI / 2)), 0.0, 0.05);
    const double x_lo = std::min(wall.start.x(), wall.end.x());
    const double x_hi = std::max(wall.start.x(), wall.end.x());
    EXPECT_NEAR(x_lo, -1.0, 0.1);
    EXPECT_NEAR(x_hi, 3.0, 0.1);
    EXPECT_NEAR(wall.start.y(), -0.03, 0.03);
    EXPECT_NEAR(wall.end.y(), -0.03, 0.03);
  }
}

TEST(LineSlam, EkfIsConsistentAndBeatsOdometryOnASyntheticLoop) {
  FilterOptions o = optionsFor("ekf_slam");
  o.motion.alpha1 = 0.01;
  o.motion.alpha3 = 0.01;
  o.motion.alpha2 = 0.01;
  o.motion.min_sigma_xy_m = 0.03;
  o.motion.min_sigma_theta_rad = 0.03;
  for (unsigned seed : {1u, 2u, 3u}) {
    EkfSlam ekf(o);
    const LoopResult r = runSyntheticLoop(&ekf, seed);
    EXPECT_LT(r.filter_error_m, 0.1) << "seed " << seed;
    EXPECT_LT(r.filter_error_m, 0.3 * r.odometry_error_m) << "seed " << seed;
    // The pose NEES (3 dof) averages near 3 when the covariance is honest; allow a factor 3.
    EXPECT_LT(r.mean_nees, 9.0) << "seed " << seed;
    EXPECT_EQ(ekf.landmarks().size(), kWalls.size());
    EXPECT_EQ(ekf.covariance().rows(), 3 + 2 * static_cast<int>(kWalls.size()));
  }
}

TEST(LineSlam, MultiFilterBeatsOdometryOnASyntheticLoop) {
  FilterOptions o = optionsFor("multifilter_smc");
  o.motion.alpha1 = 0.01;
  o.motion.alpha3 = 0.01;
  o.motion.min_sigma_xy_m = 0.03;
  o.motion.min_sigma_theta_rad = 0.03;
  for (unsigned seed : {1u, 2u}) {
    o.seed = seed;
    MultiFilterSmc smc(o);
    const LoopResult r = runSyntheticLoop(&smc, seed);
    EXPECT_LT(r.filter_error_m, 0.15) << "seed " << seed;
    EXPECT_LT(r.filter_error_m, 0.3 * r.odometry_error_m) << "seed " << seed;
    EXPECT_EQ(smc.landmarks().size(), kWalls.size());
  }
}

struct SimulatedRun {
  double filter_final_m = 0.0;
  double odometry_final_m = 0.0;
  long frames = 0;
};

/// Drives worlds/test_small.yaml once through the laser pipeline of the config and returns
/// the final position error of the filter and of the raw odometry.
SimulatedRun runTestSmall(const std::string& config, std::uint64_t seed,
                          const std::vector<std::string>& overrides) {
  std::vector<std::string> sets = overrides;
  sets.push_back("seed=" + std::to_string(seed));
  const io::SlamConfig c = io::loadSlamConfig(kRoot + "/config/" + config, sets);
  SlamPipeline pipeline(c.pipeline());
  sim::SimulatorOptions options;
  options.seed = seed;
  sim::Simulator simulator(io::loadWorld(kRoot + "/worlds/test_small.yaml"), options);
  SimulatedRun run;
  bool first = true;
  Pose2 first_true = Pose2::Zero(), first_odom = Pose2::Zero();
  Pose2 last_true = Pose2::Zero(), last_odom = Pose2::Zero();
  sim::SimEvent event;
  while (simulator.next(&event)) {
    if (event.type != sim::SimEventType::kLaser) continue;
    RangeScan scan = *event.scan;
    scan.stamp = event.stamp + 1.0;
    const FrameResult frame = pipeline.processScan(scan, event.odom_pose);
    if (frame != FrameResult::kUpdated && frame != FrameResult::kFirstFrame) continue;
    if (first) {
      first_true = event.true_pose;
      first_odom = event.odom_pose;
    }
    first = false;
    last_true = event.true_pose;
    last_odom = event.odom_pose;
    ++run.frames;
  }
  const auto& trajectory = pipeline.session().trajectory();
  if (trajectory.empty()) return run;
  const Pose2 expected = compose(compose(trajectory.front().pose, inverse(first_true)), last_true);
  run.filter_final_m = (trajectory.back().pose.head<2>() - expected.head<2>()).norm();
  const Pose2 odom_in_map =
      compose(compose(trajectory.front().pose, inverse(first_odom)), last_odom);
  run.odometry_final_m = (odom_in_map.head<2>() - expected.head<2>()).norm();
  return run;
}

TEST(LineSlam, BothVariantsBeatOdometryOnTestSmall) {
  for (const std::string config : {"laser_multifilter.yaml", "laser_ekf.yaml"}) {
    for (std::uint64_t seed : {1u, 7u}) {
      // The EKF with the WAD association alone mismatches on this run (it ends worse than
      // odometry, see docs/results.md); with the innovation gate it is a working EKF-SLAM.
      const SimulatedRun r =
          runTestSmall(config, seed, {"particles=500", "ekf.innovation_gate_chi2=13.8"});
      EXPECT_GT(r.frames, 100) << config << " seed " << seed;
      EXPECT_LT(r.filter_final_m, 0.3) << config << " seed " << seed;
      EXPECT_LT(r.filter_final_m, r.odometry_final_m) << config << " seed " << seed;
    }
  }
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

namespace rbpf_slam {
namespace core {
namespace {

// compare_at "robot" in both line filters: a wall beside a robot 100 m from the origin, seen
// again 0.02 rad turned (sensor noise), is 2 m away in map-frame rho (a new landmark by the
// paper's WAD) but 0.03 in WAD measured from the robot (the same landmark).
TEST(LineSlam, ComparedAtTheRobotAWallSeenFarFromTheOriginStaysOneLandmark) {
  for (const std::string variant : {"ekf_slam", "multifilter_smc"}) {
    for (const std::string compare_at : {"origin", "robot"}) {
      FilterOptions options = optionsFor(variant);
      options.line_association.compare_at = compare_at;
      std::unique_ptr<SlamFilter> filter = createFilter(options);
      filter->reset(Pose2(0.0, 100.0, 0.0));
      for (double theta : {0.0, 0.02}) {
        LineFeature wall;
        wall.rho = 1.0;
        wall.theta = theta;
        wall.covariance = Eigen::Vector2d(1e-4, 1e-4).asDiagonal();
        const Eigen::Vector2d normal(std::cos(theta), std::sin(theta));
        const Eigen::Vector2d along(-normal.y(), normal.x());
        wall.start = normal - 2.0 * along;  // the extent seen, on the line turned by theta
        wall.end = normal + 2.0 * along;
        FeatureSet seen;
        seen.stamp = 1.0 + theta;
        seen.lines = {wall};
        filter->update(seen);
      }
      EXPECT_EQ(filter->landmarks().size(), compare_at == "robot" ? 1u : 2u)
          << variant << ", compare_at " << compare_at;
    }
  }
}

// The multi-filter draws a new line filter's spread as seen from the robot with compare_at
// "robot": a wall first seen from (99, 50), 50 m along it from the origin's foot point, has a
// map-frame rho variance of about (50 x 0.03)^2 there (the spread turns it about the robot),
// against the init_sigma_m^2 of the paper's draw about the origin. A saved map loads back with
// the same mean and covariance (drawn from the whole covariance, correlations kept).
TEST(LineSlam, TheMultiFilterDrawsANewLineAtTheRobotAndLoadsItBack) {
  for (const std::string compare_at : {"origin", "robot"}) {
    FilterOptions options = optionsFor("multifilter_smc");
    options.line_association.compare_at = compare_at;
    std::unique_ptr<SlamFilter> filter = createFilter(options);
    filter->reset(Pose2(99.0, 50.0, 0.0));
    LineFeature wall;  // x = 100 in the map
    wall.rho = 1.0;
    wall.theta = 0.0;
    wall.covariance = Eigen::Vector2d(1e-4, 1e-4).asDiagonal();
    wall.start = Eigen::Vector2d(1.0, -2.0);
    wall.end = Eigen::Vector2d(1.0, 2.0);
    FeatureSet seen;
    seen.stamp = 1.0;
    seen.lines = {wall};
    filter->update(seen);
    const std::vector<LandmarkEstimate> map = filter->landmarks();
    ASSERT_EQ(map.size(), 1u) << compare_at;
    const double init = options.multifilter.init_sigma_m, turn = options.multifilter.init_sigma_rad;
    if (compare_at == "robot") {
      EXPECT_NEAR(map[0].covariance(0, 0), init * init + std::pow(50.0 * turn, 2), 0.6);
      EXPECT_GT(map[0].covariance(0, 1), 0.5 * 50.0 * turn * turn);  // rho and theta tied
    } else {
      EXPECT_LT(map[0].covariance(0, 0), 2.0 * init * init);
    }
    std::unique_ptr<SlamFilter> other = createFilter(options);
    other->reset(Pose2(99.0, 50.0, 0.0));
    ASSERT_TRUE(other->loadMap(map));
    const LandmarkEstimate loaded = other->landmarks().at(0);
    EXPECT_TRUE(loaded.mean.isApprox(map[0].mean, 1e-6)) << loaded.mean.transpose();
    EXPECT_TRUE(loaded.covariance.isApprox(map[0].covariance, 0.3)) << compare_at << "\n"
                                                                    << loaded.covariance;
  }
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

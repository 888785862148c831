// Sonar-only SLAM through SlamPipeline::processSonar with the shipped config/sonar_fastslam2.yaml
// on simulated runs of worlds/test_small.yaml (8-sonar Pioneer front ring).

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "rbpf_slam/core/sim/simulator.h"
#include "rbpf_slam/core/slam/slam_pipeline.h"
#include "rbpf_slam/io/evaluation.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/io/world_yaml.h"

namespace rbpf_slam {
namespace {

struct SonarRun {
  double rms_error_m = 0.0;           // ATE of the estimate (rigidly aligned to the truth)
  double odometry_rms_error_m = 0.0;  // ATE of odometry at the same frames
  long updates = 0;
  int line_landmarks = 0;
};

SonarRun runSonar(std::uint64_t seed, const std::vector<std::string>& overrides) {
  const std::string root = RBPF_SOURCE_DIR;
  std::vector<std::string> all = overrides;
  all.push_back("seed=" + std::to_string(seed));
  const io::SlamConfig config = io::loadSlamConfig(root + "/config/sonar_fastslam2.yaml", all);
  core::SlamPipeline pipeline(config.pipeline());
  core::sim::SimulatorOptions options;
  options.seed = seed;
  core::sim::Simulator simulator(io::loadWorld(root + "/worlds/test_small.yaml"), options);

  std::vector<io::StampedPose> truth, odometry;
  core::sim::SimEvent event;
  while (simulator.next(&event)) {
    if (event.type != core::sim::SimEventType::kSonar) continue;
    // One reading at a time, as sensor_msgs/Range messages arrive.
    bool updated = false;
    for (const auto& t : event.cones) {
      const core::FrameResult frame =
          pipeline.processSonar({t.reading}, event.odom_pose, event.stamp + 1.0);
      updated |= frame == core::FrameResult::kUpdated || frame == core::FrameResult::kFirstFrame;
    }
    if (!updated) continue;
    truth.push_back({event.stamp + 1.0, event.true_pose});
    odometry.push_back({event.stamp + 1.0, event.odom_pose});
  }
  SonarRun run;
  const auto& trajectory = pipeline.session().trajectory();
  EXPECT_EQ(trajectory.size(), truth.size());
  if (trajectory.empty() || trajectory.size() != truth.size()) return run;
  std::vector<io::StampedPose> estimate;
  for (const auto& p : trajectory) estimate.push_back({p.stamp, p.pose});
  run.rms_error_m = io::evaluateTrajectory(estimate, truth, io::EvaluationOptions()).ate_rmse_m;
  run.odometry_rms_error_m =
      io::evaluateTrajectory(odometry, truth, io::EvaluationOptions()).ate_rmse_m;
  run.updates = static_cast<long>(truth.size());
  for (const auto& l : pipeline.session().filter().landmarks()) {
    run.line_landmarks += l.type == core::LandmarkType::kLine ? 1 : 0;
  }
  return run;
}

TEST(SonarSlam, ShippedConfigMapsTheWallsAndStaysNearTheTruth) {
  for (std::uint64_t seed : {1u, 2u}) {
    const SonarRun r = runSonar(seed, {});
    SCOPED_TRACE(::testing::Message() << "seed " << seed << ": ATE " << r.rms_error_m
                                      << " m, odometry " << r.odometry_rms_error_m << " m");
    EXPECT_GT(r.updates, 100);
    EXPECT_GE(r.line_landmarks, 5);  // four outer walls, the free wall, the box
    EXPECT_LT(r.rms_error_m, 0.3);   // issue 4's bound on the simulated sonar worlds
    EXPECT_LT(r.rms_error_m, 1.2 * r.odometry_rms_error_m);
  }
}

TEST(SonarSlam, WithPointLandmarksTheErrorStaysBounded) {
  for (std::uint64_t seed : {1u, 2u}) {
    const SonarRun r = runSonar(seed, {"use_points=true", "sonar_features.max_point_sigma_m=0.03"});
    SCOPED_TRACE(::testing::Message() << "seed " << seed << ": ATE " << r.rms_error_m
                                      << " m, odometry " << r.odometry_rms_error_m << " m");
    EXPECT_LT(r.rms_error_m, 0.3);
  }
}

TEST(SonarSlam, BadReadingsAreSkippedNotFatal) {
  const io::SlamConfig config =
      io::loadSlamConfig(std::string(RBPF_SOURCE_DIR) + "/config/sonar_fastslam2.yaml");
  core::SlamPipeline pipeline(config.pipeline());
  core::ConeReading bad;
  bad.range = std::numeric_limits<double>::quiet_NaN();
  bad.field_of_view = 0.5;
  EXPECT_EQ(pipeline.processSonar({bad}, core::Pose2::Zero(), 1.0), core::FrameResult::kFirstFrame);
  EXPECT_EQ(pipeline.processSonar({}, core::Pose2(0.5, 0, 0), 2.0), core::FrameResult::kUpdated);
  EXPECT_EQ(pipeline.sonarExtractor().stats().invalid, 1);
  EXPECT_EQ(pipeline.processSonar({bad}, core::Pose2(0.6, 0, 0), 3.0),
            core::FrameResult::kBuffered);
  pipeline.reset();
  EXPECT_EQ(pipeline.sonarExtractor().stats().readings, 0);
}

/// config/sonar_fastslam2.yaml as shipped.
io::SlamConfig shippedSonarConfig() {
  return io::loadSlamConfig(std::string(RBPF_SOURCE_DIR) + "/config/sonar_fastslam2.yaml");
}

/// An echo at range from a 0.5 rad cone of 5 m reach, mounted at the base.
core::ConeReading echoAt(double range) {
  core::ConeReading reading;
  reading.range = range;
  reading.max_range = 5.0;
  reading.field_of_view = 0.5;
  return reading;
}

// A ring arrives as one message per transducer with one stamp: the readings after the one that
// anchored (or updated) the map join the window; none is a rejected frame.
TEST(SonarSlam, TheRestOfARingAtTheSameStampIsNotRejected) {
  const io::SlamConfig config = shippedSonarConfig();
  core::SlamPipeline pipeline(config.pipeline());
  core::ConeReading reading = echoAt(2.0);
  EXPECT_EQ(pipeline.processSonar({reading}, core::Pose2::Zero(), 1.0),
            core::FrameResult::kFirstFrame);
  for (int i = 1; i < 8; ++i) {
    reading.sensor_pose = core::Pose2(0.0, 0.0, 0.2 * i);
    EXPECT_EQ(pipeline.processSonar({reading}, core::Pose2::Zero(), 1.0),
              core::FrameResult::kBuffered)
        << "reading " << i;
  }
  EXPECT_EQ(pipeline.sonarExtractor().stats().readings, 8);
  // The next ring, after the robot moved, updates.
  EXPECT_EQ(pipeline.processSonar({reading}, core::Pose2(0.5, 0, 0), 2.0),
            core::FrameResult::kUpdated);
}

// One zero-stamped or stale reading (a driver's hiccup) used to clear the echo window before the
// session rejected its frame: the window must survive it. Several readings in a row far back
// are a restarted clock: the map starts over at the new clock and the window goes.
TEST(SonarSlam, AStaleReadingKeepsTheWindowARestartedClockClearsIt) {
  const io::SlamConfig config = shippedSonarConfig();
  core::SlamPipeline pipeline(config.pipeline());
  core::ConeReading reading = echoAt(2.0);
  ASSERT_EQ(pipeline.processSonar({reading}, core::Pose2::Zero(), 100.0),
            core::FrameResult::kFirstFrame);
  for (int i = 1; i < 8; ++i) {
    reading.sensor_pose = core::Pose2(0.0, 0.0, 0.2 * i);
    pipeline.processSonar({reading}, core::Pose2(0.01 * i, 0, 0), 100.0 + 0.1 * i);
  }
  const size_t window = pipeline.sonarExtractor().echoes().size();
  ASSERT_GE(window, 2u);
  EXPECT_EQ(pipeline.processSonar({reading}, core::Pose2(0.08, 0, 0), 0.0),
            core::FrameResult::kRejectedStamp);
  EXPECT_EQ(pipeline.processSonar({reading}, core::Pose2(0.08, 0, 0), 50.0),
            core::FrameResult::kRejectedStamp);
  EXPECT_EQ(pipeline.sonarExtractor().echoes().size(), window);
  EXPECT_EQ(pipeline.sonarExtractor().stats().clock_jumps, 0);
  // A reading a little out of order (transducers stamped apart) still joins the window.
  pipeline.processSonar({reading}, core::Pose2(0.08, 0, 0), 100.65);
  EXPECT_EQ(pipeline.sonarExtractor().echoes().size(), window + 1);
  // Late rings, each a message per transducer stamped a few milliseconds apart, with fresh
  // readings between them: none may start a new map (counting messages or stamps would).
  const long resets = pipeline.session().resets();
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 8; ++i) {
      EXPECT_EQ(pipeline.processSonar({reading}, core::Pose2::Zero(), 1.0 + 0.3 * k + 0.01 * i),
                core::FrameResult::kRejectedStamp)
          << "late ring " << k << " reading " << i;
    }
    pipeline.processSonar({reading}, core::Pose2(0.08, 0, 0), 100.7 + 0.01 * k);
  }
  EXPECT_EQ(pipeline.session().resets(), resets);
  EXPECT_GE(pipeline.sonarExtractor().echoes().size(), window + 1);
  // A bag played again: rings far back one after another, for longer than
  // reset_on_time_jump_back (1 s), start a new map.
  core::FrameResult last = core::FrameResult::kRejectedStamp;
  int rings = 0;
  for (; rings < 20 && last != core::FrameResult::kReset; ++rings) {
    for (int i = 0; i < 4 && last != core::FrameResult::kReset; ++i) {
      last = pipeline.processSonar({reading}, core::Pose2::Zero(), 1.0 + 0.25 * rings + 0.01 * i);
    }
  }
  EXPECT_EQ(last, core::FrameResult::kReset);
  EXPECT_EQ(rings, 5);  // the ring at 2.0 s: 1 s after the first stale one
  EXPECT_EQ(pipeline.session().resets(), resets + 1);
  EXPECT_EQ(pipeline.sonarExtractor().echoes().size(), 1u);  // the new clock's reading only
  EXPECT_EQ(pipeline.processSonar({reading}, core::Pose2(0.5, 0, 0), 2.5),
            core::FrameResult::kUpdated);
}

}  // namespace
}  // namespace rbpf_slam

// Tests of the per-frame SLAM path (extraction, scan matching, filter) on simulated runs of
// worlds/test_small.yaml with the shipped laser config.

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "rbpf_slam/core/sim/simulator.h"
#include "rbpf_slam/core/slam/slam_pipeline.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/io/world_yaml.h"

namespace rbpf_slam {
namespace {

struct RunResult {
  double final_position_error_m = 0.0;
  double final_yaw_error_rad = 0.0;
  long frames = 0;
};

/// Drives test_small once and feeds scans (and, if asked, the range-bearing features of the
/// same run) to a pipeline built from the laser config; compares the final pose with the
/// ground truth after aligning the first frame.
RunResult runTestSmall(std::uint64_t seed, bool with_features) {
  const std::string root = RBPF_SOURCE_DIR;
  const io::SlamConfig config = io::loadSlamConfig(root + "/config/laser_fastslam2.yaml",
                                                   {"seed=" + std::to_string(seed)});
  core::SlamPipeline pipeline(config.pipeline());
  core::sim::SimulatorOptions options;
  options.seed = seed;
  core::sim::Simulator simulator(io::loadWorld(root + "/worlds/test_small.yaml"), options);

  RunResult result;
  bool have_first = false;
  core::Pose2 first_true = core::Pose2::Zero(), last_true = core::Pose2::Zero();
  core::sim::SimEvent event;
  while (simulator.next(&event)) {
    core::FrameResult frame = core::FrameResult::kSkippedNoMotion;
    if (event.type == core::sim::SimEventType::kLaser) {
      core::RangeScan scan = *event.scan;
      scan.stamp = event.stamp + 1.0;  // the session rejects stamp 0
      frame = pipeline.processScan(scan, event.odom_pose);
    } else if (with_features && event.type == core::sim::SimEventType::kRangeBearing) {
      core::FeatureSet features = event.features;
      features.stamp = event.stamp + 1.0;
      frame = pipeline.processFeatures(features, event.odom_pose);
    } else {
      continue;
    }
    if (frame != core::FrameResult::kUpdated && frame != core::FrameResult::kFirstFrame) continue;
    ++result.frames;
    if (!have_first) first_true = event.true_pose;
    have_first = true;
    last_true = event.true_pose;
  }
  const auto& trajectory = pipeline.session().trajectory();
  EXPECT_FALSE(trajectory.empty());
  if (trajectory.empty()) return result;
  const core::Pose2 true_to_map =
      core::compose(trajectory.front().pose, core::inverse(first_true));
  const core::Pose2 expected = core::compose(true_to_map, last_true);
  const core::Pose2& estimate = trajectory.back().pose;
  result.final_position_error_m = (estimate.head<2>() - expected.head<2>()).norm();
  result.final_yaw_error_rad = std::fabs(core::wrapAngle(estimate.z() - expected.z()));
  return result;
}

/// Two seeds of test_small end within 0.3 m / 0.1 rad of the truth after min_frames updates.
void expectEndsNearTheTruth(bool with_features, long min_frames) {
  for (std::uint64_t seed : {1u, 7u}) {
    const RunResult r = runTestSmall(seed, with_features);
    EXPECT_GT(r.frames, min_frames) << "seed " << seed;
    EXPECT_LT(r.final_position_error_m, 0.3) << "seed " << seed;
    EXPECT_LT(r.final_yaw_error_rad, 0.1) << "seed " << seed;
  }
}

TEST(SlamPipeline, LaserOnlyRunEndsNearTheTruth) { expectEndsNearTheTruth(false, 100); }

// Point features processed between two scans must not make the scan match's increment
// (reference scan -> this scan) count the motion up to the feature frame twice.
TEST(SlamPipeline, ScanMatchingStaysCorrectWithFeatureFramesInBetween) {
  expectEndsNearTheTruth(true, 200);
}

}  // namespace
}  // namespace rbpf_slam

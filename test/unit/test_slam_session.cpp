// SlamSession's handling of time: stale frames are rejected, a clock that restarts (a looping
// bag) starts a new map only once several frames in a row confirm it.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/slam/slam_session.h"

namespace rbpf_slam {
namespace {

core::SlamSession makeSession(int frames_back) {
  core::FilterOptions filter;
  filter.particles = 10;
  core::SessionOptions options;
  options.reset_on_time_jump_back_s = 1.0;
  options.reset_after_frames_back = frames_back;
  return core::SlamSession(core::createFilter(filter), options);
}

core::FrameResult frame(core::SlamSession* session, double stamp) {
  return session->process(stamp, core::Pose2(0.1 * stamp, 0.0, 0.0), core::FeatureSet());
}

TEST(SlamSession, OneStaleFrameIsRejectedAndTheMapKept) {
  core::SlamSession session = makeSession(3);
  for (int i = 1; i <= 10; ++i) frame(&session, i);
  ASSERT_EQ(session.trajectory().size(), 10u);
  EXPECT_EQ(frame(&session, 5.0), core::FrameResult::kRejectedStamp);  // 5 s late
  EXPECT_EQ(frame(&session, 10.0), core::FrameResult::kRejectedStamp);  // duplicate
  EXPECT_EQ(frame(&session, 0.0), core::FrameResult::kRejectedStamp);   // zero stamp
  EXPECT_EQ(frame(&session, 11.0), core::FrameResult::kUpdated);
  EXPECT_EQ(session.resets(), 0);
  EXPECT_EQ(session.trajectory().size(), 11u);
  // Two late frames, then a good one: the run of late frames is broken, no reset.
  frame(&session, 2.0);
  frame(&session, 3.0);
  EXPECT_EQ(frame(&session, 12.0), core::FrameResult::kUpdated);
  frame(&session, 2.0);
  EXPECT_EQ(session.resets(), 0);
}

TEST(SlamSession, ARestartedClockStartsANewMapAfterEnoughFrames) {
  core::SlamSession session = makeSession(3);
  for (int i = 1; i <= 10; ++i) frame(&session, i);
  EXPECT_EQ(frame(&session, 1.0), core::FrameResult::kRejectedStamp);
  EXPECT_EQ(frame(&session, 1.5), core::FrameResult::kRejectedStamp);
  EXPECT_EQ(frame(&session, 2.0), core::FrameResult::kFirstFrame);  // third in a row: new run
  EXPECT_EQ(session.resets(), 1);
  ASSERT_EQ(session.trajectory().size(), 1u);
  EXPECT_DOUBLE_EQ(session.trajectory().front().stamp, 2.0);
  EXPECT_EQ(frame(&session, 3.0), core::FrameResult::kUpdated);
}

TEST(SlamSession, OneFrameBackResetsWhenConfiguredSo) {
  core::SlamSession session = makeSession(1);
  for (int i = 1; i <= 5; ++i) frame(&session, i);
  EXPECT_EQ(frame(&session, 1.0), core::FrameResult::kFirstFrame);
  EXPECT_EQ(session.resets(), 1);
}

TEST(SlamSession, BadOptionsAreNamed) {
  core::SessionOptions options;
  options.reset_after_frames_back = 0;
  try {
    core::validate(options);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("reset_after_frames_back"), std::string::npos);
  }
}

}  // namespace
}  // namespace rbpf_slam

namespace rbpf_slam {
namespace {

/// Spread (RMS distance from the mean) of the particles after one 0.5 m step taken `gap_s`
/// after the first frame.
double spreadAfterGap(const std::string& action, double gap_s, long* gaps, long* resets) {
  core::FilterOptions filter;
  filter.particles = 200;
  filter.seed = 3;
  core::SessionOptions options;
  options.max_time_gap_s = 30.0;
  options.gap_action = action;
  core::SlamSession session(core::createFilter(filter), options);
  session.process(1.0, core::Pose2(0.0, 0.0, 0.0), core::FeatureSet());
  session.process(1.0 + gap_s, core::Pose2(0.5, 0.0, 0.0), core::FeatureSet());
  *gaps = session.gaps();
  *resets = session.resets();
  const auto particles = session.filter().particles();
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : particles) mean += p.pose.head<2>() / particles.size();
  double sum = 0.0;
  for (const auto& p : particles) sum += (p.pose.head<2>() - mean).squaredNorm();
  return std::sqrt(sum / particles.size());
}

TEST(SlamSession, ATimeGapInflatesTheMotionNoiseOrResets) {
  long gaps = 0, resets = 0;
  const double normal = spreadAfterGap("inflate", 1.0, &gaps, &resets);
  EXPECT_EQ(gaps, 0);
  const double inflated = spreadAfterGap("inflate", 60.0, &gaps, &resets);
  EXPECT_EQ(gaps, 1);
  EXPECT_EQ(resets, 0);
  EXPECT_GT(inflated, 2.0 * normal) << "normal " << normal << ", after the gap " << inflated;
  spreadAfterGap("reset", 60.0, &gaps, &resets);
  EXPECT_EQ(gaps, 1);
  EXPECT_EQ(resets, 1);
}

TEST(SlamSession, GapOptionsAreValidated) {
  core::SessionOptions options;
  options.gap_action = "explode";
  EXPECT_THROW(core::validate(options), std::invalid_argument);
  options.gap_action = "reset";
  options.gap_noise_inflation = 0.5;
  EXPECT_THROW(core::validate(options), std::invalid_argument);
}

}  // namespace
}  // namespace rbpf_slam

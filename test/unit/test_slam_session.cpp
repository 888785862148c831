// SlamSession's handling of time: stale frames are rejected, a clock that restarts (a looping
// bag) starts a new map only once several frames in a row confirm it.

#include <gtest/gtest.h>

#include <memory>

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

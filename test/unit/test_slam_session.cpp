// SlamSession's handling of time: stale frames are rejected, a clock that restarts (a looping
// bag) starts a new map only once several frames in a row confirm it.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/slam/slam_session.h"

namespace rbpf_slam {
namespace {

/// A session over FastSLAM 2.0 with 10 particles.
core::SlamSession sessionWith(const core::SessionOptions& options) {
  core::FilterOptions filter;
  filter.particles = 10;
  return core::SlamSession(core::createFilter(filter), options);
}

core::SlamSession makeSession(int frames_back) {
  core::SessionOptions options;
  options.reset_on_time_jump_back_s = 1.0;
  options.reset_after_frames_back = frames_back;
  return sessionWith(options);
}

core::FrameResult frame(core::SlamSession* session, double stamp) {
  return session->process(stamp, core::Pose2(0.1 * stamp, 0.0, 0.0), core::FeatureSet());
}

TEST(SlamSession, OneStaleFrameIsRejectedAndTheMapKept) {
  core::SlamSession session = makeSession(3);
  for (int i = 1; i <= 10; ++i) frame(&session, i);
  ASSERT_EQ(session.trajectory().size(), 10u);
  EXPECT_EQ(frame(&session, 5.0), core::FrameResult::kRejectedStamp);  // 5 s late
  EXPECT_EQ(frame(&session, 10.0), core::FrameResult::kSkippedSameStamp);  // the same instant
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

// The reported path is the best particle's where the filter keeps one per update (FastSLAM),
// else the pose estimated at each update; estimatedPath says which it returned.
TEST(SlamSession, EstimatedPathSaysWhereItCameFrom) {
  core::SlamSession fastslam = makeSession(3);
  bool best = true;
  EXPECT_TRUE(fastslam.estimatedPath(&best).empty());
  EXPECT_FALSE(best);  // nothing yet: no best path to report
  for (int i = 1; i <= 5; ++i) frame(&fastslam, i);
  const std::vector<core::Pose2> path = fastslam.estimatedPath(&best);
  EXPECT_TRUE(best);
  ASSERT_EQ(path.size(), 5u);
  const std::vector<core::Pose2> kept = fastslam.filter().bestPath();
  for (size_t i = 0; i < path.size(); ++i) EXPECT_TRUE(path[i].isApprox(kept[i]));
  // The node's ~trajectory: the same poses at the updates' stamps.
  const std::vector<core::TrajectoryPoint> stamped = fastslam.estimatedTrajectory(&best);
  EXPECT_TRUE(best);
  ASSERT_EQ(stamped.size(), 5u);
  for (size_t i = 0; i < stamped.size(); ++i) {
    EXPECT_EQ(stamped[i].stamp, fastslam.trajectory()[i].stamp);
    EXPECT_TRUE(stamped[i].pose.isApprox(kept[i]));
  }

  core::FilterOptions ekf;
  ekf.variant = "ekf_slam";
  core::SlamSession other(core::createFilter(ekf), core::SessionOptions());
  for (int i = 1; i <= 5; ++i) frame(&other, i);
  ASSERT_TRUE(other.filter().bestPath().empty());
  const std::vector<core::Pose2> online = other.estimatedPath(&best);
  EXPECT_FALSE(best);
  ASSERT_EQ(online.size(), 5u);
  for (size_t i = 0; i < online.size(); ++i) {
    EXPECT_TRUE(online[i].isApprox(other.trajectory()[i].pose));
  }
  const std::vector<core::TrajectoryPoint> stamped_online = other.estimatedTrajectory(&best);
  EXPECT_FALSE(best);
  ASSERT_EQ(stamped_online.size(), 5u);
  for (size_t i = 0; i < stamped_online.size(); ++i) {
    EXPECT_EQ(stamped_online[i].stamp, other.trajectory()[i].stamp);
    EXPECT_TRUE(stamped_online[i].pose.isApprox(other.trajectory()[i].pose));
  }
}

// A frame at the last frame's stamp (another input of the same instant, or a repeat) is
// skipped, not used twice, not an error, and does not break or extend a run of late frames.
TEST(SlamSession, AFrameAtTheLastStampIsSkipped) {
  core::SlamSession session = makeSession(3);
  for (int i = 1; i <= 10; ++i) frame(&session, i);
  EXPECT_EQ(frame(&session, 10.0), core::FrameResult::kSkippedSameStamp);
  EXPECT_EQ(session.trajectory().size(), 10u);
  EXPECT_EQ(frame(&session, 1.0), core::FrameResult::kRejectedStamp);
  EXPECT_EQ(frame(&session, 10.0), core::FrameResult::kSkippedSameStamp);
  EXPECT_EQ(frame(&session, 1.5), core::FrameResult::kRejectedStamp);
  EXPECT_EQ(frame(&session, 2.0), core::FrameResult::kReset) << "still three late frames in a row";
  EXPECT_EQ(session.resets(), 1);
}

TEST(SlamSession, ARestartedClockStartsANewMapAfterEnoughFrames) {
  core::SlamSession session = makeSession(3);
  for (int i = 1; i <= 10; ++i) frame(&session, i);
  EXPECT_EQ(frame(&session, 1.0), core::FrameResult::kRejectedStamp);
  EXPECT_EQ(frame(&session, 1.5), core::FrameResult::kRejectedStamp);
  EXPECT_EQ(frame(&session, 2.0), core::FrameResult::kReset);  // third in a row: new run
  EXPECT_EQ(session.resets(), 1);
  ASSERT_EQ(session.trajectory().size(), 1u);
  EXPECT_DOUBLE_EQ(session.trajectory().front().stamp, 2.0);
  EXPECT_EQ(frame(&session, 3.0), core::FrameResult::kUpdated);
}

TEST(SlamSession, OneFrameBackResetsWhenConfiguredSo) {
  core::SlamSession session = makeSession(1);
  for (int i = 1; i <= 5; ++i) frame(&session, i);
  EXPECT_EQ(frame(&session, 1.0), core::FrameResult::kReset);
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
/// after the first frame. With odometry_period_s > 0 the session is told of odometry every
/// odometry_period_s between the frames, except in (hole_start, hole_end).
double spreadAfterGap(const std::string& action, double gap_s, long* gaps, long* resets,
                      double odometry_period_s = 0.0, double hole_start = 0.0,
                      double hole_end = 0.0, core::FrameResult* after_gap = nullptr) {
  core::FilterOptions filter;
  filter.particles = 200;
  filter.seed = 3;
  core::SessionOptions options;
  options.max_time_gap_s = 30.0;
  options.gap_action = action;
  core::SlamSession session(core::createFilter(filter), options);
  if (odometry_period_s > 0.0) {
    for (double t = 1.0; t <= 1.0 + gap_s + odometry_period_s; t += odometry_period_s) {
      if (t <= hole_start || t >= hole_end) session.addOdometryStamp(t);
    }
  }
  session.process(1.0, core::Pose2(0.0, 0.0, 0.0), core::FeatureSet());
  const core::FrameResult result =
      session.process(1.0 + gap_s, core::Pose2(0.5, 0.0, 0.0), core::FeatureSet());
  if (after_gap) *after_gap = result;
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
  core::FrameResult after_gap = core::FrameResult::kUpdated;
  spreadAfterGap("reset", 60.0, &gaps, &resets, 0.0, 0.0, 0.0, &after_gap);
  EXPECT_EQ(gaps, 1);
  EXPECT_EQ(resets, 1);
  EXPECT_EQ(after_gap, core::FrameResult::kReset) << "the caller must learn of the new map";
}

/// max_time_gap 30 s, the given gap_action.
core::SlamSession gapSession(const std::string& action) {
  core::SessionOptions options;
  options.max_time_gap_s = 30.0;
  options.gap_action = action;
  return sessionWith(options);
}

TEST(SlamSession, FramesFarApartWithOdometryInBetweenAreNoGap) {
  // A landmark camera reports only sightings: 60 s without a frame while the odometry kept
  // coming at 10 Hz is no gap; a 40 s hole in that odometry is, as is 60 s with no odometry
  // stamps known at all (then the frames' spacing is all there is).
  long gaps = 0, resets = 0;
  const double normal = spreadAfterGap("inflate", 1.0, &gaps, &resets);
  const double covered = spreadAfterGap("inflate", 60.0, &gaps, &resets, 0.1);
  EXPECT_EQ(gaps, 0);
  EXPECT_NEAR(covered, normal, 0.5 * normal);
  const double holed = spreadAfterGap("inflate", 60.0, &gaps, &resets, 0.1, 10.0, 50.0);
  EXPECT_EQ(gaps, 1);
  EXPECT_GT(holed, 2.0 * normal);
  spreadAfterGap("reset", 60.0, &gaps, &resets, 0.1, 10.0, 50.0);
  EXPECT_EQ(resets, 1);
  spreadAfterGap("inflate", 60.0, &gaps, &resets, 0.1, 10.0, 35.0);  // 25 s: below 30 s
  EXPECT_EQ(gaps, 0);
}

TEST(SlamSession, AClockJumpBackForgetsTheOldRunsOdometry) {
  // Odometry every 0.1 s over 1-100 s (frames until 30 s), then the bag starts over at 1 s,
  // with odometry until 20 s and none for 40 s: the old run's stamps must not fill that hole.
  core::SlamSession session = gapSession("inflate");
  for (double t = 1.0; t <= 100.0; t += 0.1) session.addOdometryStamp(t);
  for (double t = 10.0; t <= 30.0; t += 10.0) {
    session.process(t, core::Pose2(0.01 * t, 0.0, 0.0), core::FeatureSet());
  }
  for (double t = 1.0; t <= 20.0; t += 1.0) {
    for (double s = t - 0.9; s <= t + 0.05; s += 0.1) session.addOdometryStamp(s);
    session.process(t, core::Pose2(0.01 * t, 0.0, 0.0), core::FeatureSet());
  }
  ASSERT_EQ(session.resets(), 1);
  EXPECT_EQ(session.gaps(), 0);
  for (double t = 60.0; t <= 61.0; t += 0.1) session.addOdometryStamp(t);
  session.process(61.0, core::Pose2(0.61, 0.0, 0.0), core::FeatureSet());
  EXPECT_EQ(session.gaps(), 1);
}

TEST(OdometryStamps, LongestSilenceBracketsTheWindow) {
  core::OdometryStamps stamps;
  EXPECT_LT(stamps.longestSilence(0.0, 10.0).length, 0.0);  // unknown
  for (double t : {1.0, 2.0, 3.0, 9.0, 9.5, 12.0}) stamps.add(t);
  stamps.add(std::nan(""));
  stamps.add(2.0);  // a duplicate
  EXPECT_EQ(stamps.size(), 6u);
  const auto length = [&](double t0, double t1) { return stamps.longestSilence(t0, t1).length; };
  EXPECT_DOUBLE_EQ(length(2.5, 9.2), 6.0);  // 3 -> 9
  EXPECT_DOUBLE_EQ(stamps.longestSilence(2.5, 9.2).start, 3.0);
  EXPECT_DOUBLE_EQ(length(9.6, 9.7), 2.5);  // 9.5 -> 12 brackets it
  EXPECT_DOUBLE_EQ(length(1.0, 2.0), 1.0);
  EXPECT_DOUBLE_EQ(length(0.0, 1.5), 1.0);    // nothing before 0: from 0 to 1
  EXPECT_DOUBLE_EQ(length(12.0, 20.0), 8.0);  // nothing after 12 yet
  EXPECT_DOUBLE_EQ(length(9.2, 2.5), 6.0);    // order of the ends does not matter
  // Stretches that started at or before `counted_start` were dealt with already.
  EXPECT_DOUBLE_EQ(stamps.longestSilence(2.5, 9.7, 3.0).length, 2.5);  // 9.5 -> 12, not 3 -> 9
  stamps.forgetBefore(9.2);  // keeps 9, which brackets 9.2
  EXPECT_EQ(stamps.size(), 3u);
  EXPECT_DOUBLE_EQ(length(9.2, 9.4), 0.5);
  stamps.clear();
  EXPECT_LT(length(9.2, 9.4), 0.0);
}

TEST(OdometryStamps, MemoryIsBoundedAndEvictionIsNoSilence) {
  core::OdometryStamps stamps(100);
  for (int i = 0; i < 1000; ++i) stamps.add(0.01 * i);
  EXPECT_EQ(stamps.size(), 100u);
  EXPECT_NEAR(stamps.longestSilence(9.0, 9.98).length, 0.01, 1e-9);
  // A window from before the kept stamps: the odometry came until the last one evicted.
  EXPECT_NEAR(stamps.longestSilence(1.0, 9.5).length, 0.01, 1e-9);
}

// A 40 s hole in the odometry with frames every second inside it (offline, tf interpolates
// across it): one gap, and with gap_action reset one new map, not one per frame.
TEST(SlamSession, OneOdometryHoleIsOneGapHoweverManyFramesFallInIt) {
  for (const std::string action : {"inflate", "reset"}) {
    core::SlamSession session = gapSession(action);
    for (double t = 1.0; t <= 140.0; t += 0.1) {
      if (t < 20.0 || t > 60.0) session.addOdometryStamp(t);
    }
    for (double t = 2.0; t <= 90.0; t += 1.0) {
      session.process(t, core::Pose2(0.01 * t, 0.0, 0.0), core::FeatureSet());
    }
    // Frames 40 s apart while the odometry flows: no gap, so the reset kept the stamps.
    session.process(130.0, core::Pose2(1.3, 0.0, 0.0), core::FeatureSet());
    EXPECT_EQ(session.gaps(), 1) << action;
    EXPECT_EQ(session.resets(), action == "reset" ? 1 : 0) << action;
  }
}

// A frame inside a hole before the odometry after it has come (its silence provisionally ends
// at the frame), then the frame after the hole: still one gap.
TEST(SlamSession, AHoleSeenBeforeItEndsCountsOnce) {
  core::SlamSession session = gapSession("inflate");
  for (double t = 1.0; t < 20.0; t += 0.1) session.addOdometryStamp(t);
  session.process(10.0, core::Pose2(0.1, 0.0, 0.0), core::FeatureSet());
  session.process(55.0, core::Pose2(0.55, 0.0, 0.0), core::FeatureSet());
  EXPECT_EQ(session.gaps(), 1);
  for (double t = 60.1; t < 62.0; t += 0.1) session.addOdometryStamp(t);
  session.process(61.0, core::Pose2(0.61, 0.0, 0.0), core::FeatureSet());
  EXPECT_EQ(session.gaps(), 1);
}

TEST(SlamSession, GapOptionsAreValidated) {
  core::SessionOptions options;
  options.gap_action = "explode";
  EXPECT_THROW(core::validate(options), std::invalid_argument);
  options.gap_action = "reset";
  options.gap_noise_inflation = 0.5;
  EXPECT_THROW(core::validate(options), std::invalid_argument);
}

// A late sonar ring is many messages: one stamp, or stamps milliseconds apart. Only stamps far
// back for longer than reset_on_time_jump_back_s, in reset_after_frames_back distinct stamps
// with nothing in order between them, are a restarted clock.
TEST(ClockRestartDetector, ALateRingIsNotARestartedClock) {
  core::SessionOptions options;  // 1 s, 3 stamps
  core::ClockRestartDetector clock(options);
  for (int i = 0; i < 16; ++i) EXPECT_FALSE(clock.farBack(5.0)) << i;  // one stamp
  for (int i = 0; i < 16; ++i) EXPECT_FALSE(clock.farBack(5.0 + 0.01 * i)) << i;  // apart
  clock.inOrder();
  // A new clock: stamps go on from 1 s; the one 1 s after the first stale one restarts.
  EXPECT_FALSE(clock.farBack(1.0));
  EXPECT_FALSE(clock.farBack(1.5));
  EXPECT_TRUE(clock.farBack(2.0));
  EXPECT_EQ(clock.runLength(), 0);  // the run starts over
  // Input in order between late stamps ends the run.
  EXPECT_FALSE(clock.farBack(1.0));
  EXPECT_FALSE(clock.farBack(1.6));
  clock.inOrder();
  EXPECT_FALSE(clock.farBack(2.2));
  // reset_on_time_jump_back 0: never a restart.
  options.reset_on_time_jump_back_s = 0.0;
  core::ClockRestartDetector disabled(options);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(disabled.farBack(1.0 + i));
}

}  // namespace
}  // namespace rbpf_slam

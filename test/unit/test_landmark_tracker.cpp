// Landmark tracker: when it reports a new landmark (first sight, a second landmark, a landmark
// seen again after being forgotten), what it does not (the same landmark, ambiguous
// observations), lines as well as points, and bounded state.

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/tracking/landmark_tracker.h"

namespace rbpf_slam {
namespace core {
namespace {

const Eigen::Matrix3d kStepCov = Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal();
const Pose2 kStep(0.2, 0.0, 0.0);  // the robot drives along x, 0.2 m per step

TrackerObservation pointSeen(const Pose2& robot, const Eigen::Vector2d& landmark) {
  TrackerObservation o;
  o.z = predictPoint(robot, landmark).z;
  o.noise = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  return o;
}

TrackerObservation lineSeen(const Pose2& robot, const Eigen::Vector2d& line) {
  TrackerObservation o;
  o.type = LandmarkType::kLine;
  o.z = predictLine(robot, line, NAN).z;
  o.noise = Eigen::Vector2d(0.0025, 0.0009).asDiagonal();
  return o;
}

Pose2 robotAt(int step) { return Pose2(0.2 * step, 0.0, 0.0); }

TEST(LandmarkTracker, NewLandmarkOnlyWhenAnUntrackedOneAppears) {
  LandmarkTracker tracker{LandmarkTrackerOptions()};
  const Eigen::Vector2d a(5.0, 1.0), b(6.0, -2.0);
  TrackerEvent e = tracker.update(1, kStep, kStepCov, {pointSeen(robotAt(1), a)});
  EXPECT_TRUE(e.new_landmark);
  EXPECT_EQ(e.started, 1);
  for (int step = 2; step <= 5; ++step) {
    e = tracker.update(step, kStep, kStepCov, {pointSeen(robotAt(step), a)});
    EXPECT_FALSE(e.new_landmark) << step;
    EXPECT_EQ(e.matched, 1);
  }
  e = tracker.update(6, kStep, kStepCov, {pointSeen(robotAt(6), a), pointSeen(robotAt(6), b)});
  EXPECT_TRUE(e.new_landmark);
  EXPECT_EQ(e.started, 1);
  EXPECT_EQ(e.matched, 1);
  EXPECT_EQ(e.tracked, 2);
  // A few centimetres off: the same landmark.
  e = tracker.update(7, kStep, kStepCov, {pointSeen(robotAt(7), a + Eigen::Vector2d(0.05, -0.03))});
  EXPECT_FALSE(e.new_landmark);
  EXPECT_EQ(e.matched, 1);
  // Two metres from every tracked landmark: a new one.
  e = tracker.update(8, kStep, kStepCov, {pointSeen(robotAt(8), a + Eigen::Vector2d(0, 2.0))});
  EXPECT_TRUE(e.new_landmark);
  EXPECT_EQ(e.tracked, 3);
}

TEST(LandmarkTracker, AmbiguousObservationIsNeitherMatchedNorStarted) {
  LandmarkTrackerOptions options;
  options.gate_chi2 = 4.0;
  options.new_landmark_chi2 = 100.0;
  LandmarkTracker tracker(options);
  const Eigen::Vector2d a(3.0, 0.0);
  tracker.update(1, kStep, kStepCov, {pointSeen(robotAt(1), a)});
  for (int step = 2; step <= 4; ++step)
    tracker.update(step, kStep, kStepCov, {pointSeen(robotAt(step), a)});
  // 0.4 m behind along the range: (0.4 / ~0.14)^2 ~ 8, between the gate and the threshold.
  const TrackerEvent e =
      tracker.update(5, kStep, kStepCov, {pointSeen(robotAt(5), a + Eigen::Vector2d(0.4, 0))});
  EXPECT_FALSE(e.new_landmark);
  EXPECT_EQ(e.matched, 0);
  EXPECT_EQ(e.tracked, 1);
}

// Two sightings of one new landmark in one frame start one landmark, not two; a second new
// landmark in the same frame still starts its own.
TEST(LandmarkTracker, OneNewLandmarkSeenTwiceInAFrameStartsOnce) {
  LandmarkTracker tracker{LandmarkTrackerOptions()};
  const Eigen::Vector2d a(4.0, 1.0), b(5.0, -2.0);
  const Eigen::Vector2d a_again = a + Eigen::Vector2d(0.02, -0.01);
  TrackerEvent e = tracker.update(
      1, kStep, kStepCov,
      {pointSeen(robotAt(1), a), pointSeen(robotAt(1), a_again), pointSeen(robotAt(1), b)});
  EXPECT_TRUE(e.new_landmark);
  EXPECT_EQ(e.started, 2);
  EXPECT_EQ(e.matched, 1);
  EXPECT_EQ(e.tracked, 2);
  e = tracker.update(2, kStep, kStepCov, {pointSeen(robotAt(2), a), pointSeen(robotAt(2), b)});
  EXPECT_FALSE(e.new_landmark);
  EXPECT_EQ(e.matched, 2);
  EXPECT_EQ(e.tracked, 2);
}

TEST(LandmarkTracker, ForgetsLandmarksLeftBehindAndReportsThemAgain) {
  LandmarkTrackerOptions options;
  options.forget_after_steps = 5;
  LandmarkTracker tracker(options);
  const Eigen::Vector2d a(4.0, 1.0);
  for (int step = 1; step <= 3; ++step)
    tracker.update(step, kStep, kStepCov, {pointSeen(robotAt(step), a)});
  EXPECT_EQ(tracker.trackedLandmarks(), 1);
  int forgotten_at = -1;
  for (int step = 4; step <= 12; ++step) {
    const TrackerEvent e = tracker.update(step, kStep, kStepCov, {});
    if (e.forgotten > 0 && forgotten_at < 0) forgotten_at = step;
  }
  EXPECT_EQ(forgotten_at, 3 + 5);
  EXPECT_EQ(tracker.trackedLandmarks(), 0);
  const TrackerEvent e = tracker.update(13, kStep, kStepCov, {pointSeen(robotAt(13), a)});
  EXPECT_TRUE(e.new_landmark);
}

TEST(LandmarkTracker, ForgetsLandmarksFartherThanTheDistance) {
  LandmarkTrackerOptions options;
  options.forget_distance_m = 3.0;
  LandmarkTracker tracker(options);
  tracker.update(1, kStep, kStepCov, {pointSeen(robotAt(1), Eigen::Vector2d(2.0, 1.0))});
  int step = 2;
  for (; step < 40 && tracker.trackedLandmarks() > 0; ++step)
    tracker.update(step, kStep, kStepCov, {});
  // Robot at x = 0.2 step; the landmark at (2, 1) is beyond 3 m once x > 4.83.
  EXPECT_EQ(step - 1, 25);
}

TEST(LandmarkTracker, LinesFromLaserOrSonar) {
  LandmarkTracker tracker{LandmarkTrackerOptions()};
  const Eigen::Vector2d wall(2.0, M_PI / 2);  // y = 2
  const Eigen::Vector2d front(8.0, 0.0);      // x = 8
  TrackerEvent e = tracker.update(1, kStep, kStepCov, {lineSeen(robotAt(1), wall)});
  EXPECT_TRUE(e.new_landmark);
  for (int step = 2; step <= 6; ++step) {
    e = tracker.update(step, kStep, kStepCov, {lineSeen(robotAt(step), wall)});
    EXPECT_FALSE(e.new_landmark) << step;
  }
  e = tracker.update(7, kStep, kStepCov, {lineSeen(robotAt(7), wall), lineSeen(robotAt(7), front)});
  EXPECT_TRUE(e.new_landmark);
  EXPECT_EQ(e.matched, 1);
  // A point at the same place as nothing tracked of its type: new, types do not mix.
  e = tracker.update(8, kStep, kStepCov, {pointSeen(robotAt(8), Eigen::Vector2d(8.0, 2.0))});
  EXPECT_TRUE(e.new_landmark);
}

// A line's extent counts: a collinear wall 35 m further on is another landmark (an event), and a
// wall left behind is forgotten by its distance to the stretch seen, not to the infinite line.
TEST(LandmarkTracker, CollinearWallsFarApartAreDifferentLandmarks) {
  const auto segment = [](const Pose2& robot, double x0, double x1) {
    TrackerObservation o = lineSeen(robot, Eigen::Vector2d(2.0, M_PI / 2));  // y = 2
    o.start = transformPoint(inverse(robot), Eigen::Vector2d(x0, 2.0));
    o.end = transformPoint(inverse(robot), Eigen::Vector2d(x1, 2.0));
    return o;
  };
  for (const double margin : {1.0, -1.0}) {
    LandmarkTrackerOptions options;
    options.line_overlap_margin_m = margin;
    options.forget_after_steps = 1000;
    LandmarkTracker tracker(options);
    int events = 0, step = 1;
    for (; step <= 20; ++step) {  // x = 0.2 .. 4: the first wall, x in [0, 5]
      events += tracker.update(step, kStep, kStepCov, {segment(robotAt(step), 0.0, 5.0)}).started;
    }
    const Pose2 far(40.0, 0.0, 0.0);  // driven on to x = 40 with nothing in view
    for (; step <= 200; ++step) {
      tracker.update(step, kStep, kStepCov, {});
      if (robotAt(step).x() >= far.x()) break;
    }
    const TrackerEvent e = tracker.update(++step, kStep, kStepCov, {segment(robotAt(step), 38.0, 43.0)});
    events += e.started;
    if (margin >= 0.0) {
      EXPECT_EQ(events, 2) << "the second wall is another landmark";
      EXPECT_EQ(tracker.trackedLandmarks(), 1) << "the first, 35 m behind, is forgotten";
    } else {
      EXPECT_EQ(events, 1) << "infinite lines: the same wall";
    }
  }
}

// A line first seen without end points (unset in a message) has no extent yet: a later segment
// of it 3-8 m ahead is the same landmark, not a second copy (the robot's position used to be
// taken as its extent).
TEST(LandmarkTracker, ALineSeenWithoutEndsGetsItsExtentLater) {
  LandmarkTracker tracker{LandmarkTrackerOptions()};
  const Eigen::Vector2d wall(2.0, M_PI / 2);  // y = 2
  TrackerEvent e = tracker.update(1, kStep, kStepCov, {lineSeen(robotAt(1), wall)});
  ASSERT_EQ(e.started, 1);
  TrackerObservation segment = lineSeen(robotAt(2), wall);
  segment.start = transformPoint(inverse(robotAt(2)), Eigen::Vector2d(3.0, 2.0));
  segment.end = transformPoint(inverse(robotAt(2)), Eigen::Vector2d(8.0, 2.0));
  e = tracker.update(2, kStep, kStepCov, {segment});
  EXPECT_EQ(e.started, 0);
  EXPECT_EQ(e.matched, 1);
  EXPECT_EQ(tracker.trackedLandmarks(), 1);
  const LandmarkEstimate l = tracker.landmarks().front();
  EXPECT_NEAR(std::max(std::fabs(l.end.x() - l.start.x()), 0.0), 5.0, 0.1) << "the extent seen";
}

TEST(LandmarkTracker, StateIsBounded) {
  LandmarkTrackerOptions options;
  options.max_landmarks = 4;
  options.forget_after_steps = 1000;
  options.forget_distance_m = 1000.0;
  LandmarkTracker tracker(options);
  for (int step = 1; step <= 30; ++step) {
    // A new landmark every step, 3 m apart: never matched with an older one.
    tracker.update(step, kStep, kStepCov,
                   {pointSeen(robotAt(step), Eigen::Vector2d(3.0 * step, 5.0))});
    EXPECT_LE(tracker.trackedLandmarks(), 4);
    EXPECT_EQ(tracker.state().size(), 3 + 2 * tracker.trackedLandmarks());
  }
}

TEST(LandmarkTracker, MoreLandmarksInViewThanItHoldsRaiseNoEventAtEveryFrame) {
  // Eight posts in view all the time, room for five: the first frame starts five, and later
  // frames must not drop one seen now to start another (which would be an event per frame).
  LandmarkTrackerOptions options;
  options.max_landmarks = 5;
  LandmarkTracker tracker(options);
  int events = 0, left_out = 0;
  // Detection is not perfect: post (step mod 8) is missed at each frame.
  for (int step = 1; step <= 40; ++step) {
    std::vector<TrackerObservation> seen;
    for (int k = 0; k < 8; ++k) {
      if (step > 1 && k == step % 8) continue;
      seen.push_back(pointSeen(robotAt(step), Eigen::Vector2d(2.0 + 3.0 * k, 6.0)));
    }
    const TrackerEvent event = tracker.update(step, kStep, kStepCov, seen);
    events += event.new_landmark ? 1 : 0;
    left_out += event.left_out_full;
    EXPECT_LE(tracker.trackedLandmarks(), 5);
  }
  EXPECT_EQ(events, 1);
  EXPECT_GE(left_out, 40 * 2);
  // When one leaves the view for good, a waiting one takes its place once it has been unseen
  // for a fifth of forget_after_steps: one event.
  int started = 0, at = 0;
  for (int step = 41; step <= 41 + options.forget_after_steps; ++step) {
    std::vector<TrackerObservation> seen;
    for (int k = 1; k < 8; ++k) {
      seen.push_back(pointSeen(robotAt(step), Eigen::Vector2d(2.0 + 3.0 * k, 6.0)));
    }
    const TrackerEvent event = tracker.update(step, kStep, kStepCov, seen);
    if (event.new_landmark && at == 0) at = step;
    started += event.started;
  }
  EXPECT_EQ(started, 1);
  EXPECT_EQ(at, 39 + options.forget_after_steps / 5);  // post 0 was last seen at step 39
  EXPECT_EQ(tracker.trackedLandmarks(), 5);
}

TEST(LandmarkTracker, TrackedLandmarksCorrectOdometryDrift) {
  LandmarkTracker tracker{LandmarkTrackerOptions()};
  const Eigen::Vector2d a(4.0, 2.0), b(5.0, -2.0);
  // Odometry reports 0.21 m per step (one sigma too far), the robot moves 0.2 m.
  for (int step = 1; step <= 20; ++step) {
    tracker.update(step, Pose2(0.21, 0, 0), kStepCov,
                   {pointSeen(robotAt(step), a), pointSeen(robotAt(step), b)});
  }
  // The frame is anchored at the first pose (x = 0.21 by odometry, truly 0.2), so the truth
  // in the tracker's frame is x = 4.01; dead reckoning says 4.2.
  const double error = std::fabs(tracker.pose().x() - (robotAt(20).x() + 0.01));
  EXPECT_LT(error, 0.5 * 0.19) << tracker.pose().transpose();
}

TEST(LandmarkTracker, ValidateNamesTheKey) {
  LandmarkTrackerOptions o;
  o.gate_chi2 = 20.0;
  o.new_landmark_chi2 = 10.0;
  try {
    validate(o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tracker.new_landmark_chi2"), std::string::npos);
  }
  o = LandmarkTrackerOptions();
  o.forget_after_steps = 0;
  EXPECT_THROW(validate(o), std::invalid_argument);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

// The landmark tracker on its own (TrackerFrontend, behind the landmark_tracker node): feature
// frames with odometry poses in; a new-landmark event exactly when an untracked landmark comes
// into view; tracked landmarks (points and walls, with extents) in the odometry frame, anchored
// at a first pose away from the origin; bad frames refused with the reason.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/tracking/tracker_frontend.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kRange = 4.0;  // the sensor sees points this far, in front of the robot
const Pose2 kStart(2.0, -1.0, 0.7);  // the first odometry pose: the frame is not the origin

/// The robot drives straight on from kStart, 0.2 m per step, with exact odometry.
Pose2 robotAt(int step) { return compose(kStart, Pose2(0.2 * step, 0.0, 0.0)); }

/// Points ahead along the route (in the odometry frame), entering the view one by one, and a
/// wall parallel to the route, 2 m to its left.
struct World {
  std::vector<Eigen::Vector2d> points;
  Eigen::Vector2d wall;  // (rho, alpha) in the odometry frame
  World() {
    for (double along : {3.0, 5.5, 8.0}) {
      points.push_back(transformPoint(kStart, Eigen::Vector2d(along, -1.0)));
    }
    const double alpha = kStart.z() + M_PI / 2.0;  // normal pointing to the wall
    const Eigen::Vector2d on_wall = transformPoint(kStart, Eigen::Vector2d(0.0, 2.0));
    double rho = on_wall.dot(Eigen::Vector2d(std::cos(alpha), std::sin(alpha))), theta = alpha;
    normalizeLine(rho, theta);
    wall = Eigen::Vector2d(rho, theta);
  }
  /// Noise-free features from pose; the wall seen from 1 m behind to 3 m ahead of the robot.
  FeatureSet observe(const Pose2& pose, double stamp) const {
    FeatureSet set;
    set.stamp = stamp;
    for (const Eigen::Vector2d& p : points) {
      const Eigen::Vector2d z = predictPoint(pose, p).z;
      if (z.x() > kRange || std::fabs(z.y()) > M_PI / 2.0) continue;
      PointFeature f;
      f.range = z.x();
      f.bearing = z.y();
      f.covariance = Eigen::Vector2d(1e-4, 1e-5).asDiagonal();
      set.points.push_back(f);
    }
    LineFeature line;
    const Eigen::Vector2d z = predictLine(pose, wall, NAN).z;
    line.rho = z.x();
    line.theta = z.y();
    line.covariance = Eigen::Vector2d(1e-4, 1e-5).asDiagonal();
    line.start = Eigen::Vector2d(-1.0, 2.0);  // base frame: the wall is 2 m to the left
    line.end = Eigen::Vector2d(3.0, 2.0);
    set.lines.push_back(line);
    return set;
  }
};

FilterOptions options() {
  FilterOptions o;
  o.use_points = true;
  o.use_lines = true;
  return o;
}

TEST(TrackerFrontend, EventsExactlyWhenAnUntrackedLandmarkComesIntoView) {
  const World world;
  TrackerFrontend frontend(options());
  std::string why;
  std::map<int, int> started_at;  // step -> landmarks started
  for (int step = 0; step < 25; ++step) {
    TrackerEvent event;
    ASSERT_TRUE(frontend.process(world.observe(robotAt(step), 1.0 + step), robotAt(step), &event,
                                 &why))
        << why;
    if (event.new_landmark) started_at[step] = event.started;
  }
  // Step 0: the wall and the first point (3 m ahead, 1 m aside). The second point (5.5 m)
  // comes within the 4 m range at step 9 (1.8 m driven), the third (8 m) at step 21.
  std::map<int, int> expected{{0, 2}, {9, 1}, {21, 1}};
  EXPECT_EQ(started_at, expected);
}

TEST(TrackerFrontend, LandmarksAreInTheOdometryFrameWithStableIdsAndWallExtent) {
  const World world;
  TrackerFrontend frontend(options());
  std::string why;
  TrackerEvent event;
  std::map<int, Eigen::Vector2d> first_seen;  // point id -> position when first listed
  for (int step = 0; step < 15; ++step) {
    ASSERT_TRUE(frontend.process(world.observe(robotAt(step), 1.0 + step), robotAt(step), &event,
                                 &why));
    for (const LandmarkEstimate& e : frontend.landmarks()) {
      if (e.type == LandmarkType::kPoint && !first_seen.count(e.id)) first_seen[e.id] = e.mean;
    }
  }
  EXPECT_LT((frontend.pose().head<2>() - robotAt(14).head<2>()).norm(), 0.05);
  int points = 0, lines = 0;
  for (const LandmarkEstimate& e : frontend.landmarks()) {
    ASSERT_TRUE(e.mean.allFinite() && e.covariance.allFinite());
    if (e.type == LandmarkType::kPoint) {
      ++points;
      double nearest = 1e9;
      for (const Eigen::Vector2d& p : world.points) nearest = std::min(nearest, (e.mean - p).norm());
      EXPECT_LT(nearest, 0.05) << "point " << e.id << " at " << e.mean.transpose();
      ASSERT_TRUE(first_seen.count(e.id)) << "a point changed its id";
      EXPECT_LT((first_seen[e.id] - e.mean).norm(), 0.05) << "id " << e.id << " moved";
    } else {
      ++lines;
      const Eigen::Vector2d d = lineDifference(e.mean, world.wall);
      EXPECT_LT(std::fabs(d.x()), 0.05);
      EXPECT_LT(std::fabs(d.y()), 0.01);
      // Seen from 1 m behind the start to 3 m ahead of step 14 (2.8 m driven): 6.8 m of wall.
      EXPECT_NEAR((e.end - e.start).norm(), 6.8, 0.1);
    }
  }
  EXPECT_EQ(points, 2);
  EXPECT_EQ(lines, 1);
}

TEST(TrackerFrontend, RefusesStaleStampsAndNonFinitePosesAndStartsOverOnReset) {
  const World world;
  TrackerFrontend frontend(options());
  std::string why;
  TrackerEvent event;
  EXPECT_FALSE(frontend.atLastStamp(1.0)) << "nothing processed yet";
  ASSERT_TRUE(frontend.process(world.observe(robotAt(0), 1.0), robotAt(0), &event, &why));
  EXPECT_TRUE(frontend.atLastStamp(1.0));  // the node skips it as another input of that instant
  EXPECT_FALSE(frontend.atLastStamp(0.5));
  EXPECT_FALSE(frontend.atLastStamp(1.5));
  event = TrackerEvent();
  EXPECT_FALSE(frontend.process(world.observe(robotAt(1), 1.0), robotAt(1), &event, &why));
  EXPECT_EQ(why, "stamp not after the last");
  const Pose2 bad(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0);
  EXPECT_FALSE(frontend.process(world.observe(robotAt(1), 2.0), bad, &event, &why));
  EXPECT_EQ(why, "odometry pose not finite");
  EXPECT_EQ(event.step, 0) << "a refused frame changed the event";
  EXPECT_EQ(frontend.steps(), 1);
  frontend.reset();
  EXPECT_TRUE(frontend.landmarks().empty());
  ASSERT_TRUE(frontend.process(world.observe(robotAt(3), 0.5), robotAt(3), &event, &why));
  EXPECT_TRUE(event.new_landmark) << "after a reset everything in view is new";
  EXPECT_EQ(event.step, 1);
  // A NaN first stamp (core API callers) is refused, not kept: it used to refuse every later one.
  frontend.reset();
  EXPECT_FALSE(frontend.process(world.observe(robotAt(0), std::nan("")), robotAt(0), &event, &why));
  EXPECT_EQ(why, "stamp not finite or not positive");
  EXPECT_TRUE(frontend.process(world.observe(robotAt(0), 1.0), robotAt(0), &event, &why)) << why;
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

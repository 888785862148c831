#pragma once
// Robot kinematics (differential drive, car-like bicycle) and the controller that steers the
// simulated robot around its waypoint loop.

#include <Eigen/Core>
#include <vector>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/sim/world.h"

namespace rbpf_slam {
namespace core {
namespace sim {

/// Commands for one control step; steering_rad is used by the bicycle model only.
struct Control {
  double speed_mps = 0.0;
  double turn_rate_radps = 0.0;
  double steering_rad = 0.0;
};

/// The turn rate that a control produces for the robot's drive type.
double turnRate(const RobotConfig& robot, const Control& control);

/// Moves pose along a circular arc at (speed, turn rate) for dt seconds.
Pose2 integrateArc(const Pose2& pose, double speed_mps, double turn_rate_radps, double dt_s);

/// Steers along the waypoint loop (pure pursuit or turn-then-drive) and counts laps.
class WaypointFollower {
 public:
  WaypointFollower(const RobotConfig& robot, std::vector<Eigen::Vector2d> waypoints, int laps);

  /// The pose where the route starts: the first waypoint, facing the second.
  Pose2 startPose() const;
  /// The command for the next dt_s seconds; advances to the next waypoint when one is reached.
  Control control(const Pose2& pose, double dt_s);

  bool done() const { return done_; }
  int lapsCompleted() const { return laps_completed_; }
  int targetIndex() const { return target_; }

 private:
  bool reached(const Eigen::Vector2d& position) const;
  void advance();
  Control purePursuit(const Pose2& pose, double dt_s);
  Control turnThenDrive(const Pose2& pose) const;

  const RobotConfig robot_;
  const std::vector<Eigen::Vector2d> waypoints_;
  const int laps_;
  int target_ = 1;
  int laps_completed_ = 0;
  bool done_ = false;
  double steering_rad_ = 0.0;  // current steering angle (bicycle), for the rate limit
};

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

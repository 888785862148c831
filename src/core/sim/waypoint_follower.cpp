#include "rbpf_slam/core/sim/waypoint_follower.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam {
namespace core {
namespace sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
// Pure pursuit on a differential drive turns on the spot beyond this carrot angle.
constexpr double kTurnInPlaceAngleRad = 60.0 * kDegToRad;
// Turn-then-drive turns on the spot while the heading error exceeds this.
constexpr double kTurnStartRad = 10.0 * kDegToRad;
// Proportional heading gain [1/s] for turning on the spot and for driving straight.
constexpr double kHeadingGain = 3.0;

double angleTo(const Pose2& pose, const Eigen::Vector2d& target) {
  const Eigen::Vector2d d = target - pose.head<2>();
  return wrapAngle(std::atan2(d.y(), d.x()) - pose.z());
}

}  // namespace

double turnRate(const RobotConfig& robot, const Control& control) {
  if (robot.drive == DriveType::kBicycle) {
    return control.speed_mps * std::tan(control.steering_rad) / robot.wheelbase_m;
  }
  return control.turn_rate_radps;
}

Pose2 integrateArc(const Pose2& pose, double speed_mps, double turn_rate_radps, double dt_s) {
  const double theta = pose.z();
  const double rotation = turn_rate_radps * dt_s;
  if (std::abs(rotation) < 1e-9) {
    const double heading = theta + 0.5 * rotation;
    return Pose2(pose.x() + speed_mps * dt_s * std::cos(heading),
                 pose.y() + speed_mps * dt_s * std::sin(heading), wrapAngle(theta + rotation));
  }
  const double radius = speed_mps / turn_rate_radps;
  return Pose2(pose.x() + radius * (std::sin(theta + rotation) - std::sin(theta)),
               pose.y() + radius * (std::cos(theta) - std::cos(theta + rotation)),
               wrapAngle(theta + rotation));
}

WaypointFollower::WaypointFollower(const RobotConfig& robot, std::vector<Eigen::Vector2d> waypoints,
                                   int laps)
    : robot_(robot), waypoints_(std::move(waypoints)), laps_(laps) {}

Pose2 WaypointFollower::startPose() const {
  const Eigen::Vector2d d = waypoints_[1] - waypoints_[0];
  return Pose2(waypoints_[0].x(), waypoints_[0].y(), std::atan2(d.y(), d.x()));
}

bool WaypointFollower::reached(const Eigen::Vector2d& position) const {
  const Eigen::Vector2d& q = waypoints_[target_];
  const Eigen::Vector2d& p = waypoints_[(target_ + waypoints_.size() - 1) % waypoints_.size()];
  // Reached when close, or when past the line through the target normal to the leg (so that
  // a car whose turning circle misses the waypoint does not orbit it forever).
  return (position - q).norm() < robot_.waypoint_tolerance_m || (position - q).dot(q - p) > 0.0;
}

void WaypointFollower::advance() {
  if (target_ == 0 && ++laps_completed_ >= laps_) done_ = true;
  target_ = (target_ + 1) % static_cast<int>(waypoints_.size());
}

Control WaypointFollower::control(const Pose2& pose, double dt_s) {
  for (size_t i = 0; i < waypoints_.size() && !done_ && reached(pose.head<2>()); ++i) advance();
  if (done_) return Control();
  if (robot_.controller == ControllerType::kTurnThenDrive) return turnThenDrive(pose);
  return purePursuit(pose, dt_s);
}

Control WaypointFollower::purePursuit(const Pose2& pose, double dt_s) {
  const Eigen::Vector2d& q = waypoints_[target_];
  const Eigen::Vector2d& p = waypoints_[(target_ + waypoints_.size() - 1) % waypoints_.size()];
  const Eigen::Vector2d leg = q - p;
  const double length = leg.norm();
  const double along =
      std::clamp((pose.head<2>() - p).dot(leg) / (length * length), 0.0, 1.0) * length +
      robot_.lookahead_m;
  const Eigen::Vector2d carrot = along >= length ? q : Eigen::Vector2d(p + leg * (along / length));
  const double alpha = angleTo(pose, carrot);
  const double distance = std::max((carrot - pose.head<2>()).norm(), 1e-6);
  const double curvature = 2.0 * std::sin(alpha) / distance;

  Control control;
  control.speed_mps = robot_.speed_mps;
  if (robot_.drive == DriveType::kBicycle) {
    const double max_steering = robot_.max_steering_deg * kDegToRad;
    double wanted = std::abs(alpha) > M_PI_2 ? std::copysign(max_steering, alpha)
                                             : std::atan(robot_.wheelbase_m * curvature);
    wanted = std::clamp(wanted, -max_steering, max_steering);
    if (robot_.max_steering_rate_deg_s > 0.0) {
      const double step = robot_.max_steering_rate_deg_s * kDegToRad * dt_s;
      wanted = std::clamp(wanted, steering_rad_ - step, steering_rad_ + step);
    }
    steering_rad_ = wanted;
    control.steering_rad = wanted;
    control.turn_rate_radps = turnRate(robot_, control);
    return control;
  }
  const double max_turn_rate = robot_.max_turn_rate_deg_s * kDegToRad;
  if (std::abs(alpha) > kTurnInPlaceAngleRad) {
    control.speed_mps = 0.0;
    control.turn_rate_radps = std::clamp(kHeadingGain * alpha, -max_turn_rate, max_turn_rate);
    return control;
  }
  control.turn_rate_radps = control.speed_mps * curvature;
  if (std::abs(control.turn_rate_radps) > max_turn_rate) {
    // Keep the curvature, slow down.
    control.speed_mps = max_turn_rate / std::abs(curvature);
    control.turn_rate_radps = std::copysign(max_turn_rate, curvature);
  }
  return control;
}

Control WaypointFollower::turnThenDrive(const Pose2& pose) const {
  const double alpha = angleTo(pose, waypoints_[target_]);
  const double max_turn_rate = robot_.max_turn_rate_deg_s * kDegToRad;
  Control control;
  control.turn_rate_radps = std::clamp(kHeadingGain * alpha, -max_turn_rate, max_turn_rate);
  control.speed_mps = std::abs(alpha) > kTurnStartRad ? 0.0 : robot_.speed_mps;
  return control;
}

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

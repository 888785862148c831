#include "rbpf_slam/core/filters/measurement_models.h"

#include <cmath>

namespace rbpf_slam {
namespace core {

Prediction predictPoint(const Pose2& pose, const Eigen::Vector2d& point) {
  Prediction p;
  const double dx = point.x() - pose.x(), dy = point.y() - pose.y();
  const double q = std::max(dx * dx + dy * dy, 1e-12);
  const double r = std::sqrt(q);
  p.z << r, wrapAngle(std::atan2(dy, dx) - pose.z());
  p.h_pose << -dx / r, -dy / r, 0.0, dy / q, -dx / q, -1.0;
  p.h_landmark << dx / r, dy / r, -dy / q, dx / q;
  return p;
}

Prediction predictLine(const Pose2& pose, const Eigen::Vector2d& line, double observed_theta) {
  Prediction p;
  const double rho = line.x(), alpha = line.y();
  const double c = std::cos(alpha), s = std::sin(alpha);
  const double rho_robot = rho - pose.x() * c - pose.y() * s;
  const double theta_robot = wrapAngle(alpha - pose.z());
  double sign = rho_robot >= 0.0 ? 1.0 : -1.0;
  if (std::isfinite(observed_theta)) {
    sign = std::fabs(wrapAngle(observed_theta - theta_robot)) <= M_PI / 2.0 ? 1.0 : -1.0;
  }
  p.z << sign * rho_robot, wrapAngle(theta_robot + (sign > 0.0 ? 0.0 : M_PI));
  p.h_pose << -sign * c, -sign * s, 0.0, 0.0, 0.0, -1.0;
  p.h_landmark << sign, sign * (pose.x() * s - pose.y() * c), 0.0, 1.0;
  return p;
}

Eigen::Vector2d pointFromObservation(const Pose2& pose, const Eigen::Vector2d& range_bearing,
                                     Eigen::Matrix2d* jacobian_z) {
  const double r = range_bearing.x();
  const double angle = pose.z() + range_bearing.y();
  const double c = std::cos(angle), s = std::sin(angle);
  if (jacobian_z) *jacobian_z << c, -r * s, s, r * c;
  return Eigen::Vector2d(pose.x() + r * c, pose.y() + r * s);
}

Eigen::Vector2d lineFromObservation(const Pose2& pose, const Eigen::Vector2d& rho_theta,
                                    Eigen::Matrix2d* jacobian_z) {
  const double alpha = wrapAngle(rho_theta.y() + pose.z());
  const double c = std::cos(alpha), s = std::sin(alpha);
  double rho = rho_theta.x() + pose.x() * c + pose.y() * s;
  Eigen::Matrix2d j;
  j << 1.0, -pose.x() * s + pose.y() * c, 0.0, 1.0;
  Eigen::Vector2d line(rho, alpha);
  if (rho < 0.0) {  // keep rho >= 0 in the map: flip the normal
    line << -rho, wrapAngle(alpha + M_PI);
    j.row(0) *= -1.0;
  }
  if (jacobian_z) *jacobian_z = j;
  return line;
}

Eigen::Vector2d lineDifference(const Eigen::Vector2d& line, const Eigen::Vector2d& reference) {
  double d_alpha = wrapAngle(line.y() - reference.y());
  double rho = line.x();
  if (std::fabs(d_alpha) > M_PI / 2.0) {
    rho = -rho;
    d_alpha = wrapAngle(d_alpha + M_PI);
  }
  return Eigen::Vector2d(rho - reference.x(), d_alpha);
}

}  // namespace core
}  // namespace rbpf_slam

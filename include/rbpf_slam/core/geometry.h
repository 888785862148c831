#pragma once
// 2D rigid-body geometry shared by every core module: poses as (x, y, theta).

#include <Eigen/Core>
#include <cmath>

namespace rbpf_slam {
namespace core {

/// A planar pose (x [m], y [m], theta [rad]).
using Pose2 = Eigen::Vector3d;

/// Wraps an angle to [-pi, pi).
inline double wrapAngle(double angle) {
  if (!std::isfinite(angle)) return angle;
  angle = std::fmod(angle + M_PI, 2.0 * M_PI);
  if (angle < 0.0) angle += 2.0 * M_PI;  // may round up to 2 pi (an angle just below -pi)
  const double wrapped = angle - M_PI;
  return wrapped >= M_PI ? -M_PI : wrapped;
}

/// a (+) b: b expressed in a's frame, returned in a's parent frame.
inline Pose2 compose(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.z()), s = std::sin(a.z());
  return Pose2(a.x() + c * b.x() - s * b.y(), a.y() + s * b.x() + c * b.y(),
               wrapAngle(a.z() + b.z()));
}

/// The inverse transform of a.
inline Pose2 inverse(const Pose2& a) {
  const double c = std::cos(a.z()), s = std::sin(a.z());
  return Pose2(-c * a.x() - s * a.y(), s * a.x() - c * a.y(), wrapAngle(-a.z()));
}

/// a^-1 (+) b: the pose of b in a's frame (e.g. an odometry increment).
inline Pose2 between(const Pose2& a, const Pose2& b) { return compose(inverse(a), b); }

/// Maps a point from the frame of pose into the pose's parent frame.
inline Eigen::Vector2d transformPoint(const Pose2& pose, const Eigen::Vector2d& p) {
  const double c = std::cos(pose.z()), s = std::sin(pose.z());
  return Eigen::Vector2d(pose.x() + c * p.x() - s * p.y(), pose.y() + s * p.x() + c * p.y());
}

/// True when every component is finite.
template <typename Derived>
bool allFinite(const Eigen::MatrixBase<Derived>& m) {
  return m.allFinite();
}

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Observation models of point and line landmarks with their Jacobians, shared by every
// landmark filter (FastSLAM 2.0, robust, H-infinity, EKF).

#include <Eigen/Core>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

/// A predicted observation z_hat = h(pose, landmark) with d h / d pose and d h / d landmark.
struct Prediction {
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix<double, 2, 3> h_pose = Eigen::Matrix<double, 2, 3>::Zero();
  Eigen::Matrix2d h_landmark = Eigen::Matrix2d::Zero();
};

/// Range and bearing of map point (x, y) from pose.
Prediction predictPoint(const Pose2& pose, const Eigen::Vector2d& point);

/// A map line (rho, alpha) seen from pose, in normal form relative to the robot. The sign of
/// the robot-frame normal is chosen to be the one nearest observed_theta, so that lines
/// passing close to the robot do not flip (pass NaN to use rho >= 0).
Prediction predictLine(const Pose2& pose, const Eigen::Vector2d& line, double observed_theta);

/// Innovation z - z_hat with the angular component wrapped.
inline Eigen::Vector2d innovation(const Eigen::Vector2d& z, const Eigen::Vector2d& z_hat) {
  return Eigen::Vector2d(z.x() - z_hat.x(), wrapAngle(z.y() - z_hat.y()));
}

/// Covariance of the innovation z - z_hat from the landmark's uncertainty and the observation
/// noise, H_l P_l H_l^T + R (the pose taken as known).
inline Eigen::Matrix2d landmarkInnovationCovariance(const Prediction& p,
                                                    const Eigen::Matrix2d& landmark_cov,
                                                    const Eigen::Matrix2d& noise) {
  return p.h_landmark * landmark_cov * p.h_landmark.transpose() + noise;
}

/// Inverse models: a new landmark from an observation at pose, with d m / d z.
Eigen::Vector2d pointFromObservation(const Pose2& pose, const Eigen::Vector2d& range_bearing,
                                     Eigen::Matrix2d* jacobian_z);
Eigen::Vector2d lineFromObservation(const Pose2& pose, const Eigen::Vector2d& rho_theta,
                                    Eigen::Matrix2d* jacobian_z);

/// The map-frame (rho, alpha) made comparable to reference: flipped to the same normal
/// half-plane. Returns (delta_rho, delta_alpha) of line minus reference.
Eigen::Vector2d lineDifference(const Eigen::Vector2d& line, const Eigen::Vector2d& reference);

}  // namespace core
}  // namespace rbpf_slam

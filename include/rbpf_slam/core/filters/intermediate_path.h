#pragma once
// Intermediate path estimation of Lee, Kim and Chung (ICRA 2010, sec. IV, Fig. 5): the poses
// between two sampled end poses x_{t-s} and x_t, from the odometry increments of the steps in
// between, by constrained least squares over the relative motions solved with an iterated
// EKF (the loop-closing step of Estrada, Neira and Tardos 2005).

#include <Eigen/Core>
#include <vector>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

/// Mean and covariance of each pose strictly between the two end poses.
struct IntermediatePath {
  std::vector<Pose2> means;                  // x_{t-s+1} .. x_{t-1}
  std::vector<Eigen::Matrix3d> covariances;  // map frame
  int iterations = 0;
  bool converged = false;
};

/// d (a + b) / d a and d (a + b) / d b of pose composition.
Eigen::Matrix3d composeJacobianFirst(const Pose2& a, const Pose2& b);
Eigen::Matrix3d composeJacobianSecond(const Pose2& a);

/// increments[k] is the odometry increment from pose k to pose k+1, expressed in the frame of
/// pose k, with covariance increment_covariances[k] in that frame (positive definite);
/// s = increments.size() >= 1 increments join `start` to `end`, giving s - 1 intermediate poses.
/// Minimises sum_k |d_k - increments[k]|^2 weighted by the inverse covariances subject to
/// start + d_0 + ... + d_{s-1} = end (+ is pose composition).
IntermediatePath estimateIntermediatePath(const Pose2& start, const Pose2& end,
                                          const std::vector<Pose2>& increments,
                                          const std::vector<Eigen::Matrix3d>& increment_covariances,
                                          int max_iterations = 10);

}  // namespace core
}  // namespace rbpf_slam

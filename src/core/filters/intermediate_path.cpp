#include "rbpf_slam/core/filters/intermediate_path.h"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

namespace rbpf_slam {
namespace core {

Eigen::Matrix3d composeJacobianFirst(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.z()), s = std::sin(a.z());
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  j(0, 2) = -s * b.x() - c * b.y();
  j(1, 2) = c * b.x() - s * b.y();
  return j;
}

Eigen::Matrix3d composeJacobianSecond(const Pose2& a) {
  const double c = std::cos(a.z()), s = std::sin(a.z());
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  j.topLeftCorner<2, 2>() << c, -s, s, c;
  return j;
}

namespace {

/// Poses along the chain and, for each, its Jacobian with respect to all increments.
void chain(const Pose2& start, const Eigen::VectorXd& d, std::vector<Pose2>* poses,
           std::vector<Eigen::MatrixXd>* jacobians) {
  const int n = static_cast<int>(d.size() / 3);
  poses->assign(1, start);
  jacobians->assign(1, Eigen::MatrixXd::Zero(3, 3 * n));
  for (int k = 0; k < n; ++k) {
    const Pose2& previous = poses->back();
    const Pose2 increment = d.segment<3>(3 * k);
    Eigen::MatrixXd j = composeJacobianFirst(previous, increment) * jacobians->back();
    j.middleCols<3>(3 * k) += composeJacobianSecond(previous);
    Pose2 next = compose(previous, increment);
    next.z() = previous.z() + increment.z();  // unwrapped along the chain, wrapped on output
    poses->push_back(next);
    jacobians->push_back(j);
  }
}

}  // namespace

IntermediatePath estimateIntermediatePath(const Pose2& start, const Pose2& end,
                                          const std::vector<Pose2>& increments,
                                          const std::vector<Eigen::Matrix3d>& increment_covariances,
                                          int max_iterations) {
  const int n = static_cast<int>(increments.size());
  if (n < 1 || increment_covariances.size() != increments.size()) {
    throw std::invalid_argument("estimateIntermediatePath: need one covariance per increment");
  }
  Eigen::VectorXd prior(3 * n);
  Eigen::MatrixXd prior_cov = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int k = 0; k < n; ++k) {
    prior.segment<3>(3 * k) = increments[k];
    prior_cov.block<3, 3>(3 * k, 3 * k) = increment_covariances[k];
  }
  // Iterated EKF with the end pose as a noise-free measurement of the chain's last pose:
  // d_{i+1} = prior + K (r(d_i) + J (d_i - prior)), K = P J^T (J P J^T)^-1.
  IntermediatePath path;
  Eigen::VectorXd d = prior;
  std::vector<Pose2> poses;
  std::vector<Eigen::MatrixXd> jacobians;
  Eigen::MatrixXd gain;
  Eigen::MatrixXd h;
  for (int iteration = 0; iteration < std::max(1, max_iterations); ++iteration) {
    chain(start, d, &poses, &jacobians);
    h = jacobians.back();
    Eigen::Vector3d residual = end - poses.back();
    residual.z() = wrapAngle(residual.z());
    const Eigen::Matrix3d s = h * prior_cov * h.transpose() + 1e-12 * Eigen::Matrix3d::Identity();
    gain = prior_cov * h.transpose() * s.inverse();
    const Eigen::VectorXd next = prior + gain * (residual + h * (d - prior));
    const double change = (next - d).norm();
    d = next;
    path.iterations = iteration + 1;
    if (change < 1e-10) {
      path.converged = true;
      break;
    }
  }
  chain(start, d, &poses, &jacobians);
  const Eigen::MatrixXd posterior_cov =
      (Eigen::MatrixXd::Identity(3 * n, 3 * n) - gain * h) * prior_cov;
  for (int k = 1; k < n; ++k) {
    Pose2 mean = poses[k];
    mean.z() = wrapAngle(mean.z());
    path.means.push_back(mean);
    const Eigen::Matrix3d cov = jacobians[k] * posterior_cov * jacobians[k].transpose();
    path.covariances.push_back(0.5 * (cov + cov.transpose()));
  }
  return path;
}

}  // namespace core
}  // namespace rbpf_slam

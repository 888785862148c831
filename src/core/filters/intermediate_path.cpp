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

/// Poses along the chain from start (headings unwrapped along it, wrapped on output).
std::vector<Pose2> chain(const Pose2& start, const std::vector<Pose2>& d) {
  std::vector<Pose2> poses(1, start);
  poses.reserve(d.size() + 1);
  for (const Pose2& step : d) {
    const Pose2& previous = poses.back();
    Pose2 next = compose(previous, step);
    next.z() = previous.z() + step.z();
    poses.push_back(next);
  }
  return poses;
}

/// d pose_n / d d_k for every k (the chain's last pose against each increment), O(n): with
/// F_m = d pose_{m+1} / d pose_m and B_k = d pose_{k+1} / d d_k, it is F_{n-1} ... F_{k+1} B_k.
std::vector<Eigen::Matrix3d> lastPoseJacobian(const std::vector<Pose2>& poses,
                                              const std::vector<Pose2>& d) {
  const int n = static_cast<int>(d.size());
  std::vector<Eigen::Matrix3d> h(n);
  Eigen::Matrix3d after = Eigen::Matrix3d::Identity();  // F_{n-1} ... F_{k+1}
  for (int k = n - 1; k >= 0; --k) {
    h[k] = after * composeJacobianSecond(poses[k]);
    after = after * composeJacobianFirst(poses[k], d[k]);
  }
  return h;
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
  const std::vector<Eigen::Matrix3d>& p = increment_covariances;  // block-diagonal prior
  // Iterated EKF with the end pose as a noise-free measurement h(d) of the chain's last pose:
  // d_{i+1} = prior + K (r(d_i) + H (d_i - prior)), K = P H^T S^-1, S = H P H^T. P is
  // block-diagonal, so every product is taken block by block (O(n) per iteration; the whole
  // estimate is O(n) time and memory).
  IntermediatePath path;
  std::vector<Pose2> d = increments;
  std::vector<Pose2> poses;
  std::vector<Eigen::Matrix3d> p_ht(n);  // P_k H_k^T
  Eigen::Matrix3d s_inv = Eigen::Matrix3d::Identity();
  for (int iteration = 0; iteration < std::max(1, max_iterations); ++iteration) {
    poses = chain(start, d);
    const std::vector<Eigen::Matrix3d> h = lastPoseJacobian(poses, d);
    Eigen::Vector3d innovation = end - poses.back();
    innovation.z() = wrapAngle(innovation.z());
    Eigen::Matrix3d s = 1e-12 * Eigen::Matrix3d::Identity();
    for (int k = 0; k < n; ++k) {
      p_ht[k] = p[k] * h[k].transpose();
      s += h[k] * p_ht[k];
      innovation += h[k] * (d[k] - increments[k]);
    }
    s_inv = s.inverse();
    const Eigen::Vector3d correction = s_inv * innovation;
    double change = 0.0;
    for (int k = 0; k < n; ++k) {
      const Pose2 next = increments[k] + p_ht[k] * correction;
      change += (next - d[k]).squaredNorm();
      d[k] = next;
    }
    path.iterations = iteration + 1;
    if (change < 1e-20) {
      path.converged = true;
      break;
    }
  }
  poses = chain(start, d);
  // Covariance of pose j: G_j P G_j^T - (G_j P H^T) S^-1 (G_j P H^T)^T, with G_j the Jacobian
  // of pose j against the increments (P H^T from the last linearisation), both by recursion
  // along the chain: G_{j+1} P G_{j+1}^T = F_j (G_j P G_j^T) F_j^T + B_j P_j B_j^T and
  // G_{j+1} P H^T = F_j (G_j P H^T) + B_j P_j H_j^T. O(n), not O(n^2).
  Eigen::Matrix3d prior = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d g_p_ht = Eigen::Matrix3d::Zero();
  for (int j = 1; j < n; ++j) {
    const Eigen::Matrix3d f = composeJacobianFirst(poses[j - 1], d[j - 1]);
    const Eigen::Matrix3d b = composeJacobianSecond(poses[j - 1]);
    prior = (f * prior * f.transpose() + b * p[j - 1] * b.transpose()).eval();
    g_p_ht = (f * g_p_ht + b * p_ht[j - 1]).eval();
    const Eigen::Matrix3d cov = prior - g_p_ht * s_inv * g_p_ht.transpose();
    Pose2 mean = poses[j];
    mean.z() = wrapAngle(mean.z());
    path.means.push_back(mean);
    path.covariances.push_back(0.5 * (cov + cov.transpose()));
  }
  return path;
}

}  // namespace core
}  // namespace rbpf_slam

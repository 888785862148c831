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

/// Poses along the chain and, for each pose j, its Jacobian blocks d pose_j / d d_k (k < j;
/// blocks[j][k]), O(n^2) 3x3 blocks in all.
void chain(const Pose2& start, const std::vector<Pose2>& d, std::vector<Pose2>* poses,
           std::vector<std::vector<Eigen::Matrix3d>>* blocks) {
  const int n = static_cast<int>(d.size());
  poses->assign(1, start);
  blocks->assign(1, {});
  for (int k = 0; k < n; ++k) {
    const Pose2& previous = poses->back();
    const Eigen::Matrix3d f = composeJacobianFirst(previous, d[k]);
    std::vector<Eigen::Matrix3d> next_blocks(k + 1);
    for (int m = 0; m < k; ++m) next_blocks[m] = f * (*blocks)[k][m];
    next_blocks[k] = composeJacobianSecond(previous);
    Pose2 next = compose(previous, d[k]);
    next.z() = previous.z() + d[k].z();  // unwrapped along the chain, wrapped on output
    poses->push_back(next);
    blocks->push_back(std::move(next_blocks));
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
  const std::vector<Eigen::Matrix3d>& p = increment_covariances;  // block-diagonal prior
  // Iterated EKF with the end pose as a noise-free measurement h(d) of the chain's last pose:
  // d_{i+1} = prior + K (r(d_i) + H (d_i - prior)), K = P H^T S^-1, S = H P H^T. P is
  // block-diagonal, so every product is taken block by block (O(n) per iteration).
  IntermediatePath path;
  std::vector<Pose2> d = increments;
  std::vector<Pose2> poses;
  std::vector<std::vector<Eigen::Matrix3d>> blocks;
  std::vector<Eigen::Matrix3d> p_ht(n);  // P_k H_k^T
  Eigen::Matrix3d s_inv = Eigen::Matrix3d::Identity();
  for (int iteration = 0; iteration < std::max(1, max_iterations); ++iteration) {
    chain(start, d, &poses, &blocks);
    const std::vector<Eigen::Matrix3d>& h = blocks.back();
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
  chain(start, d, &poses, &blocks);
  // Covariance of pose j: G_j P G_j^T - (G_j P H^T) S^-1 (G_j P H^T)^T, with G_j = blocks[j]
  // (P H^T from the last linearisation).
  for (int j = 1; j < n; ++j) {
    Eigen::Matrix3d prior = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d g_p_ht = Eigen::Matrix3d::Zero();
    for (int k = 0; k < j; ++k) {
      prior += blocks[j][k] * p[k] * blocks[j][k].transpose();
      g_p_ht += blocks[j][k] * p_ht[k];
    }
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

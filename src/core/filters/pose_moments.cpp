#include "rbpf_slam/core/filters/pose_moments.h"

#include <cmath>

namespace rbpf_slam {
namespace core {

PoseEstimate poseMoments(const std::vector<Pose2>& poses, const std::vector<double>& weights) {
  PoseEstimate e;
  double x = 0.0, y = 0.0, c = 0.0, s = 0.0;
  for (size_t i = 0; i < poses.size(); ++i) {
    x += weights[i] * poses[i].x();
    y += weights[i] * poses[i].y();
    c += weights[i] * std::cos(poses[i].z());
    s += weights[i] * std::sin(poses[i].z());
  }
  e.mean = Pose2(x, y, std::atan2(s, c));
  e.covariance.setZero();
  for (size_t i = 0; i < poses.size(); ++i) {
    Pose2 d = poses[i] - e.mean;
    d.z() = wrapAngle(d.z());
    e.covariance += weights[i] * d * d.transpose();
  }
  return e;
}

PoseEstimate mixtureMoments(const std::vector<Pose2>& means,
                            const std::vector<Eigen::Matrix3d>& covariances,
                            const std::vector<double>& weights) {
  PoseEstimate e = poseMoments(means, weights);
  for (size_t i = 0; i < means.size(); ++i) e.covariance += weights[i] * covariances[i];
  return e;
}

}  // namespace core
}  // namespace rbpf_slam

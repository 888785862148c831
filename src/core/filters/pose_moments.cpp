#include "rbpf_slam/core/filters/pose_moments.h"

#include <cmath>

namespace rbpf_slam {
namespace core {

PoseEstimate poseMoments(const std::vector<Pose2>& poses, const std::vector<double>& weights) {
  return poseMomentsOf(weights, [&](size_t i) -> const Pose2& { return poses[i]; });
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

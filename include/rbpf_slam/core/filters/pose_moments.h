#pragma once
// Moments of weighted pose sets, for every filter's estimate(): one circular mean for the
// heading and one covariance rule, so that the variants report their clouds alike.

#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace core {

/// Weighted mean (circular mean for the heading) and covariance of poses, the heading
/// differences wrapped. The weights must sum to 1; an empty set gives the zero pose and a zero
/// covariance.
PoseEstimate poseMoments(const std::vector<Pose2>& poses, const std::vector<double>& weights);

/// Moments of the Gaussian mixture sum_j w_j N(means_j, covariances_j): poseMoments of the
/// means plus the weighted component covariances.
PoseEstimate mixtureMoments(const std::vector<Pose2>& means,
                            const std::vector<Eigen::Matrix3d>& covariances,
                            const std::vector<double>& weights);

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Moments of weighted pose sets, for every filter's estimate(): one circular mean for the
// heading and one covariance rule, so that the variants report their clouds alike.

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace core {

/// Weighted mean of the poses pose_at(i), i < weights.size(): circular mean for the heading
/// (poses held inside other records need no copy). The weights must sum to 1; an empty set
/// gives the zero pose.
template <typename PoseAt>
Pose2 poseMeanOf(const std::vector<double>& weights, PoseAt pose_at) {
  double x = 0.0, y = 0.0, c = 0.0, s = 0.0;
  for (size_t i = 0; i < weights.size(); ++i) {
    const Pose2& p = pose_at(i);
    x += weights[i] * p.x();
    y += weights[i] * p.y();
    c += weights[i] * std::cos(p.z());
    s += weights[i] * std::sin(p.z());
  }
  return Pose2(x, y, std::atan2(s, c));
}

/// Weighted second moment of the poses pose_at(i) about the pose about, the heading
/// differences wrapped: their covariance when about is their mean (poseMeanOf).
template <typename PoseAt>
Eigen::Matrix3d poseSecondMomentOf(const std::vector<double>& weights, PoseAt pose_at,
                                   const Pose2& about) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < weights.size(); ++i) {
    Pose2 d = pose_at(i) - about;
    d.z() = wrapAngle(d.z());
    m += weights[i] * d * d.transpose();
  }
  return m;
}

/// Weighted mean (poseMeanOf) and covariance (poseSecondMomentOf about it) of the poses
/// pose_at(i); an empty set gives the zero pose and a zero covariance.
template <typename PoseAt>
PoseEstimate poseMomentsOf(const std::vector<double>& weights, PoseAt pose_at) {
  PoseEstimate e;
  e.mean = poseMeanOf(weights, pose_at);
  e.covariance = poseSecondMomentOf(weights, pose_at, e.mean);
  return e;
}

/// poseMomentsOf a vector of poses (as many as weights).
PoseEstimate poseMoments(const std::vector<Pose2>& poses, const std::vector<double>& weights);

/// The clusters of a pose cloud, much as amcl forms them to choose the pose it reports (amcl:
/// fixed 0.5 m x 10 deg cells, not joined across +-180 deg): poses binned into cells of cell_m x
/// cell_m x cell_rad (heading wrapped), cells that touch (the 26 neighbours) in one cluster.
/// Returns each pose's cluster (0, 1, ...; -1 for a non-finite pose) and the number of clusters in
/// *count.
std::vector<int> poseClusters(const std::vector<Pose2>& poses, double cell_m, double cell_rad,
                              int* count);

/// The pose to report from a cloud that may hold several hypotheses (global localization): when
/// one cluster (poseClusters) holds more than half the weight, its weighted mean, with the
/// whole cloud's second moment about that mean as the covariance (heading differences
/// wrapped), so that a spread cloud still reports its spread; else (one cluster, or no place
/// standing out) exactly poseMoments: the mean of the whole cloud. The weights must sum to 1
/// (one per pose, else std::invalid_argument); a weight <= 0 counts for no cluster.
PoseEstimate heaviestClusterMoments(const std::vector<Pose2>& poses,
                                    const std::vector<double>& weights, double cell_m,
                                    double cell_rad);

/// Moments of the Gaussian mixture sum_j w_j N(means_j, covariances_j): poseMoments of the
/// means plus the weighted component covariances.
PoseEstimate mixtureMoments(const std::vector<Pose2>& means,
                            const std::vector<Eigen::Matrix3d>& covariances,
                            const std::vector<double>& weights);

}  // namespace core
}  // namespace rbpf_slam

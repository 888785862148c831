#pragma once
// Rigid alignment of planar point sets and paths: used by the evaluation (ATE after alignment)
// and by the choices among ensemble members (how far apart two members' paths are).

#include <Eigen/Core>
#include <vector>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

/// The rigid transform T = (x, y, theta) minimising sum_i |T(source_i) - target_i|^2 (Umeyama
/// 1991 / Horn 1987 without scale, in closed form for the plane). Throws std::invalid_argument
/// when the sizes differ or both are empty.
Pose2 alignRigid2D(const std::vector<Eigen::Vector2d>& source,
                   const std::vector<Eigen::Vector2d>& target);

/// Root mean square distance between the positions of two paths of equal length, pose i with
/// pose i, after a is rigidly aligned onto b (the ATE of a against b as the reference). Throws
/// std::invalid_argument when the lengths differ or both are empty.
double alignedRmsDistance(const std::vector<Pose2>& a, const std::vector<Pose2>& b);

/// For each of several paths of equal length, the median of its alignedRmsDistance to each of
/// the others (each pair aligned once: the distance is symmetric). How far a path is from
/// where the others agree. Needs at least two paths; throws std::invalid_argument like
/// alignedRmsDistance.
std::vector<double> medianDistancesToOthers(const std::vector<std::vector<Pose2>>& paths);

/// The path itself when it holds at most max_poses poses, else max_poses of its poses evenly
/// spaced from the first to the last: indices floor(i (size - 1) / (max_poses - 1)), i = 0 ..
/// max_poses - 1 (the last pose alone for max_poses 1). Equally long paths keep the same
/// indices, so they stay comparable pose by pose. Bounds the cost of aligning paths that grow
/// with the run. Throws std::invalid_argument for max_poses < 1.
std::vector<Pose2> evenlySpacedPoses(const std::vector<Pose2>& path, size_t max_poses);

}  // namespace core
}  // namespace rbpf_slam

#include "rbpf_slam/core/alignment.h"

#include <cmath>
#include <stdexcept>
#include <utility>

#include "rbpf_slam/core/statistics.h"

namespace rbpf_slam {
namespace core {

Pose2 alignRigid2D(const std::vector<Eigen::Vector2d>& source,
                   const std::vector<Eigen::Vector2d>& target) {
  if (source.size() != target.size() || source.empty()) {
    throw std::invalid_argument("alignRigid2D needs two equally long, non-empty point sets");
  }
  Eigen::Vector2d source_mean = Eigen::Vector2d::Zero();
  Eigen::Vector2d target_mean = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < source.size(); ++i) {
    source_mean += source[i];
    target_mean += target[i];
  }
  source_mean /= static_cast<double>(source.size());
  target_mean /= static_cast<double>(target.size());
  // In the plane the optimal rotation maximises sum (c * dot + s * cross) over centred pairs,
  // so theta = atan2(sum cross, sum dot): the 2D case of the SVD solution.
  double dot = 0.0, cross = 0.0;
  for (size_t i = 0; i < source.size(); ++i) {
    const Eigen::Vector2d p = source[i] - source_mean;
    const Eigen::Vector2d q = target[i] - target_mean;
    dot += p.dot(q);
    cross += p.x() * q.y() - p.y() * q.x();
  }
  const double theta = (dot == 0.0 && cross == 0.0) ? 0.0 : std::atan2(cross, dot);
  const Eigen::Vector2d translation =
      target_mean - transformPoint(Pose2(0.0, 0.0, theta), source_mean);
  return Pose2(translation.x(), translation.y(), theta);
}

double alignedRmsDistance(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  if (a.size() != b.size() || a.empty()) {
    throw std::invalid_argument("alignedRmsDistance needs two equally long, non-empty paths");
  }
  std::vector<Eigen::Vector2d> source(a.size()), target(b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    source[i] = a[i].head<2>();
    target[i] = b[i].head<2>();
  }
  const Pose2 t = alignRigid2D(source, target);
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    sum += (transformPoint(t, source[i]) - target[i]).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(a.size()));
}

std::vector<double> medianDistancesToOthers(const std::vector<std::vector<Pose2>>& paths) {
  const size_t n = paths.size();
  if (n < 2) throw std::invalid_argument("medianDistancesToOthers needs two paths or more");
  std::vector<std::vector<double>> to_others(n);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      const double d = alignedRmsDistance(paths[i], paths[j]);
      to_others[i].push_back(d);
      to_others[j].push_back(d);
    }
  }
  std::vector<double> medians;
  for (std::vector<double>& d : to_others) medians.push_back(median(std::move(d)));
  return medians;
}

std::vector<Pose2> evenlySpacedPoses(const std::vector<Pose2>& path, size_t max_poses) {
  if (max_poses < 1) throw std::invalid_argument("evenlySpacedPoses needs max_poses >= 1");
  if (path.size() <= max_poses) return path;
  if (max_poses == 1) return {path.back()};
  std::vector<Pose2> out;
  out.reserve(max_poses);
  const size_t last = path.size() - 1;
  for (size_t i = 0; i < max_poses; ++i) out.push_back(path[i * last / (max_poses - 1)]);
  return out;
}

}  // namespace core
}  // namespace rbpf_slam

#include "rbpf_slam/core/filters/pose_moments.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

namespace rbpf_slam {
namespace core {

PoseEstimate poseMoments(const std::vector<Pose2>& poses, const std::vector<double>& weights) {
  return poseMomentsOf(weights, [&](size_t i) -> const Pose2& { return poses[i]; });
}

std::vector<int> poseClusters(const std::vector<Pose2>& poses, double cell_m, double cell_rad,
                              int* count) {
  const int headings = std::max(1, static_cast<int>(std::ceil(2.0 * M_PI / cell_rad)));
  using Cell = std::array<long, 3>;
  struct CellHash {
    size_t operator()(const Cell& c) const {
      const auto u = [](long v) { return static_cast<std::uint64_t>(v); };  // wraps, no overflow
      return static_cast<size_t>(u(c[0]) * 73856093ULL ^ u(c[1]) * 19349663ULL ^
                                 u(c[2]) * 83492791ULL);
    }
  };
  std::unordered_map<Cell, int, CellHash> cells;  // cell -> its index
  cells.reserve(poses.size());
  std::vector<int> cell_of(poses.size(), -1);
  for (size_t i = 0; i < poses.size(); ++i) {
    const Pose2& p = poses[i];
    if (!p.allFinite() || std::fabs(p.x()) > 1e12 || std::fabs(p.y()) > 1e12) continue;
    const long h = static_cast<long>(std::floor((wrapAngle(p.z()) + M_PI) / cell_rad));
    const Cell c{static_cast<long>(std::floor(p.x() / cell_m)),
                 static_cast<long>(std::floor(p.y() / cell_m)),
                 ((h % headings) + headings) % headings};
    cell_of[i] = cells.emplace(c, static_cast<int>(cells.size())).first->second;
  }
  // Union-find over the cells: each joins its occupied neighbours.
  std::vector<int> parent(cells.size());
  std::iota(parent.begin(), parent.end(), 0);
  const auto root = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const auto& [c, index] : cells) {
    for (long dx = -1; dx <= 1; ++dx) {
      for (long dy = -1; dy <= 1; ++dy) {
        for (long dh = -1; dh <= 1; ++dh) {
          const Cell n{c[0] + dx, c[1] + dy, ((c[2] + dh) % headings + headings) % headings};
          const auto found = cells.find(n);
          if (found != cells.end()) parent[root(found->second)] = root(index);
        }
      }
    }
  }
  std::vector<int> label(cells.size(), -1);
  int clusters = 0;
  for (size_t k = 0; k < cells.size(); ++k) {
    const int r = root(static_cast<int>(k));
    if (label[r] < 0) label[r] = clusters++;
    label[k] = label[r];
  }
  std::vector<int> cluster(poses.size(), -1);
  for (size_t i = 0; i < poses.size(); ++i) {
    if (cell_of[i] >= 0) cluster[i] = label[cell_of[i]];
  }
  if (count) *count = clusters;
  return cluster;
}

PoseEstimate heaviestClusterMoments(const std::vector<Pose2>& poses,
                                    const std::vector<double>& weights, double cell_m,
                                    double cell_rad) {
  if (weights.size() != poses.size()) {
    throw std::invalid_argument("heaviestClusterMoments: one weight per pose");
  }
  const auto pose_at = [&](size_t i) -> const Pose2& { return poses[i]; };
  int count = 0;
  const std::vector<int> cluster = poseClusters(poses, cell_m, cell_rad, &count);
  if (count <= 1) return poseMomentsOf(weights, pose_at);
  const auto counts = [&](size_t i) { return cluster[i] >= 0 && weights[i] > 0.0; };
  std::vector<double> mass(count, 0.0);
  for (size_t i = 0; i < poses.size(); ++i) {
    if (counts(i)) mass[cluster[i]] += weights[i];
  }
  const int best = static_cast<int>(std::max_element(mass.begin(), mass.end()) - mass.begin());
  if (!(mass[best] > 0.5 * std::accumulate(mass.begin(), mass.end(), 0.0))) {
    return poseMomentsOf(weights, pose_at);
  }
  std::vector<double> member_weights(poses.size(), 0.0);
  for (size_t i = 0; i < poses.size(); ++i) {
    if (counts(i) && cluster[i] == best) member_weights[i] = weights[i] / mass[best];
  }
  // The whole cloud's second moment about the reported mean, the heading differences wrapped
  // (the circular mean does not zero their weighted sum, so "covariance + offset^2" would not do).
  PoseEstimate e;
  e.mean = poseMeanOf(member_weights, pose_at);
  e.covariance = poseSecondMomentOf(weights, pose_at, e.mean);
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

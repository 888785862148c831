#pragma once
// A synthetic room for the unit tests of the landmark filters: known walls and posts observed
// from a pose as (rho, theta) lines with their visible extents and (range, bearing) points.

#include <cmath>
#include <utility>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {

/// The infinite line through a and b in normal form (rho >= 0, normal angle), in their frame.
inline Eigen::Vector2d lineThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = (b - a).normalized();
  Eigen::Vector2d n(-d.y(), d.x());
  double rho = n.dot(a);
  if (rho < 0) {
    rho = -rho;
    n = -n;
  }
  return Eigen::Vector2d(rho, std::atan2(n.y(), n.x()));
}

/// A rectangular room with posts, observed as infinite walls with visible extents and points.
struct SyntheticWorld {
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls{
      {{-5, -4}, {5, -4}}, {{5, -4}, {5, 4}}, {{5, 4}, {-5, 4}}, {{-5, 4}, {-5, -4}},
      {{-1, -1.5}, {1, -1.5}}, {{1, 1.5}, {-1, 1.5}}};
  std::vector<Eigen::Vector2d> posts{{-3, -2}, {3, -2}, {3, 2}, {-3, 2}, {0, 3}, {0, -3}};

  FeatureSet observe(const Pose2& pose, Rng& rng, double sigma_rho, double sigma_theta) const {
    FeatureSet set;
    const Pose2 inv = inverse(pose);
    for (const auto& [a, b] : walls) {
      const Eigen::Vector2d ra = transformPoint(inv, a), rb = transformPoint(inv, b);
      const Eigen::Vector2d line = lineThrough(ra, rb);
      LineFeature f;
      f.rho = line.x() + sampleGaussian(rng, sigma_rho);
      f.theta = wrapAngle(line.y() + sampleGaussian(rng, sigma_theta));
      f.covariance = Eigen::Vector2d(sigma_rho * sigma_rho, sigma_theta * sigma_theta).asDiagonal();
      f.start = ra;
      f.end = rb;
      set.lines.push_back(f);
    }
    for (const auto& post : posts) {
      const Eigen::Vector2d r = transformPoint(inv, post);
      if (r.norm() > 6.0) continue;
      PointFeature f;
      f.range = r.norm() + sampleGaussian(rng, 0.05);
      f.bearing = std::atan2(r.y(), r.x()) + sampleGaussian(rng, 0.02);
      f.covariance = Eigen::Vector2d(0.05 * 0.05, 0.02 * 0.02).asDiagonal();
      set.points.push_back(f);
    }
    return set;
  }
};

}  // namespace core
}  // namespace rbpf_slam

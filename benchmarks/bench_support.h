#pragma once
// Pieces the benchmarks share: the process's resident set, and FastSLAM 2.0 over a prebuilt
// grid of point landmarks (the map and particle-count benchmarks).

#include <cmath>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/filters/fastslam2.h"

namespace rbpf_slam {
namespace bench {

/// Resident set size ("VmRSS") or its peak ("VmHWM") of this process, MB (NaN if unknown).
inline double residentMb(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(field + ":", 0) == 0) return std::stod(line.substr(field.size() + 1)) / 1024.0;
  }
  return NAN;
}

/// Point-landmark options with tight, fixed measurement noise, so that grid landmarks far
/// apart compared with it stay distinct; the motion floors are the caller's.
inline core::FilterOptions pointLandmarkOptions(int particles, double min_sigma_xy_m,
                                                double min_sigma_theta_rad) {
  core::FilterOptions o;
  o.particles = particles;
  o.seed = 1;
  o.use_lines = false;
  o.measurement.use_feature_covariance = false;
  o.measurement.sigma_range_m = 0.02;
  o.measurement.sigma_bearing_rad = 0.002;
  o.motion.min_sigma_xy_m = min_sigma_xy_m;
  o.motion.min_sigma_theta_rad = min_sigma_theta_rad;
  return o;
}

/// FastSlam2 whose particles can all be given one prebuilt map (shared, path-copied on
/// write, exactly as after resampling).
class PrebuiltMapFastSlam2 : public core::FastSlam2 {
 public:
  using core::FastSlam2::FastSlam2;
  void shareMap(const std::shared_ptr<core::LandmarkMap>& map) {
    for (core::Particle& p : particles_) p.map = map;
  }
};

/// `count` positions on a square grid of the given spacing centred near the origin (offset by
/// (0.3, 0.7) m so that no landmark sits on an axis), row by row.
inline std::vector<Eigen::Vector2d> landmarkGrid(int count, double spacing_m) {
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count))));
  std::vector<Eigen::Vector2d> positions;
  for (int i = 0; i < side && static_cast<int>(positions.size()) < count; ++i) {
    for (int j = 0; j < side && static_cast<int>(positions.size()) < count; ++j) {
      positions.emplace_back((i - 0.5 * (side - 1)) * spacing_m + 0.3,
                             (j - 0.5 * (side - 1)) * spacing_m + 0.7);
    }
  }
  return positions;
}

}  // namespace bench
}  // namespace rbpf_slam

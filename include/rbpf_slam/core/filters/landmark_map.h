#pragma once
// A particle's landmark map, shared copy-on-write: resampling copies one pointer, and a
// write copies only the pointer table and the one landmark that changes.

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace core {

/// One landmark's 2D EKF: point (x, y) or line (rho, alpha) in the map frame.
struct Landmark {
  int id = -1;
  LandmarkType type = LandmarkType::kPoint;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  double extent_min = 0.0;  // line: observed extent as positions along the line direction
  double extent_max = 0.0;
  int observations = 1;
  int last_seen_step = 0;
  int created_step = 0;
  int existence = 1;  // existence counter (landmark_existence.h)
};

/// The landmarks of one particle. Value semantics through shared, immutable landmarks.
class LandmarkMap {
 public:
  int size() const { return static_cast<int>(landmarks_.size()); }
  const Landmark& operator[](int i) const { return *landmarks_[i]; }
  /// Replaces landmark i; only this map sees the change.
  void set(int i, const Landmark& landmark) { landmarks_[i] = std::make_shared<const Landmark>(landmark); }
  void add(const Landmark& landmark) { landmarks_.push_back(std::make_shared<const Landmark>(landmark)); }
  void remove(int i) { landmarks_.erase(landmarks_.begin() + i); }

 private:
  std::vector<std::shared_ptr<const Landmark>> landmarks_;
};

/// Writable access to a map that may be shared: copies the table on first write.
inline LandmarkMap& mutableMap(std::shared_ptr<LandmarkMap>* map) {
  if (!*map) {
    *map = std::make_shared<LandmarkMap>();
  } else if (map->use_count() > 1) {
    *map = std::make_shared<LandmarkMap>(**map);
  }
  return **map;
}

/// Position of point p along the direction of line (rho, alpha).
inline double alongLine(const Eigen::Vector2d& line, const Eigen::Vector2d& p) {
  return -std::sin(line.y()) * p.x() + std::cos(line.y()) * p.y();
}

/// The point of line (rho, alpha) at position s along its direction.
inline Eigen::Vector2d pointOnLine(const Eigen::Vector2d& line, double s) {
  const double c = std::cos(line.y()), si = std::sin(line.y());
  return Eigen::Vector2d(line.x() * c - s * si, line.x() * si + s * c);
}

/// Converts a landmark to the interface's estimate (line extent as end points).
LandmarkEstimate toEstimate(const Landmark& landmark);

}  // namespace core
}  // namespace rbpf_slam

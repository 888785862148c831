#pragma once
// Ray casting against the simulated world's wall segments and landmark posts.

#include <Eigen/Core>
#include <limits>
#include <vector>

#include "rbpf_slam/core/sim/world.h"

namespace rbpf_slam {
namespace core {
namespace sim {

/// A landmark post seen by range sensors.
struct Circle {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius_m = 0.0;
};

/// The first surface a ray meets, and the angle between the ray and that surface's normal.
struct RayHit {
  double range_m = std::numeric_limits<double>::infinity();  // inf: nothing within reach
  double incidence_rad = 0.0;                                // 0 = head-on, pi/2 = grazing
  bool hit() const { return range_m < std::numeric_limits<double>::infinity(); }
};

/// Finds the nearest intersection of a ray with a set of segments and circles.
class RayCaster {
 public:
  RayCaster() = default;
  RayCaster(std::vector<Segment> segments, std::vector<Circle> circles);

  /// The nearest hit along direction angle_rad from origin, up to max_range_m.
  RayHit cast(const Eigen::Vector2d& origin, double angle_rad, double max_range_m) const;
  /// True when nothing blocks the straight line from origin to target, except within
  /// tolerance_m of the target.
  bool clearLine(const Eigen::Vector2d& origin, const Eigen::Vector2d& target,
                 double tolerance_m) const;
  /// A caster holding only the geometry within radius_m of center (cheaper for one reading).
  RayCaster nearby(const Eigen::Vector2d& center, double radius_m) const;

  /// Distinct segment end points (corners and edges, which echo at any incidence).
  const std::vector<Eigen::Vector2d>& vertices() const { return vertices_; }
  const std::vector<Segment>& segments() const { return segments_; }
  const std::vector<Circle>& circles() const { return circles_; }

 private:
  std::vector<Segment> segments_;
  std::vector<Circle> circles_;
  std::vector<Eigen::Vector2d> vertices_;
};

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

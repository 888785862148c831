#include "rbpf_slam/core/sim/ray_caster.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam {
namespace core {
namespace sim {
namespace {

double cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
  return u.x() * v.y() - u.y() * v.x();
}

bool containsPoint(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& p) {
  return std::any_of(points.begin(), points.end(),
                     [&p](const Eigen::Vector2d& q) { return (q - p).squaredNorm() < 1e-18; });
}

}  // namespace

RayCaster::RayCaster(std::vector<Segment> segments, std::vector<Circle> circles)
    : segments_(std::move(segments)), circles_(std::move(circles)) {
  for (const Segment& s : segments_) {
    if (!containsPoint(vertices_, s.a)) vertices_.push_back(s.a);
    if (!containsPoint(vertices_, s.b)) vertices_.push_back(s.b);
  }
}

RayHit RayCaster::cast(const Eigen::Vector2d& origin, double angle_rad, double max_range_m) const {
  const Eigen::Vector2d d(std::cos(angle_rad), std::sin(angle_rad));
  RayHit best;
  for (const Segment& s : segments_) {
    const Eigen::Vector2d e = s.b - s.a;
    const double denominator = cross(d, e);
    if (std::abs(denominator) < 1e-12) continue;  // parallel rays graze, never reflect
    const Eigen::Vector2d w = s.a - origin;
    const double t = cross(w, e) / denominator;
    const double u = cross(w, d) / denominator;
    if (t < 0.0 || t > max_range_m || t >= best.range_m || u < 0.0 || u > 1.0) continue;
    best.range_m = t;
    // |sin| of the angle between the ray and the wall is |cos| of the incidence angle.
    best.incidence_rad = std::acos(std::min(1.0, std::abs(denominator) / e.norm()));
  }
  for (const Circle& c : circles_) {
    const Eigen::Vector2d m = origin - c.center;
    const double b = m.dot(d);
    const double k = m.squaredNorm() - c.radius_m * c.radius_m;
    if (k <= 0.0) continue;  // the origin is inside the post
    const double discriminant = b * b - k;
    if (discriminant < 0.0) continue;
    const double t = -b - std::sqrt(discriminant);
    if (t < 0.0 || t > max_range_m || t >= best.range_m) continue;
    const Eigen::Vector2d normal = (m + t * d) / c.radius_m;
    best.range_m = t;
    best.incidence_rad = std::acos(std::min(1.0, std::abs(normal.dot(d))));
  }
  return best;
}

bool RayCaster::clearLine(const Eigen::Vector2d& origin, const Eigen::Vector2d& target,
                          double tolerance_m) const {
  const Eigen::Vector2d delta = target - origin;
  const double distance = delta.norm();
  if (distance <= tolerance_m) return true;
  const RayHit hit = cast(origin, std::atan2(delta.y(), delta.x()), distance - tolerance_m);
  return !hit.hit();
}

RayCaster RayCaster::nearby(const Eigen::Vector2d& center, double radius_m) const {
  std::vector<Segment> segments;
  for (const Segment& s : segments_) {
    if (distanceToSegment(center, s.a, s.b) <= radius_m) segments.push_back(s);
  }
  std::vector<Circle> circles;
  for (const Circle& c : circles_) {
    if ((c.center - center).norm() - c.radius_m <= radius_m) circles.push_back(c);
  }
  return RayCaster(std::move(segments), std::move(circles));
}

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

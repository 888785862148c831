#include "rbpf_slam/core/sim/sensor_models.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rbpf_slam {
namespace core {
namespace sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

Pose2 laserMountPose(const LaserConfig& config) {
  return Pose2(config.mount_x_m, config.mount_y_m, wrapAngle(config.mount_yaw_deg * kDegToRad));
}

RangeScan simulateLaserScan(const LaserConfig& config, const RayCaster& caster,
                            const Pose2& base_pose, Rng* rng) {
  RangeScan scan;
  const double fov = config.fov_deg * kDegToRad;
  const double increment = config.resolution_deg * kDegToRad;
  const bool full_circle = config.fov_deg >= 360.0 - 1e-9;
  const int beams = static_cast<int>(std::round(fov / increment)) + (full_circle ? 0 : 1);
  scan.angle_min = -0.5 * fov;
  scan.angle_increment = increment;
  scan.range_min = config.min_range_m;
  scan.range_max = config.max_range_m;
  scan.sensor_pose = laserMountPose(config);
  scan.ranges.resize(beams);

  const Pose2 sensor = compose(base_pose, scan.sensor_pose);
  const RayCaster local = caster.nearby(sensor.head<2>(), config.max_range_m);
  for (int i = 0; i < beams; ++i) {
    const double angle = sensor.z() + scan.angle_min + i * increment;
    const RayHit hit = local.cast(sensor.head<2>(), angle, config.max_range_m);
    double range = hit.range_m;
    if (hit.hit() && rng) range += sampleGaussian(*rng, config.range_noise_m);
    if (range > config.max_range_m) range = kInf;
    scan.ranges[i] = static_cast<float>(std::max(range, config.min_range_m));
  }
  return scan;
}

double simulateConeRange(const RingSensorConfig& config, const RayCaster& caster,
                         const Pose2& sensor_pose, Rng* rng) {
  const Eigen::Vector2d origin = sensor_pose.head<2>();
  const RayCaster local = caster.nearby(origin, config.max_range_m);
  const double half_cone = 0.5 * config.cone_deg * kDegToRad;
  const double critical = config.critical_angle_deg * kDegToRad;
  const int rays = 1 + static_cast<int>(std::ceil(config.cone_deg / config.ray_spacing_deg));
  double nearest = kInf;
  for (int i = 0; i < rays; ++i) {
    const double offset = rays == 1 ? 0.0 : -half_cone + 2.0 * half_cone * i / (rays - 1);
    const RayHit hit = local.cast(origin, sensor_pose.z() + offset, config.max_range_m);
    // A surface met beyond the critical angle reflects the pulse away (specular): no echo.
    if (hit.hit() && hit.incidence_rad <= critical) nearest = std::min(nearest, hit.range_m);
  }
  if (config.corner_echoes) {
    for (const Eigen::Vector2d& vertex : local.vertices()) {
      const Eigen::Vector2d d = vertex - origin;
      const double distance = d.norm();
      if (distance >= nearest || distance > config.max_range_m) continue;
      if (std::abs(wrapAngle(std::atan2(d.y(), d.x()) - sensor_pose.z())) > half_cone) continue;
      if (local.clearLine(origin, vertex, 1e-3)) nearest = distance;
    }
  }
  if (nearest > config.max_range_m) return config.max_range_m;
  if (rng) nearest += sampleGaussian(*rng, config.range_noise_m);
  return std::clamp(nearest, config.min_range_m, config.max_range_m);
}

FeatureSet observeLandmarks(const RangeBearingConfig& config,
                            const std::vector<Landmark>& landmarks, const RayCaster& caster,
                            const Pose2& base_pose, Rng* rng) {
  FeatureSet features;
  const double half_fov = 0.5 * config.fov_deg * kDegToRad;
  const double sigma_bearing = config.bearing_noise_deg * kDegToRad;
  for (const Landmark& landmark : landmarks) {
    const Eigen::Vector2d d = landmark.position - base_pose.head<2>();
    const double range = d.norm();
    const double bearing = wrapAngle(std::atan2(d.y(), d.x()) - base_pose.z());
    if (range < config.min_range_m || range > config.max_range_m) continue;
    if (std::abs(bearing) > half_fov) continue;
    if (config.occlusion &&
        !caster.clearLine(base_pose.head<2>(), landmark.position, landmark.radius_m + 1e-6)) {
      continue;
    }
    if (rng && config.detection_probability < 1.0 &&
        sampleUniform(*rng) >= config.detection_probability) {
      continue;
    }
    PointFeature point;
    point.range = range;
    point.bearing = bearing;
    if (rng) {
      point.range = std::max(0.0, range + sampleGaussian(*rng, config.range_noise_m));
      point.bearing = wrapAngle(bearing + sampleGaussian(*rng, sigma_bearing));
    }
    point.covariance =
        Eigen::Vector2d(config.range_noise_m * config.range_noise_m, sigma_bearing * sigma_bearing)
            .asDiagonal();
    point.id = config.known_ids ? landmark.id : -1;
    features.points.push_back(point);
  }
  return features;
}

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

#include "rbpf_slam/core/filters/observation.h"

#include <Eigen/Dense>
#include <cmath>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

bool usableLine(const LineFeature& line) {
  return std::isfinite(line.rho) && std::isfinite(line.theta) && line.start.allFinite() &&
         line.end.allFinite();
}

bool usablePoint(const PointFeature& point) {
  return std::isfinite(point.range) && std::isfinite(point.bearing) && point.range > 0.0;
}

bool finitePositiveDefinite(const Eigen::Matrix2d& c) {
  return c.allFinite() && c(0, 0) > 0.0 && c(1, 1) > 0.0 && c.determinant() > 0.0;
}

Eigen::Matrix2d observationNoise(const Eigen::Matrix2d& given, double sigma_a, double sigma_b,
                                 const MeasurementOptions& options) {
  const Eigen::Matrix2d floor = Eigen::Vector2d(sigma_a * sigma_a, sigma_b * sigma_b).asDiagonal();
  const Eigen::Matrix2d symmetric = 0.5 * (given + given.transpose());
  if (options.use_feature_covariance && finitePositiveDefinite(symmetric)) {
    return Eigen::Matrix2d(symmetric * options.covariance_inflation + floor);
  }
  return floor;
}

std::vector<Observation> prepareObservations(const FeatureSet& features,
                                             const FilterOptions& options, int* rejected) {
  std::vector<Observation> out;
  const MeasurementOptions& m = options.measurement;
  forEachUsableFeature(
      features, options.use_lines, options.use_points, rejected,
      [&](const LineFeature& line) {
        Observation o;
        o.type = LandmarkType::kLine;
        double rho = line.rho, theta = line.theta;
        normalizeLine(rho, theta);
        o.z << rho, theta;
        o.noise = observationNoise(line.covariance, m.sigma_rho_m, m.sigma_theta_rad, m);
        o.start = line.start;
        o.end = line.end;
        out.push_back(o);
      },
      [&](const PointFeature& point) {
        Observation o;
        o.type = LandmarkType::kPoint;
        o.z << point.range, wrapAngle(point.bearing);
        o.noise = observationNoise(point.covariance, m.sigma_range_m, m.sigma_bearing_rad, m);
        o.known_id = point.id;
        out.push_back(o);
      });
  return out;
}

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Features as every landmark filter takes them: which features are usable (finite, a point at
// a positive range), the noise a feature is given (its own covariance plus the configured
// floors), and the prepared observations of the FastSLAM family.

#include <Eigen/Core>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/filters/slam_filter.h"  // LandmarkType

namespace rbpf_slam {
namespace core {

/// One observation prepared for the filter: value, noise, type, and extent if a line.
struct Observation {
  LandmarkType type = LandmarkType::kPoint;
  Eigen::Vector2d z = Eigen::Vector2d::Zero();  // (range, bearing) or (rho, theta)
  Eigen::Matrix2d noise = Eigen::Matrix2d::Identity();
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // line extent, base frame
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  int known_id = -1;
};

/// A line with finite (rho, theta) and extent.
bool usableLine(const LineFeature& line);
/// A point with finite range and bearing and a positive range.
bool usablePoint(const PointFeature& point);

/// Calls on_line for each usable line (when use_lines) and on_point for each usable point (when
/// use_points), in the order given; sets *rejected to the number of unusable ones among those.
template <class OnLine, class OnPoint>
void forEachUsableFeature(const FeatureSet& features, bool use_lines, bool use_points,
                          int* rejected, OnLine on_line, OnPoint on_point) {
  *rejected = 0;
  if (use_lines) {
    for (const LineFeature& line : features.lines) {
      if (usableLine(line)) {
        on_line(line);
      } else {
        ++*rejected;
      }
    }
  }
  if (use_points) {
    for (const PointFeature& point : features.points) {
      if (usablePoint(point)) {
        on_point(point);
      } else {
        ++*rejected;
      }
    }
  }
}

/// A covariance that is finite and positive definite (what a noise or an innovation needs).
bool finitePositiveDefinite(const Eigen::Matrix2d& c);

/// The noise of a feature: its own covariance (symmetrised, times covariance_inflation) plus
/// the floors diag(sigma_a^2, sigma_b^2) when use_feature_covariance and the covariance is a
/// finite positive definite one; the floors alone otherwise.
Eigen::Matrix2d observationNoise(const Eigen::Matrix2d& given, double sigma_a, double sigma_b,
                                 const MeasurementOptions& options);

/// Feature set -> observations with the noise of options.measurement, lines only if
/// options.use_lines, points only if options.use_points (a point's id becomes known_id);
/// unusable features are left out and counted in *rejected.
std::vector<Observation> prepareObservations(const FeatureSet& features,
                                             const FilterOptions& options, int* rejected);

}  // namespace core
}  // namespace rbpf_slam

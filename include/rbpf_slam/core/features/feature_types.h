#pragma once
// Landmark observations in the robot's base frame, as extracted from laser or sonar.

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

/// A point landmark seen at (range, bearing) from the base frame origin.
struct PointFeature {
  double range = 0.0;    // m
  double bearing = 0.0;  // rad, counter-clockwise from the base x axis
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  // over (range, bearing)
  int id = -1;           // known identity, or -1 when association is the filter's job
};

/// An infinite line in normal form (rho >= 0, theta = normal direction), seen as a segment.
struct LineFeature {
  double rho = 0.0;    // m
  double theta = 0.0;  // rad
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  // over (rho, theta)
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // observed extent, base frame
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
};

/// One 2D range scan (laser), with the sensor's mounting pose in the base frame.
struct RangeScan {
  double stamp = 0.0;             // s
  double angle_min = 0.0;         // rad
  double angle_increment = 0.0;   // rad, may be negative for reversed scans
  double range_min = 0.0;         // m
  double range_max = 0.0;         // m
  std::vector<float> ranges;      // m; NaN, inf and out-of-range values mean "no return"
  Pose2 sensor_pose = Pose2::Zero();  // sensor in base frame
};

/// False for a sensor pose in the base frame that is not finite or more than a kilometre from
/// the base: a broken transform, not a robot (its points would overflow the grids' indices).
inline bool plausibleSensorMount(const Pose2& sensor_pose) {
  constexpr double kMaxMountDistanceM = 1000.0;
  return sensor_pose.allFinite() && sensor_pose.head<2>().norm() <= kMaxMountDistanceM;
}

/// One cone-sensor reading (sonar, infrared), with the transducer pose in the base frame.
struct ConeReading {
  double stamp = 0.0;
  double range = 0.0;            // m
  double min_range = 0.0;        // m
  double max_range = 0.0;        // m; a reading at or above it is "no echo"
  double field_of_view = 0.0;    // rad, full cone angle
  Pose2 sensor_pose = Pose2::Zero();
};

/// Everything observed at one instant, in the base frame.
struct FeatureSet {
  double stamp = 0.0;
  std::vector<PointFeature> points;
  std::vector<LineFeature> lines;
  /// Raw data for variants that use it (grid maps); may be null.
  std::shared_ptr<const RangeScan> scan;
  std::vector<ConeReading> cones;

  bool empty() const { return points.empty() && lines.empty() && !scan && cones.empty(); }
};

/// Brings a line into normal form: rho >= 0 and theta wrapped to [-pi, pi).
inline void normalizeLine(double& rho, double& theta) {
  if (rho < 0.0) {
    rho = -rho;
    theta += M_PI;
  }
  theta = wrapAngle(theta);
}

}  // namespace core
}  // namespace rbpf_slam

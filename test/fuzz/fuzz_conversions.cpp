// libFuzzer target: ROS messages with arbitrary field values (NaN, inf, huge, negative, empty,
// wrong counts) through the message conversions the node uses (LaserScan, Range, PointCloud,
// FeatureArray, tf), then the laser extractor. Findings: crashes, sanitizer reports, and
// anything non-finite let through to the core.

#include <cmath>
#include <string>
#include <vector>

#include "fuzz_common.h"
#include "rbpf_slam/core/features/laser_line_extractor.h"
#include "rbpf_slam/core/features/sonar_feature_extractor.h"
#include "rbpf_slam/ros/conversions.h"

using namespace rbpf_slam;

namespace {

/// A float that is usually plausible and sometimes raw bytes (NaN, inf, denormals, huge).
float someFloat(fuzz::ByteReader* in, float scale) {
  const uint8_t kind = in->take<uint8_t>();
  if (kind < 200) return static_cast<float>(in->take<int16_t>()) * scale;
  return in->take<float>();
}

double someDouble(fuzz::ByteReader* in, double scale) {
  const uint8_t kind = in->take<uint8_t>();
  if (kind < 200) return static_cast<double>(in->take<int16_t>()) * scale;
  return in->take<double>();
}

core::Pose2 somePose(fuzz::ByteReader* in) {
  geometry_msgs::Transform t;
  t.translation.x = someDouble(in, 0.01);
  t.translation.y = someDouble(in, 0.01);
  t.rotation.z = someDouble(in, 1e-4);
  t.rotation.w = someDouble(in, 1e-4);
  return rosbridge::toPose2(t);  // the pose tf would give, however broken the quaternion
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::ByteReader in(data, size);
  const core::Pose2 mount = somePose(&in);
  if (!mount.allFinite()) return 0;  // the node drops non-finite tf before converting

  sensor_msgs::LaserScan scan;
  scan.header.stamp = ros::Time(1.0);
  scan.angle_min = someFloat(&in, 1e-3f);
  scan.angle_max = someFloat(&in, 1e-3f);
  scan.angle_increment = someFloat(&in, 1e-4f);
  scan.range_min = someFloat(&in, 1e-2f);
  scan.range_max = someFloat(&in, 1e-2f);
  const int beams = in.take<uint16_t>() % 1100;
  for (int i = 0; i < beams && !in.empty(); ++i) scan.ranges.push_back(someFloat(&in, 1e-3f));
  core::RangeScan converted;
  std::string error;
  if (rosbridge::toRangeScan(scan, mount, &converted, &error)) {
    fuzz::require(std::isfinite(converted.angle_min) && std::isfinite(converted.angle_increment) &&
                  converted.angle_increment != 0.0);
    static const core::LaserLineExtractor extractor{core::LaserExtractorOptions()};
    const core::FeatureSet features = extractor.extract(converted);
    for (const auto& l : features.lines) {
      fuzz::require(std::isfinite(l.rho) && l.rho >= 0.0 && std::isfinite(l.theta) &&
                    l.covariance.allFinite());
    }
    for (const auto& p : features.points) {
      fuzz::require(std::isfinite(p.range) && std::isfinite(p.bearing) && p.covariance.allFinite());
    }
  }

  sensor_msgs::Range range;
  range.header.stamp = ros::Time(1.0);
  range.field_of_view = someFloat(&in, 1e-3f);
  range.min_range = someFloat(&in, 1e-2f);
  range.max_range = someFloat(&in, 1e-2f);
  range.range = someFloat(&in, 1e-2f);
  core::ConeReading reading;
  if (rosbridge::toConeReading(range, mount, &reading, &error)) {
    fuzz::require(std::isfinite(reading.field_of_view) && reading.field_of_view > 0.0);
    core::SonarFeatureExtractor sonar{core::SonarExtractorOptions()};
    sonar.addReadings({reading}, core::Pose2::Zero(), 1.0);
  }

  sensor_msgs::PointCloud cloud;
  const int points = in.take<uint8_t>() % 40;
  for (int i = 0; i < points && !in.empty(); ++i) {
    geometry_msgs::Point32 p;
    p.x = someFloat(&in, 1e-2f);
    p.y = someFloat(&in, 1e-2f);
    cloud.points.push_back(p);
  }
  for (const Eigen::Vector2d& p : rosbridge::toBasePoints(cloud, mount)) {
    (void)p;  // may be non-finite: the cone matching below must cope
  }

  FeatureArray array;
  array.header.stamp = ros::Time(1.0);
  const int lines = in.take<uint8_t>() % 20, pts = in.take<uint8_t>() % 20;
  for (int i = 0; i < lines && !in.empty(); ++i) {
    LineFeature l;
    l.rho = someDouble(&in, 1e-2);
    l.theta = someDouble(&in, 1e-3);
    for (double& c : l.covariance) c = someDouble(&in, 1e-4);
    l.start.x = someDouble(&in, 1e-2);
    l.end.y = someDouble(&in, 1e-2);
    array.lines.push_back(l);
  }
  for (int i = 0; i < pts && !in.empty(); ++i) {
    PointFeature p;
    p.range = someDouble(&in, 1e-2);
    p.bearing = someDouble(&in, 1e-3);
    for (double& c : p.covariance) c = someDouble(&in, 1e-4);
    p.id = in.take<int32_t>();
    array.points.push_back(p);
  }
  int dropped = 0;
  const core::FeatureSet set = rosbridge::toFeatureSet(array, mount, &dropped);
  fuzz::require(dropped >= 0 && dropped <= lines + pts);
  for (const auto& l : set.lines) {
    fuzz::require(std::isfinite(l.rho) && l.rho >= 0.0 && std::isfinite(l.theta) &&
                  l.covariance.allFinite() && l.start.allFinite() && l.end.allFinite());
  }
  for (const auto& p : set.points) {
    fuzz::require(std::isfinite(p.range) && p.range >= 0.0 && std::isfinite(p.bearing) &&
                  p.covariance.allFinite());
  }
  return 0;
}

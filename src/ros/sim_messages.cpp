#include "rbpf_slam/ros/sim_messages.h"

#include <cmath>
#include <cstdio>

#include "rbpf_slam/ros/conversions.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

namespace sim = core::sim;
using core::Pose2;

sensor_msgs::LaserScan scanMessage(const core::RangeScan& scan, double rate_hz,
                                   const ros::Time& stamp) {
  sensor_msgs::LaserScan message;
  message.header.stamp = stamp;
  message.header.frame_id = "base_laser_link";
  message.angle_min = scan.angle_min;
  message.angle_increment = scan.angle_increment;
  message.angle_max = scan.angle_min + (scan.ranges.size() - 1) * scan.angle_increment;
  message.scan_time = rate_hz > 0.0 ? 1.0 / rate_hz : 0.0;
  message.range_min = scan.range_min;
  message.range_max = scan.range_max;
  message.ranges = scan.ranges;
  return message;
}

std::vector<sensor_msgs::Range> coneMessages(const sim::SimEvent& event,
                                             const std::string& frame_prefix,
                                             std::uint8_t radiation, const ros::Time& stamp) {
  std::vector<sensor_msgs::Range> messages;
  for (const sim::TransducerReading& cone : event.cones) {
    sensor_msgs::Range message;
    message.header.stamp = stamp;
    message.header.frame_id = frame_prefix + std::to_string(cone.index);
    message.radiation_type = radiation;
    message.field_of_view = cone.reading.field_of_view;
    message.min_range = cone.reading.min_range;
    message.max_range = cone.reading.max_range;
    message.range = cone.reading.range;
    messages.push_back(message);
  }
  return messages;
}

/// Echoes (readings below max range) as points in base_link, as RosAria publishes them.
sensor_msgs::PointCloud sonarCloud(const sim::SimEvent& event, const ros::Time& stamp) {
  sensor_msgs::PointCloud cloud;
  cloud.header.stamp = stamp;
  cloud.header.frame_id = "base_link";
  for (const sim::TransducerReading& cone : event.cones) {
    if (cone.reading.range >= cone.reading.max_range) continue;
    const Pose2& mount = cone.reading.sensor_pose;
    geometry_msgs::Point32 point;
    point.x = mount.x() + cone.reading.range * std::cos(mount.z());
    point.y = mount.y() + cone.reading.range * std::sin(mount.z());
    cloud.points.push_back(point);
  }
  return cloud;
}

FeatureArray featureMessage(const sim::SimEvent& event, const ros::Time& stamp) {
  FeatureArray message;
  message.header.stamp = stamp;
  message.header.frame_id = "base_link";
  for (const auto& feature : event.features.points) {
    PointFeature point;
    point.range = feature.range;
    point.bearing = feature.bearing;
    for (int k = 0; k < 4; ++k) point.covariance[k] = feature.covariance(k / 2, k % 2);
    point.id = feature.id;
    message.points.push_back(point);
  }
  return message;
}

}  // namespace

tf2_msgs::TFMessage simStaticTransforms(const sim::Simulator& simulator,
                                        const ros::Time& stamp) {
  const sim::SensorsConfig& sensors = simulator.world().sensors;
  tf2_msgs::TFMessage message;
  if (sensors.laser.enabled) {
    message.transforms.push_back(
        toTransformStamped(simulator.laserPose(), "base_link", "base_laser_link", stamp));
  }
  for (size_t i = 0; sensors.sonar.enabled && i < simulator.sonarPoses().size(); ++i) {
    message.transforms.push_back(toTransformStamped(simulator.sonarPoses()[i], "base_link",
                                                    "sonar_" + std::to_string(i), stamp));
  }
  for (size_t i = 0; sensors.infrared.enabled && i < simulator.infraredPoses().size(); ++i) {
    message.transforms.push_back(toTransformStamped(simulator.infraredPoses()[i], "base_link",
                                                    "ir_" + std::to_string(i), stamp));
  }
  return message;
}

SimMessages toSimMessages(const sim::SimEvent& event, const sim::Simulator& simulator,
                          const SimClock& clock) {
  const ros::Time stamp = clock.stamp(event.stamp);
  SimMessages out;
  switch (event.type) {
    case sim::SimEventType::kOdometry: {
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(toTransformStamped(event.odom_pose, "odom", "base_link", stamp));
      out.tf = tf;
      out.odom = toOdometryMsg(event.odom_pose, event.odom_twist, "odom", "base_link", stamp);
      const Eigen::Vector3d true_twist(event.true_speed_mps, 0.0, event.true_turn_rate_radps);
      out.ground_truth = toOdometryMsg(event.true_pose, true_twist, "map", "base_link", stamp);
      break;
    }
    case sim::SimEventType::kLaser:
      if (event.scan) {
        out.scan = scanMessage(*event.scan, simulator.world().sensors.laser.rate_hz, stamp);
      }
      break;
    case sim::SimEventType::kSonar:
      out.sonar = coneMessages(event, "sonar_", sensor_msgs::Range::ULTRASOUND, stamp);
      out.sonar_cloud = sonarCloud(event, stamp);
      break;
    case sim::SimEventType::kInfrared:
      out.infrared = coneMessages(event, "ir_", sensor_msgs::Range::INFRARED, stamp);
      break;
    case sim::SimEventType::kRangeBearing:
      out.features = featureMessage(event, stamp);
      break;
    case sim::SimEventType::kWorldChange:
      break;  // no message: the truth file and the node's log record changes
  }
  return out;
}

std::string groundTruthTumLine(const sim::SimEvent& event, const SimClock& clock) {
  const Pose2& p = event.true_pose;
  // Sized for any double (%f of 1e300 is 300 digits): a fixed buffer cut the newline.
  const char* format = "%.6f %.6f %.6f 0 0.000000000 0.000000000 %.9f %.9f\n";
  const double t = clock.seconds(event.stamp), qz = std::sin(0.5 * p.z()),
               qw = std::cos(0.5 * p.z());
  const int n = std::snprintf(nullptr, 0, format, t, p.x(), p.y(), qz, qw);
  std::string line(n > 0 ? n : 0, '\0');
  if (n > 0) std::snprintf(&line[0], line.size() + 1, format, t, p.x(), p.y(), qz, qw);
  return line;
}

}  // namespace rosbridge
}  // namespace rbpf_slam

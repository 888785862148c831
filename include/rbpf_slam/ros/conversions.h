#pragma once
// Converts ROS messages to and from the core's types; no logic beyond the conversion.

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Transform.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <rbpf_slam/FeatureArray.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Header.h>

#include <cmath>
#include <string>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/grid/grid_map_data.h"

namespace rbpf_slam {
namespace rosbridge {

core::Pose2 toPose2(const geometry_msgs::Transform& transform);
core::Pose2 toPose2(const geometry_msgs::Pose& pose);
/// An initialpose message (rviz's 2D Pose Estimate) as the session takes it: the pose and the
/// x, y, yaw rows of its covariance. An all-zero (unset) covariance becomes rviz's 0.25 m^2,
/// 0.25 m^2, 0.0685 rad^2, and so does an unusable one, said in *note. Returns why the message
/// is to be ignored ("" when it is not): a frame other than map_frame (empty is taken as it),
/// a non-finite pose.
std::string fromInitialPose(const geometry_msgs::PoseWithCovarianceStamped& msg,
                            const std::string& map_frame, core::Pose2* pose,
                            Eigen::Matrix3d* covariance, std::string* note);
/// A sensor's mounting pose in the base frame as the 2D filters use it.
struct SensorMount {
  core::Pose2 pose = core::Pose2::Zero();  // x, y and the direction of the sensor's x axis
  /// The sensor's z axis points down: a laser mounted upside down, whose beam angles turn the
  /// other way in the base frame (toRangeScan's upside_down).
  bool upside_down = false;
  /// Angle between the sensor's z axis and the base's vertical (up, or down when upside_down),
  /// rad. The readings are projected as if level whatever it is; see isTilted.
  double tilt_rad = 0.0;
};
/// Beyond this the readings of a tilted sensor, projected as if level, are noticeably off
/// (a 5 deg tilt shortens ranges by 0.4 % and hits the floor 11 m ahead of a 1 m mount).
constexpr double kMaxLevelTiltRad = 5.0 * M_PI / 180.0;
/// The mount of a sensor frame from its transform in the base frame (a non-unit quaternion
/// is normalised; a zero one reads as level).
SensorMount toSensorMount(const geometry_msgs::Transform& transform);
/// A frame or topic name without its leading '/' (tf2 frames carry none; old bags do).
std::string stripSlash(const std::string& name);

/// Stamps past this (year 2103) are a driver's -1 or garbage: tf2 adds its cache length to
/// stamps, which must stay under 2^32 s, and throws otherwise.
constexpr double kFarStampS = 4.2e9;
/// Why tf2 cannot take this stamp ("stamp 4294967295.000 s is near 2^32 s ..."), or empty.
std::string farStampProblem(const ros::Time& stamp);

/// Why t cannot be used, as tf2's setTransform refuses it (it logs and returns false) or
/// its arithmetic fails: an empty or equal frame name, a stamp near 2^32 s (farStampProblem),
/// a value that is not finite (tf2 itself takes an infinite translation, which would put the
/// robot at infinity), a rotation whose quaternion is not normalised (|q|^2 off 1 by 0.01 or
/// more, tf2's rule). Empty when it can be used.
std::string transformProblem(const geometry_msgs::TransformStamped& t);
/// True when the mount is tilted more than kMaxLevelTiltRad: callers warn that the readings
/// are used as if level (the filters are 2D).
inline bool isTilted(const SensorMount& mount) { return mount.tilt_rad > kMaxLevelTiltRad; }
/// The warning for a tilted mount of frame: names the frame and the angle.
std::string tiltWarning(const std::string& frame, const SensorMount& mount);
geometry_msgs::Transform toTransform(const core::Pose2& pose);
geometry_msgs::Pose toPoseMsg(const core::Pose2& pose);
/// (x, y, yaw) covariance into the 6x6 row-major (x, y, z, roll, pitch, yaw) of a ROS pose.
boost::array<double, 36> toPoseCovariance(const Eigen::Matrix3d& covariance);
/// The transform parent -> child (child's pose in parent) at stamp.
geometry_msgs::TransformStamped toTransformStamped(const core::Pose2& pose, const std::string& parent,
                                                   const std::string& child, const ros::Time& stamp);
/// child's pose in frame with its twist (vx, vy, wz, in the child frame) at stamp.
nav_msgs::Odometry toOdometryMsg(const core::Pose2& pose, const Eigen::Vector3d& twist,
                                 const std::string& frame, const std::string& child,
                                 const ros::Time& stamp);

/// The scan with its sensor mounting pose in the base frame; upside_down (SensorMount's)
/// mirrors the beam angles. Returns false and sets error when the header of the scan
/// cannot describe a scan (zero or non-finite increment, ...).
bool toRangeScan(const sensor_msgs::LaserScan& msg, const core::Pose2& sensor_in_base,
                 core::RangeScan* scan, std::string* error, bool upside_down = false);

/// One sonar (or infrared) reading with its transducer pose in the base frame. Returns false
/// and sets error when the message cannot describe a cone (field_of_view not in (0, pi)); a
/// NaN or infinite range is kept, the extractor counts it as no echo.
bool toConeReading(const sensor_msgs::Range& msg, const core::Pose2& sensor_in_base,
                   core::ConeReading* reading, std::string* error);

/// The points of a cloud whose frame is at frame_in_base, in the base frame (z dropped);
/// upside_down (SensorMount's) mirrors y first.
std::vector<Eigen::Vector2d> toBasePoints(const sensor_msgs::PointCloud& msg,
                                          const core::Pose2& frame_in_base,
                                          bool upside_down = false);
/// A PointCloud2 (RosAria's sonar_pointcloud2) as a PointCloud with the same header and
/// points (x, y and, when present, z; other fields dropped). Returns false and sets error when
/// the cloud has no float x and y fields within point_step, is big-endian, has rows shorter
/// than width x point_step (row_step), or data shorter than its rows need.
bool toPointCloud(const sensor_msgs::PointCloud2& msg, sensor_msgs::PointCloud* out,
                  std::string* error);

/// Features from a message whose frame is at frame_in_base; features with non-finite values
/// are dropped and counted in *dropped. upside_down (SensorMount's): the frame's y axis
/// points the other way in the base frame, so bearings and line normals are mirrored first.
core::FeatureSet toFeatureSet(const FeatureArray& msg, const core::Pose2& frame_in_base,
                              int* dropped, bool upside_down = false);
/// Features of set whose covariance is set (not all zero) but not positive definite: the
/// filters use their configured noise for those instead (observationNoise), which a driver
/// publishing broken covariances should hear about.
int countUnusableCovariances(const core::FeatureSet& set);
/// The warning for count such features arriving on topic.
std::string unusableCovarianceWarning(int count, const std::string& topic);
FeatureArray toMsg(const core::FeatureSet& features, const std_msgs::Header& header);

/// A core grid as nav_msgs/OccupancyGrid (same cell order and values) in frame at stamp.
nav_msgs::OccupancyGrid toOccupancyGrid(const core::GridMapData& grid, const std::string& frame,
                                        const ros::Time& stamp);

}  // namespace rosbridge
}  // namespace rbpf_slam

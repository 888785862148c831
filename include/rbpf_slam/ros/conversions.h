#pragma once
// Converts ROS messages to and from the core's types; no logic beyond the conversion.

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <rbpf_slam/FeatureArray.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Header.h>

#include <string>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/grid/grid_map_data.h"

namespace rbpf_slam {
namespace rosbridge {

core::Pose2 toPose2(const geometry_msgs::Transform& transform);
core::Pose2 toPose2(const geometry_msgs::Pose& pose);
/// True when the frame's z axis points down in its parent: a laser mounted upside down,
/// whose beam angles turn the other way in the base frame (toPose2 gives the direction of its
/// x axis either way).
bool isUpsideDown(const geometry_msgs::Transform& transform);
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

/// The scan with its sensor mounting pose in the base frame; upside_down (isUpsideDown of the
/// mount) mirrors the beam angles. Returns false and sets error when the header of the scan
/// cannot describe a scan (zero or non-finite increment, ...).
bool toRangeScan(const sensor_msgs::LaserScan& msg, const core::Pose2& sensor_in_base,
                 core::RangeScan* scan, std::string* error, bool upside_down = false);

/// One sonar (or infrared) reading with its transducer pose in the base frame. Returns false
/// and sets error when the message cannot describe a cone (field_of_view not in (0, pi)); a
/// NaN or infinite range is kept, the extractor counts it as no echo.
bool toConeReading(const sensor_msgs::Range& msg, const core::Pose2& sensor_in_base,
                   core::ConeReading* reading, std::string* error);

/// The points of a cloud whose frame is at frame_in_base, in the base frame (z dropped).
std::vector<Eigen::Vector2d> toBasePoints(const sensor_msgs::PointCloud& msg,
                                          const core::Pose2& frame_in_base);

/// Features from a message whose frame is at frame_in_base; features with non-finite values
/// are dropped and counted in *dropped.
core::FeatureSet toFeatureSet(const FeatureArray& msg, const core::Pose2& frame_in_base,
                              int* dropped);
FeatureArray toMsg(const core::FeatureSet& features, const std_msgs::Header& header);

/// A core grid as nav_msgs/OccupancyGrid (same cell order and values) in frame at stamp.
nav_msgs::OccupancyGrid toOccupancyGrid(const core::GridMapData& grid, const std::string& frame,
                                        const ros::Time& stamp);

}  // namespace rosbridge
}  // namespace rbpf_slam

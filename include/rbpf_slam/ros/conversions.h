#pragma once
// Converts ROS messages to and from the core's types; no logic beyond the conversion.

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <rbpf_slam/FeatureArray.h>
#include <sensor_msgs/LaserScan.h>
#include <std_msgs/Header.h>

#include <string>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace rosbridge {

core::Pose2 toPose2(const geometry_msgs::Transform& transform);
core::Pose2 toPose2(const geometry_msgs::Pose& pose);
geometry_msgs::Transform toTransform(const core::Pose2& pose);
geometry_msgs::Pose toPoseMsg(const core::Pose2& pose);

/// The scan with its sensor mounting pose in the base frame. Returns false and sets error
/// when the header of the scan cannot describe a scan (zero or non-finite increment, ...).
bool toRangeScan(const sensor_msgs::LaserScan& msg, const core::Pose2& sensor_in_base,
                 core::RangeScan* scan, std::string* error);

/// Features from a message whose frame is at frame_in_base; features with non-finite values
/// are dropped and counted in *dropped.
core::FeatureSet toFeatureSet(const FeatureArray& msg, const core::Pose2& frame_in_base,
                              int* dropped);
FeatureArray toMsg(const core::FeatureSet& features, const std_msgs::Header& header);

}  // namespace rosbridge
}  // namespace rbpf_slam

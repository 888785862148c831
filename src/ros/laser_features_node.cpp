#include "rbpf_slam/ros/laser_features_node.h"

#include <rbpf_slam/FeatureArray.h>

#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/param_loader.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

constexpr double kWarningPeriodS = 10.0;

}  // namespace

LaserFeaturesNode::LaserFeaturesNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : config_(loadConfigFromParams(private_nh)),
      extractor_(config_.laser),
      tf_listener_(tf_buffer_, nh) {
  const uint32_t queue = static_cast<uint32_t>(config_.ros.queue_size);
  scan_subscriber_.subscribe(nh, config_.ros.scan_topic, queue);
  // Only base -> sensor is needed (usually static), so wait for that, not for odometry.
  scan_filter_ = std::make_unique<tf2_ros::MessageFilter<sensor_msgs::LaserScan>>(
      scan_subscriber_, tf_buffer_, config_.ros.base_frame, queue, nh);
  scan_filter_->registerCallback(&LaserFeaturesNode::scanCallback, this);
  scan_filter_->registerFailureCallback(
      [this](const sensor_msgs::LaserScan::ConstPtr& msg, tf2_ros::FilterFailureReason r) {
        messageDropped(msg, r);
      });
  features_publisher_ = nh.advertise<FeatureArray>(config_.ros.features_topic, 10);
}

void LaserFeaturesNode::scanCallback(const sensor_msgs::LaserScan::ConstPtr& msg) {
  core::Pose2 sensor_in_base;
  try {
    sensor_in_base = toPose2(
        tf_buffer_.lookupTransform(config_.ros.base_frame, msg->header.frame_id, msg->header.stamp)
            .transform);
  } catch (const tf2::TransformException& e) {
    warnThrottled("tf " + msg->header.frame_id, "No transform " + config_.ros.base_frame + " -> " +
                                                    msg->header.frame_id + ": " + e.what());
    return;
  }
  core::RangeScan scan;
  std::string error;
  const bool ok = toRangeScan(*msg, sensor_in_base, &scan, &error);
  if (!error.empty()) warnThrottled("scan header", "Scan: " + error);
  if (!ok) return;
  std_msgs::Header header;
  header.stamp = msg->header.stamp;
  header.frame_id = config_.ros.base_frame;
  features_publisher_.publish(toMsg(extractor_.extract(scan), header));
}

void LaserFeaturesNode::messageDropped(const sensor_msgs::LaserScan::ConstPtr& msg,
                                       tf2_ros::FilterFailureReason reason) {
  if (reason == tf2_ros::filter_failure_reasons::EmptyFrameID) {
    warnThrottled("empty frame_id", "Dropping a scan with an empty header.frame_id");
  } else {
    warnThrottled("no tf " + msg->header.frame_id,
                  "Dropping a scan: no transform " + config_.ros.base_frame + " -> " +
                      msg->header.frame_id + " at " + std::to_string(msg->header.stamp.toSec()));
  }
}

void LaserFeaturesNode::warnThrottled(const std::string& cause, const std::string& message) {
  const ros::WallTime now = ros::WallTime::now();
  auto it = last_warning_.find(cause);
  if (it != last_warning_.end() && (now - it->second).toSec() < kWarningPeriodS) return;
  last_warning_[cause] = now;
  ROS_WARN_STREAM("laser_features: " << message);
}

}  // namespace rosbridge
}  // namespace rbpf_slam

#include "rbpf_slam/ros/laser_features_node.h"

#include <rbpf_slam/FeatureArray.h>

#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/param_loader.h"

namespace rbpf_slam {
namespace rosbridge {
LaserFeaturesNode::LaserFeaturesNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : config_(loadConfigFromParams(private_nh)),
      extractor_(config_.laser),
      tf_listener_(tf_buffer_, nh, "laser_features") {
  using Ptr = sensor_msgs::LaserScan::ConstPtr;
  TfGatedSubscriber<sensor_msgs::LaserScan>::Handlers handlers;
  handlers.on_message = [this](const Ptr& msg) { scanCallback(msg); };
  handlers.on_failure = [this](const Ptr& msg, tf2_ros::FilterFailureReason reason) {
    messageDropped(msg, reason);
  };
  handlers.on_bad_stamp = [this](const Ptr& msg, const std::string& why) {
    warnings_.warn("far stamp " + msg->header.frame_id,
                   "Dropping a scan in frame '" + msg->header.frame_id + "': " + why);
  };
  handlers.on_unknown_frame = [this](const Ptr& msg, const std::string& error) {
    warnings_.warn("frame " + msg->header.frame_id,
                   "Dropping a scan in frame '" + msg->header.frame_id +
                       "': tf has no transform " + config_.ros.base_frame + " -> " +
                       msg->header.frame_id + " (" + error + ")");
  };
  // Only base -> sensor is needed (usually static), so wait for that, not for odometry.
  scan_input_ = std::make_unique<TfGatedSubscriber<sensor_msgs::LaserScan>>(
      nh, config_.ros.scan_topic, static_cast<uint32_t>(config_.ros.queue_size), &tf_buffer_,
      config_.ros.base_frame, config_.ros.base_frame, std::move(handlers));
  features_publisher_ = nh.advertise<FeatureArray>(config_.ros.features_topic, 10);
}

void LaserFeaturesNode::scanCallback(const sensor_msgs::LaserScan::ConstPtr& msg) {
  SensorMount mount;
  try {
    // tf2 refuses frame names with a leading '/' (old drivers and bags still write them).
    mount = toSensorMount(tf_buffer_
                              .lookupTransform(config_.ros.base_frame,
                                               stripSlash(msg->header.frame_id), msg->header.stamp)
                              .transform);
  } catch (const tf2::TransformException& e) {
    warnings_.warn("tf " + msg->header.frame_id, "No transform " + config_.ros.base_frame + " -> " +
                                                    msg->header.frame_id + ": " + e.what());
    return;
  }
  if (isTilted(mount)) {
    warnings_.warn("tilt " + msg->header.frame_id, tiltWarning(msg->header.frame_id, mount));
  }
  core::RangeScan scan;
  std::string error;
  const bool ok = toRangeScan(*msg, mount.pose, &scan, &error, mount.upside_down);
  if (!error.empty()) warnings_.warn("scan header", "Scan: " + error);
  if (!ok) return;
  std_msgs::Header header;
  header.stamp = msg->header.stamp;
  header.frame_id = config_.ros.base_frame;
  features_publisher_.publish(toMsg(extractor_.extract(scan), header));
}

void LaserFeaturesNode::messageDropped(const sensor_msgs::LaserScan::ConstPtr& msg,
                                       tf2_ros::FilterFailureReason reason) {
  if (reason == tf2_ros::filter_failure_reasons::EmptyFrameID) {
    warnings_.warn("empty frame_id", "Dropping a scan with an empty header.frame_id");
  } else {
    warnings_.warn("no tf " + msg->header.frame_id,
                  "Dropping a scan: no transform " + config_.ros.base_frame + " -> " +
                      msg->header.frame_id + " at " + std::to_string(msg->header.stamp.toSec()));
  }
}

}  // namespace rosbridge
}  // namespace rbpf_slam

#pragma once
// Extracts line and point features from laser scans and republishes them as FeatureArray.

#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/buffer.h>

#include <memory>
#include <string>

#include "rbpf_slam/core/features/laser_line_extractor.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/ros/node_support.h"

namespace rbpf_slam {
namespace rosbridge {

/// The laser_features node: `scan` in, `features` (base frame, scan stamp) out.
class LaserFeaturesNode {
 public:
  /// Reads the private parameters as a full config and uses its laser_features section;
  /// throws io::ConfigError or std::invalid_argument on bad parameters.
  LaserFeaturesNode(ros::NodeHandle nh, ros::NodeHandle private_nh);
  /// The tf listener stops first: its thread must not feed the tf queues of the subscribers
  /// destroyed before it (members go in reverse order; it is declared before them).
  ~LaserFeaturesNode() { tf_listener_.stop(); }

 private:
  void scanCallback(const sensor_msgs::LaserScan::ConstPtr& msg);
  void messageDropped(const sensor_msgs::LaserScan::ConstPtr& msg,
                      tf2_ros::FilterFailureReason reason);

  const io::SlamConfig config_;
  const core::LaserLineExtractor extractor_;
  tf2_ros::Buffer tf_buffer_;
  CheckedTransformListener tf_listener_;
  std::unique_ptr<TfGatedSubscriber<sensor_msgs::LaserScan>> scan_input_;
  ros::Publisher features_publisher_;
  ThrottledWarnings warnings_{"laser_features"};
};

}  // namespace rosbridge
}  // namespace rbpf_slam

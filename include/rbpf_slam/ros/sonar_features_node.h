#pragma once
// Extracts line and point features from sonar (sensor_msgs/Range per transducer) and
// republishes them as FeatureArray, for pipelines that run extraction in its own node.

#include <message_filters/subscriber.h>
#include <ros/ros.h>
#include <sensor_msgs/Range.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <map>
#include <memory>
#include <string>

#include "rbpf_slam/core/features/sonar_feature_extractor.h"
#include "rbpf_slam/io/slam_config.h"

namespace rbpf_slam {
namespace rosbridge {

/// The sonar_features node: `sonar` in, `features` (base frame, stamp of the reading that
/// completed the window) out. Echoes are accumulated over the robot's motion, so it needs
/// odometry (odom -> base) as well as the transducer poses (base -> sonar_i) from tf.
class SonarFeaturesNode {
 public:
  /// Reads the private parameters as a full config and uses its sonar_features section;
  /// throws io::ConfigError or std::invalid_argument on bad parameters (sonar_source must be
  /// `range`: PointCloud input goes straight to rbpf_slam_node).
  SonarFeaturesNode(ros::NodeHandle nh, ros::NodeHandle private_nh);

  long published() const { return published_; }

 private:
  void sonarCallback(const sensor_msgs::Range::ConstPtr& msg);
  void messageDropped(const sensor_msgs::Range::ConstPtr& msg, tf2_ros::FilterFailureReason reason);
  void warnThrottled(const std::string& cause, const std::string& message);

  const io::SlamConfig config_;
  core::SonarFeatureExtractor extractor_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  message_filters::Subscriber<sensor_msgs::Range> sonar_subscriber_;
  std::unique_ptr<tf2_ros::MessageFilter<sensor_msgs::Range>> sonar_filter_;
  ros::Publisher features_publisher_;
  std::map<std::string, ros::WallTime> last_warning_;
  double last_stamp_ = 0.0;
  long published_ = 0;
};

}  // namespace rosbridge
}  // namespace rbpf_slam

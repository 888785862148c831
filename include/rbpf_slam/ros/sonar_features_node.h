#pragma once
// Extracts line and point features from sonar (sensor_msgs/Range per transducer) and
// republishes them as FeatureArray, for pipelines that run extraction in its own node.

#include <ros/ros.h>
#include <sensor_msgs/Range.h>
#include <tf2_ros/buffer.h>

#include <memory>
#include <string>

#include "rbpf_slam/core/features/sonar_feature_extractor.h"
#include "rbpf_slam/core/slam/slam_session.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/ros/diagnostics.h"
#include "rbpf_slam/ros/node_support.h"

namespace rbpf_slam {
namespace rosbridge {

/// The sonar_features node: `sonar` in, `features` (base frame, stamp of the reading that
/// completed the window) out. Echoes are accumulated over the robot's motion, so it needs
/// odometry (odom -> base) as well as the transducer poses (base -> sonar_i) from tf.
/// Readings it cannot use (a frame tf does not know, an empty frame, no tf in time, an older
/// stamp, a malformed message) are dropped with a throttled warning naming the cause and
/// counted on /diagnostics ("sonar_features": "dropped: <cause>", "updates" = feature frames
/// published, "resets" = echo windows cleared because the stamps went back).
class SonarFeaturesNode {
 public:
  /// Reads the private parameters as a full config and uses its sonar_features section;
  /// throws io::ConfigError or std::invalid_argument on bad parameters (sonar_source must be
  /// `range`: PointCloud input goes straight to rbpf_slam_node).
  SonarFeaturesNode(ros::NodeHandle nh, ros::NodeHandle private_nh);
  /// The tf listener stops first: its thread must not feed the tf queues of the subscribers
  /// destroyed before it (members go in reverse order; it is declared before them).
  ~SonarFeaturesNode() { tf_listener_.stop(); }

  long published() const { return published_; }

 private:
  void sonarCallback(const sensor_msgs::Range::ConstPtr& msg);
  void messageDropped(const sensor_msgs::Range::ConstPtr& msg, tf2_ros::FilterFailureReason reason);
  /// Drops the reading, counting cause on /diagnostics and warning (throttled per key).
  void drop(const std::string& cause, const std::string& key, const std::string& message);
  void publishDiagnostics(const ros::WallTimerEvent& event);

  const io::SlamConfig config_;
  core::SonarFeatureExtractor extractor_;
  tf2_ros::Buffer tf_buffer_;
  CheckedTransformListener tf_listener_;
  std::vector<std::unique_ptr<TfGatedSubscriber<sensor_msgs::Range>>>
      sonar_inputs_;  // a topic each
  ros::Publisher features_publisher_;
  ros::Publisher diagnostics_publisher_;
  ros::WallTimer diagnostics_timer_;
  SlamDiagnostics diagnostics_;
  ThrottledWarnings warnings_{"sonar_features"};
  double last_stamp_ = 0.0;
  core::ClockRestartDetector clock_;  // stamps far before last_stamp_: late, or a new clock
  long published_ = 0;
};

}  // namespace rosbridge
}  // namespace rbpf_slam

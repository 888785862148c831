#pragma once
// The landmark tracker as its own node: `features` in (FeatureArray, any frame in tf, odometry
// through tf odom -> base), `tracker/events` (rbpf_slam/TrackerEvent, one per new-landmark
// step) and `tracker/landmarks` (MarkerArray of the tracked landmarks in the odometry frame)
// out, `/diagnostics` (status `landmark_tracker`). Config: the `tracker`, `measurement`,
// `motion`, `use_lines` and `use_points` keys of the config the node is given (as for
// rbpf_slam_node, e.g. config/landmarks_robust.yaml).

#include <rbpf_slam/FeatureArray.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <memory>
#include <string>

#include "rbpf_slam/core/slam/slam_session.h"
#include "rbpf_slam/core/tracking/tracker_frontend.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/ros/diagnostics.h"
#include "rbpf_slam/ros/markers.h"
#include "rbpf_slam/ros/node_support.h"

namespace rbpf_slam {
namespace rosbridge {

class LandmarkTrackerNode {
 public:
  /// Reads the private parameters as a full config; throws io::ConfigError or
  /// std::invalid_argument on bad parameters.
  LandmarkTrackerNode(ros::NodeHandle nh, ros::NodeHandle private_nh);
  /// The tf listener stops first: its thread must not feed the tf queues of the subscribers
  /// destroyed before it (members go in reverse order; it is declared before them).
  ~LandmarkTrackerNode() { tf_listener_.stop(); }

 private:
  void featuresCallback(const FeatureArray::ConstPtr& msg);
  void messageDropped(const FeatureArray::ConstPtr& msg, tf2_ros::FilterFailureReason reason);
  /// Drops the message, counting cause on /diagnostics and warning (throttled per key).
  void drop(const std::string& cause, const std::string& key, const std::string& message);
  void publishDiagnostics(const ros::WallTimerEvent& event);

  const io::SlamConfig config_;
  core::TrackerFrontend frontend_;
  core::ClockRestartDetector clock_;  // tells a restarted clock from late messages
  tf2_ros::Buffer tf_buffer_;
  CheckedTransformListener tf_listener_;
  std::unique_ptr<TfGatedSubscriber<FeatureArray>> features_input_;
  ros::Publisher events_publisher_, landmarks_publisher_, diagnostics_publisher_;
  ros::WallTimer diagnostics_timer_;
  SlamDiagnostics diagnostics_;
  LandmarkMarkers markers_;
  ThrottledWarnings warnings_{"landmark_tracker"};
};

}  // namespace rosbridge
}  // namespace rbpf_slam

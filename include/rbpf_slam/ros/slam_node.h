#pragma once
// Wires ROS topics and tf to one SlamPipeline: scans, sonar readings and features in,
// map -> odom, pose, trajectory, landmarks and particles out; services ~reset, ~pause, ~resume,
// ~save_map, ~load_map and the `initialpose` topic; the map as a grid on ~map, ~map_metadata
// and ~dynamic_map (the variant's grid, or its landmarks rasterised).

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/GetMap.h>
#include <nav_msgs/OccupancyGrid.h>
#include <rbpf_slam/FeatureArray.h>
#include <rbpf_slam/MapFile.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud.h>
#include <sensor_msgs/Range.h>
#include <std_srvs/Empty.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_broadcaster.h>
#include <topic_tools/shape_shifter.h>

#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <string>

#include "rbpf_slam/core/slam/slam_pipeline.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/diagnostics.h"
#include "rbpf_slam/ros/markers.h"
#include "rbpf_slam/ros/node_support.h"

namespace rbpf_slam {
namespace rosbridge {

/// How a node built on SlamNode differs from rbpf_slam_node (dpf_master_node).
struct SlamNodeCustomisation {
  std::set<std::string> own_parameters;  // private parameters that are not config keys
  /// Builds the filter from the config (default: core::createFilter).
  std::function<std::unique_ptr<core::SlamFilter>(const io::SlamConfig&)> make_filter;
};

/// The rbpf_slam_node: converts incoming messages, hands them to the core, publishes results.
class SlamNode {
 public:
  /// Reads the config from private_nh's parameters; throws io::ConfigError (bad parameters) or
  /// std::invalid_argument (options the core rejects).
  SlamNode(ros::NodeHandle nh, ros::NodeHandle private_nh,
           const SlamNodeCustomisation& customisation = SlamNodeCustomisation());
  /// The tf listener stops first: its thread must not feed the tf queues of the subscribers
  /// destroyed before it (members go in reverse order; it is declared before them).
  ~SlamNode() { tf_listener_.stop(); }

  const io::SlamConfig& config() const { return config_; }

 private:
  void scanCallback(const sensor_msgs::LaserScan::ConstPtr& msg);
  void featuresCallback(const FeatureArray::ConstPtr& msg);
  void sonarCallback(const sensor_msgs::Range::ConstPtr& msg);
  void sonarCloudCallback(const sensor_msgs::PointCloud::ConstPtr& msg);
  /// sonar_cloud as it arrives: sensor_msgs/PointCloud, or PointCloud2 (RosAria's
  /// sonar_pointcloud2) converted to it; then through the tf gate to sonarCloudCallback.
  void sonarCloudArrived(const topic_tools::ShapeShifter::ConstPtr& msg);
  /// Tells the session when odom -> base arrived (its gap check is on odometry silences).
  void odometryTfCallback(const tf2_msgs::TFMessage::ConstPtr& msg);
  /// Subscribes to topic through tf (TfGatedSubscriber) on the odometry frame.
  template <typename Message>
  std::unique_ptr<TfGatedSubscriber<Message>> subscribeFiltered(
      const std::string& topic, void (SlamNode::*callback)(const boost::shared_ptr<const Message>&));
  void messageDropped(const std_msgs::Header& header, tf2_ros::FilterFailureReason reason);
  /// A message stamped before the earliest transform tf holds for it (TfGatedSubscriber).
  void beforeTf(const std_msgs::Header& header);
  /// A message whose frame tf does not connect to the base: dropped, counted, warned.
  void frameNotInTf(const std_msgs::Header& header, const std::string& tf_error);
  /// The odometry pose of the base and the mount of the message frame in the base frame at
  /// the header's stamp; false (with a throttled warning) if tf cannot give them. A tilted
  /// frame is used as if level, with a throttled warning.
  bool lookupPoses(const std_msgs::Header& header, core::Pose2* odom_pose,
                   SensorMount* frame_mount);
  void handleResult(core::FrameResult result, const ros::Time& stamp, double update_ms);
  void publishDiagnostics(const ros::WallTimerEvent& event);
  /// The topics the node waits on, for the warning when nothing arrives.
  std::string inputTopics() const;
  /// ~pose, ~trajectory (at once with trajectory_now, else throttled), ~landmarks, ~particles.
  void publishState(const ros::Time& stamp, bool trajectory_now = false);
  void publishLandmarks(const ros::Time& stamp);
  /// ~trajectory: at once with `now` (or trajectory_publish_period 0), else at most once per
  /// period while someone subscribes; a path not sent yet is sent by the flush timer (resets
  /// and initialpose send at once).
  void publishTrajectory(bool now);
  void flushTrajectory(const ros::WallTimerEvent& event);
  void publishTransform(const ros::TimerEvent& event);
  bool resetService(std_srvs::Empty::Request& request, std_srvs::Empty::Response& response);
  /// amcl's global_localization: grid_pf on a loaded map spreads its particles over the map.
  bool globalLocalizationService(std_srvs::Empty::Request& request,
                                 std_srvs::Empty::Response& response);
  bool pauseService(std_srvs::Empty::Request& request, std_srvs::Empty::Response& response);
  bool resumeService(std_srvs::Empty::Request& request, std_srvs::Empty::Response& response);
  bool saveMapService(MapFile::Request& request, MapFile::Response& response);
  /// What ~load_map's reply advises after a map was loaded: the run starts spread, or set the
  /// pose (and, with the config's global start, what ~reset and ~global_localization do).
  std::string loadedMapAdvice() const;
  bool loadMapService(MapFile::Request& request, MapFile::Response& response);
  /// The current map as a grid: the filter's own (grid_pf) or the landmarks rasterised.
  bool currentMap(const ros::Time& stamp, nav_msgs::OccupancyGrid* map);
  void publishMap(const ros::TimerEvent& event);
  bool dynamicMapService(nav_msgs::GetMap::Request& request, nav_msgs::GetMap::Response& response);
  /// rviz's 2D Pose Estimate: the particles are redrawn around the pose, maps kept.
  void initialPoseCallback(const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& msg);
  /// Resets everything when ros::Time::now() went backwards (a bag played again); returns
  /// false while there is no clock yet.
  bool checkClock();
  /// checkClock() and not paused (a paused frame is counted); false: ignore the frame.
  bool readyForFrame();
  void resetAll(const std::string& why, core::SlamSession::ResetCause cause =
                                            core::SlamSession::ResetCause::kClockWentBack);
  /// Warns about cause at most once every few seconds.
  void warnThrottled(const std::string& cause, const std::string& message) {
    warnings_.warn(cause, message);
  }

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  const io::SlamConfig config_;
  core::SlamPipeline pipeline_;

  tf2_ros::Buffer tf_buffer_;
  CheckedTransformListener tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::unique_ptr<TfGatedSubscriber<sensor_msgs::LaserScan>> scan_input_;
  std::unique_ptr<TfGatedSubscriber<FeatureArray>> features_input_;
  std::vector<std::unique_ptr<TfGatedSubscriber<sensor_msgs::Range>>>
      sonar_inputs_;                           // a topic each
  std::set<std::string> silent_sonar_topics_;  // warned about once: silent while others talk
  bool said_before_first_transform_ = false;   // beforeTf said it once
  std::unique_ptr<TfGatedSubscriber<sensor_msgs::PointCloud>> sonar_cloud_input_;
  ros::Subscriber sonar_cloud_subscriber_;      // either cloud type, into sonar_cloud_input_
  std::vector<core::Pose2> sonar_transducers_;  // sonar_cloud: from tf, found once

  ros::Publisher pose_publisher_;
  ros::Publisher trajectory_publisher_;
  ros::WallTimer trajectory_timer_;
  ros::WallTime trajectory_published_at_;
  bool trajectory_pending_ = false;  // updates since the last ~trajectory sent
  core::FilterStats grid_seen_;      // the filter's counts at the last diagnostics (grid_pf)
  ros::Publisher landmarks_publisher_;
  ros::Publisher particles_publisher_;
  ros::ServiceServer reset_server_, pause_server_, resume_server_, save_map_server_,
      load_map_server_, global_localization_server_;
  ros::Subscriber initial_pose_subscriber_;
  ros::Subscriber odometry_tf_subscriber_;  // /tf, for the stamps of odom -> base only
  ros::Publisher diagnostics_publisher_;
  ros::WallTimer diagnostics_timer_;
  SlamDiagnostics diagnostics_{"rbpf_slam_node"};
  bool paused_ = false;
  long frames_while_paused_ = 0;
  ros::Timer transform_timer_;
  ros::Publisher map_publisher_, map_metadata_publisher_;
  ros::ServiceServer dynamic_map_server_;
  ros::Timer map_timer_;
  long map_published_at_update_ = -1;

  LandmarkMarkers landmark_markers_;
  ros::Time last_transform_stamp_;
  ros::Time last_now_;
  int stale_drops_in_a_row_ = 0;  // "older than the tf cache" drops since the last good frame
  ThrottledWarnings warnings_{"rbpf_slam_node"};
  long updates_ = 0;
  ros::WallTime started_ = ros::WallTime::now();  // for the "nothing arrives" warning
};

}  // namespace rosbridge
}  // namespace rbpf_slam

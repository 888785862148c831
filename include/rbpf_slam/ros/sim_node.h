#pragma once
// The live simulator node: drives a world file's robot in (scaled) real time and publishes
// what the `simulate` tool writes to a bag (tf, /odom, /ground_truth, /scan, /sonar,
// /sonar_cloud, /ir, /features) plus /clock, for roslaunch demos and tests.

#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cstdio>
#include <memory>
#include <string>

#include "rbpf_slam/core/sim/simulator.h"
#include "rbpf_slam/ros/sim_messages.h"

namespace rbpf_slam {
namespace rosbridge {

/// Options of sim_node, read from its private parameters.
struct SimNodeOptions {
  std::string world;               // ~world: world file (required)
  int seed = 0;                    // ~seed
  double rate = 1.0;               // ~rate: simulated seconds per wall second (> 0)
  bool publish_clock = true;       // ~publish_clock: default = /use_sim_time
  double duration_s = 0.0;         // ~duration: stop earlier; 0 = the whole route
  double start_delay_s = 2.0;      // ~start_delay: wall s with the clock at 0 before starting
  std::string ground_truth_file;   // ~ground_truth_file: TUM file, complete when the route is done
};

/// Reads and checks the options; throws std::invalid_argument naming the parameter.
SimNodeOptions loadSimNodeOptions(const ros::NodeHandle& private_nh);

/// Runs the simulator and publishes its events when their time comes.
class SimNode {
 public:
  SimNode(ros::NodeHandle nh, const SimNodeOptions& options);
  /// Publishes until the route is done (then keeps the clock and the last odometry going
  /// with the robot standing still) or ROS shuts down.
  void run();

 private:
  void publish(const core::sim::SimEvent& event);
  void publishClock(double t);
  /// Waits until the wall clock reaches simulated time t (scaled by the rate).
  void waitFor(double t);

  ros::NodeHandle nh_;
  const SimNodeOptions options_;
  core::sim::Simulator simulator_;
  SimClock clock_;
  ros::WallTime wall_start_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  ros::Publisher clock_publisher_, odom_publisher_, ground_truth_publisher_, scan_publisher_,
      sonar_publisher_, sonar_cloud_publisher_, infrared_publisher_, features_publisher_;
  std::unique_ptr<FILE, int (*)(FILE*)> ground_truth_file_;
};

}  // namespace rosbridge
}  // namespace rbpf_slam

// rbpf_slam_node: SLAM from scans or features; see include/rbpf_slam/ros/slam_node.h.
#include <ros/ros.h>

#include <exception>

#include "rbpf_slam/ros/slam_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "rbpf_slam_node");
  // Handles outlive the node object: rosconsole stays up to report a failed construction.
  ros::NodeHandle nh, private_nh("~");
  try {
    rbpf_slam::rosbridge::SlamNode node(nh, private_nh);
    ros::spin();
  } catch (const std::exception& e) {  // io::ConfigError or options the core rejects
    ROS_FATAL_STREAM("rbpf_slam_node: " << e.what());
    return 1;
  }
  return 0;
}

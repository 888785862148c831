// sonar_features: sonar -> features; see include/rbpf_slam/ros/sonar_features_node.h.
#include <ros/ros.h>

#include <exception>

#include "rbpf_slam/ros/sonar_features_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "sonar_features");
  // Handles outlive the node object: rosconsole stays up to report a failed construction.
  ros::NodeHandle nh, private_nh("~");
  try {
    rbpf_slam::rosbridge::SonarFeaturesNode node(nh, private_nh);
    ros::spin();
  } catch (const std::exception& e) {  // io::ConfigError or options the core rejects
    ROS_FATAL_STREAM("sonar_features: " << e.what());
    return 1;
  }
  return 0;
}

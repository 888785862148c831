// dpf_local_node: one local filter of the distributed filter; see include/rbpf_slam/ros/dpf_nodes.h.
#include <ros/ros.h>

#include <exception>

#include "rbpf_slam/ros/dpf_nodes.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "dpf_local_node");
  ros::NodeHandle nh, private_nh("~");
  try {
    rbpf_slam::rosbridge::DpfLocalNode node(nh, private_nh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("dpf_local_node: " << e.what());
    return 1;
  }
  return 0;
}

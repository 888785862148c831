// sim_node: a world file's robot and sensors, live; see include/rbpf_slam/ros/sim_node.h.
#include <ros/ros.h>

#include <exception>

#include "rbpf_slam/ros/sim_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "sim_node");
  ros::NodeHandle nh, private_nh("~");
  try {
    rbpf_slam::rosbridge::SimNode node(nh, rbpf_slam::rosbridge::loadSimNodeOptions(private_nh));
    node.run();
  } catch (const std::exception& e) {  // bad parameters or a bad world file
    ROS_FATAL_STREAM("sim_node: " << e.what());
    return 1;
  }
  return 0;
}

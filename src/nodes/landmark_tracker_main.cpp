// landmark_tracker: features -> tracker/events, tracker/landmarks; see
// include/rbpf_slam/ros/landmark_tracker_node.h.
#include <ros/ros.h>

#include <exception>

#include "rbpf_slam/ros/landmark_tracker_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "landmark_tracker");
  // Handles outlive the node object: rosconsole stays up to report a failed construction.
  ros::NodeHandle nh, private_nh("~");
  try {
    rbpf_slam::rosbridge::LandmarkTrackerNode node(nh, private_nh);
    ros::spin();
  } catch (const std::exception& e) {  // io::ConfigError or options the core rejects
    ROS_FATAL_STREAM("landmark_tracker: " << e.what());
    return 1;
  }
  return 0;
}

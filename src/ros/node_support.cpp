#include "rbpf_slam/ros/node_support.h"

namespace rbpf_slam {
namespace rosbridge {

std::string stripSlash(const std::string& name) {
  return !name.empty() && name[0] == '/' ? name.substr(1) : name;
}

void ThrottledWarnings::warn(const std::string& cause, const std::string& message) {
  const ros::WallTime now = ros::WallTime::now();
  auto it = last_.find(cause);
  if (it != last_.end() && (now - it->second).toSec() < period_s_) return;
  last_[cause] = now;
  ROS_WARN_STREAM(node_name_ << ": " << message);
}

bool frameInTf(const tf2_ros::Buffer& tf, const std::string& base_frame, const std::string& frame,
               std::string* error) {
  if (frame.empty() || !tf._frameExists(stripSlash(base_frame))) return true;
  return tf.canTransform(stripSlash(base_frame), stripSlash(frame), ros::Time(0), error);
}

}  // namespace rosbridge
}  // namespace rbpf_slam

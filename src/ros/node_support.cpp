#include "rbpf_slam/ros/node_support.h"

#include <cstdio>

#include "rbpf_slam/ros/conversions.h"

namespace rbpf_slam {
namespace rosbridge {

void ThrottledWarnings::warn(const std::string& cause, const std::string& message) {
  const ros::WallTime now = ros::WallTime::now();
  auto it = last_.find(cause);
  if (it != last_.end() && (now - it->second).toSec() < period_s_) return;
  last_[cause] = now;
  ROS_WARN_STREAM(node_name_ << ": " << message);
}

std::vector<core::Pose2> lookupTransducers(const tf2::BufferCore& tf, const std::string& base,
                                           const std::string& prefix, const ros::Time& stamp) {
  constexpr int kMaxTransducers = 64;
  std::vector<core::Pose2> poses;
  for (int i = 0; i < kMaxTransducers; ++i) {
    try {
      poses.push_back(
          toPose2(tf.lookupTransform(base, prefix + std::to_string(i), stamp).transform));
    } catch (const std::exception&) {  // TransformException, or tf2's time arithmetic
      break;
    }
  }
  return poses;
}

bool frameInTf(const tf2_ros::Buffer& tf, const std::string& base_frame, const std::string& frame,
               std::string* error) {
  if (frame.empty() || !tf._frameExists(stripSlash(base_frame))) return true;
  return tf.canTransform(stripSlash(base_frame), stripSlash(frame), ros::Time(0), error);
}

}  // namespace rosbridge
}  // namespace rbpf_slam

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

CheckedTransformListener::CheckedTransformListener(tf2::BufferCore& buffer,
                                                   const ros::NodeHandle& nh,
                                                   std::string node_name)
    : buffer_(buffer), nh_(nh), spinner_(1, &queue_), node_name_(node_name),
      warnings_(std::move(node_name)) {
  buffer_.setUsingDedicatedThread(true);  // as tf2_ros's: lookups may wait with a timeout
  nh_.setCallbackQueue(&queue_);
  // Absolute names, as tf2_ros: a launch file's remap of /tf still applies. The callback takes
  // the whole message event, declared as such: given a lambda alone, roscpp builds the event
  // from the bare message and the publisher's name (the "authority") is lost.
  using Event = const ros::MessageEvent<tf2_msgs::TFMessage const>&;
  const boost::function<void(Event)> on_tf = [this](Event event) {
    handle(*event.getConstMessage(), event.getPublisherName(), false);
  };
  const boost::function<void(Event)> on_static = [this](Event event) {
    handle(*event.getConstMessage(), event.getPublisherName(), true);
  };
  tf_subscriber_ = nh_.subscribe<tf2_msgs::TFMessage, Event>("/tf", 100, on_tf);
  static_subscriber_ = nh_.subscribe<tf2_msgs::TFMessage, Event>("/tf_static", 100, on_static);
  spinner_.start();
}

CheckedTransformListener::~CheckedTransformListener() { stop(); }

void CheckedTransformListener::stop() {
  spinner_.stop();
  tf_subscriber_.shutdown();
  static_subscriber_.shutdown();
}

void CheckedTransformListener::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  buffer_.clear();
  guard_.clear();
}

void CheckedTransformListener::handle(const tf2_msgs::TFMessage& msg,
                                      const std::string& authority, bool is_static) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::Time now = ros::Time::now();
  if (now < last_update_) {  // a bag played again (rosbag play -l) or a simulator restarted
    ROS_WARN_STREAM(node_name_ << ": the clock went back " << (last_update_.toSec() - now.toSec())
                               << " s: clearing the tf buffer");
    buffer_.clear();
    guard_.clear();
  }
  last_update_ = now;
  for (const geometry_msgs::TransformStamped& t : msg.transforms) {
    std::string problem = transformProblem(t);
    // A stamp far off (a glitch, a driver's garbage) would make tf2 drop every later real
    // transform of that pair as older than it (core::StampGuard: compared with the newest
    // transform taken and with the clock, which may be off while all the transforms agree).
    // Static transforms: any stamp.
    if (problem.empty() && !is_static) {
      const double stamp = t.header.stamp.toSec();
      switch (guard_.check(stripSlash(t.child_frame_id), stamp, now.toSec())) {
        case core::StampGuard::Verdict::kTake:
          break;
        case core::StampGuard::Verdict::kRepeat: {
          // tf2 keeps the first transform of a stamp and warns of every repeat; a converted log
          // with coarse stamps or a driver publishing twice per stamp repeats hundreds of times.
          // Skipped here, and said once in a while with the count.
          const std::string child = stripSlash(t.child_frame_id);
          const long repeats = ++repeated_[child];
          warnings_.warn("repeat " + child,
                         "skipping transforms " + t.header.frame_id + " -> " + t.child_frame_id +
                             " on /tf from " + authority +
                             " that repeat the newest stamp taken for that frame (tf2 keeps the "
                             "first of a stamp): " +
                             std::to_string(repeats) + " so far");
          continue;
        }
        case core::StampGuard::Verdict::kRefuseAhead:
          problem =
              "stamp " + std::to_string(stamp) + " s is more than a day after " +
              (guard_.newest() > 0.0 ? "both the newest transform so far (" +
                                           std::to_string(guard_.newest()) + " s) and the clock"
                                     : "the clock (" + std::to_string(now.toSec()) + " s)");
          break;
        case core::StampGuard::Verdict::kRestart:
          ROS_WARN_STREAM(node_name_ << ": " << t.header.frame_id << " -> " << t.child_frame_id
                                     << " stamped " << std::to_string(stamp)
                                     << " s agrees with the clock, but the newest transform taken ("
                                     << std::to_string(guard_.newest())
                                     << " s) is more than a day ahead of both: that one was "
                                        "wrong; clearing the tf buffer");
          buffer_.clear();
          guard_.clear();
          ++restarts_;
          break;
      }
    }
    if (problem.empty()) {
      try {
        // false when tf2 refuses it itself (old data, a repeat of an older stamp, its stricter
        // quaternion check): tf2 logs that, and it is not counted here
        if (buffer_.setTransform(t, authority, is_static) && !is_static) {
          guard_.taken(stripSlash(t.child_frame_id), t.header.stamp.toSec());
        }
        continue;
      } catch (const std::exception& e) {  // tf2's time arithmetic, whatever the stamp
        problem = e.what();
      }
    }
    ++refused_;
    const std::string topic = is_static ? "/tf_static" : "/tf";
    warnings_.warn("refused " + topic + " " + t.header.frame_id + " -> " + t.child_frame_id,
                   "dropped a transform on " + topic + " from " + authority + ", " +
                       t.header.frame_id + " -> " + t.child_frame_id + ": " + problem);
  }
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

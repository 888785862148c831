#pragma once
// Shared by the fault-injection rostests (faults_node, sonar_faults_node): the exact range to
// a rectangular room's walls, and an observer of everything the nodes publish that the checks
// need (poses, landmark markers, map -> odom, /diagnostics by status name).

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <utility>

namespace rbpf_slam {
namespace fault_test {

/// Distance from (x, y) along heading a to the walls of the room [-half_x, half_x] x
/// [-half_y, half_y].
double rangeToWall(double x, double y, double a, double half_x, double half_y) {
  const double c = std::cos(a), s = std::sin(a);
  double best = std::numeric_limits<double>::infinity();
  if (c > 1e-9) best = std::min(best, (half_x - x) / c);
  if (c < -1e-9) best = std::min(best, (-half_x - x) / c);
  if (s > 1e-9) best = std::min(best, (half_y - y) / s);
  if (s < -1e-9) best = std::min(best, (-half_y - y) / s);
  return best;
}

/// Everything the node publishes that the checks need, with running fault flags.
class Observer {
 public:
  Observer() {
    ros::NodeHandle nh;
    pose_sub_ = nh.subscribe("/rbpf_slam_node/pose", 100, &Observer::onPose, this);
    markers_sub_ = nh.subscribe("/rbpf_slam_node/landmarks", 100, &Observer::onMarkers, this);
    tf_sub_ = nh.subscribe("/tf", 1000, &Observer::onTf, this);
    diag_sub_ = nh.subscribe("/diagnostics", 10, &Observer::onDiagnostics, this);
  }
  long poses() { std::lock_guard<std::mutex> l(m_); return poses_; }
  double lastPoseStamp() { std::lock_guard<std::mutex> l(m_); return last_pose_stamp_; }
  size_t landmarks() { std::lock_guard<std::mutex> l(m_); return shown_.size(); }
  long nonFinite() { std::lock_guard<std::mutex> l(m_); return non_finite_; }
  long repeatedTf() { std::lock_guard<std::mutex> l(m_); return repeated_tf_; }
  long mapToOdom() { std::lock_guard<std::mutex> l(m_); return map_to_odom_; }
  /// A value of the latest /diagnostics report of the named status, or -1 when absent.
  long diagnostic(const std::string& key, const std::string& status = "rbpf_slam_node") {
    std::lock_guard<std::mutex> l(m_);
    auto it = diagnostics_[status].find(key);
    return it == diagnostics_[status].end() ? -1 : std::stol(it->second);
  }
  /// When the named status was last reported.
  ros::WallTime lastDiagnostics(const std::string& status = "rbpf_slam_node") {
    std::lock_guard<std::mutex> l(m_);
    return diag_time_[status];
  }
  /// After a clock jump the map -> odom stamps start over.
  void newClockEpoch() { std::lock_guard<std::mutex> l(m_); last_tf_stamp_ = 0.0; }

 private:
  void onPose(const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& msg) {
    std::lock_guard<std::mutex> l(m_);
    ++poses_;
    last_pose_stamp_ = msg->header.stamp.toSec();
    const auto& p = msg->pose.pose;
    bool ok = std::isfinite(p.position.x) && std::isfinite(p.position.y) &&
              std::isfinite(p.orientation.z) && std::isfinite(p.orientation.w);
    for (double c : msg->pose.covariance) ok = ok && std::isfinite(c);
    if (!ok) ++non_finite_;
  }
  void onMarkers(const visualization_msgs::MarkerArray::ConstPtr& msg) {
    std::lock_guard<std::mutex> l(m_);
    for (const auto& m : msg->markers) {
      const auto key = std::make_pair(m.ns, m.id);
      if (m.action == visualization_msgs::Marker::DELETEALL) {
        shown_.clear();
      } else if (m.action == visualization_msgs::Marker::DELETE) {
        shown_.erase(key);
      } else {
        shown_.insert(key);
        bool ok = std::isfinite(m.pose.position.x) && std::isfinite(m.pose.position.y) &&
                  std::isfinite(m.scale.x) && std::isfinite(m.scale.y);
        for (const auto& p : m.points) ok = ok && std::isfinite(p.x) && std::isfinite(p.y);
        if (!ok) ++non_finite_;
      }
    }
  }
  void onTf(const tf2_msgs::TFMessage::ConstPtr& msg) {
    std::lock_guard<std::mutex> l(m_);
    for (const auto& t : msg->transforms) {
      if (t.header.frame_id != "map" || t.child_frame_id != "odom") continue;
      ++map_to_odom_;
      const auto& v = t.transform.translation;
      const auto& q = t.transform.rotation;
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(q.z) ||
          !std::isfinite(q.w)) {
        ++non_finite_;
      }
      const double stamp = t.header.stamp.toSec();
      if (stamp <= last_tf_stamp_) ++repeated_tf_;
      last_tf_stamp_ = stamp;
    }
  }
  void onDiagnostics(const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
    std::lock_guard<std::mutex> l(m_);
    for (const auto& status : msg->status) {
      auto& values = diagnostics_[status.name];
      values.clear();
      for (const auto& kv : status.values) {
        try {
          (void)std::stod(kv.value);
          values[kv.key] = kv.value;
        } catch (const std::exception&) {  // "true"/"false" and text values are not counts
        }
      }
      diag_time_[status.name] = ros::WallTime::now();
    }
  }

  std::mutex m_;
  ros::Subscriber pose_sub_, markers_sub_, tf_sub_, diag_sub_;
  long poses_ = 0, non_finite_ = 0, repeated_tf_ = 0, map_to_odom_ = 0;
  double last_pose_stamp_ = 0.0, last_tf_stamp_ = 0.0;
  std::set<std::pair<std::string, int>> shown_;
  std::map<std::string, std::map<std::string, std::string>> diagnostics_;  // by status name
  std::map<std::string, ros::WallTime> diag_time_;
};

}  // namespace fault_test
}  // namespace rbpf_slam

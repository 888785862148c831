#include "rbpf_slam/ros/bag_validation.h"

#include <nav_msgs/Odometry.h>
#include <rbpf_slam/FeatureArray.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud.h>
#include <sensor_msgs/Range.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "rbpf_slam/core/slam/slam_session.h"
#include "rbpf_slam/ros/bag_files.h"
#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/node_support.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

/// Keeps the running state of one stream while the bag is read.
struct StreamState {
  StreamReport report;
  ros::Time last;
  bool has_last = false;

  std::vector<std::pair<double, double>> steps;  // (step, bag-relative time it began)

  void add(const ros::Time& stamp, const ros::Time& bag_begin) {
    ++report.messages;
    if (stamp.isZero()) {
      ++report.zero_stamps;
      return;
    }
    if (!farStampProblem(stamp).empty()) {
      ++report.far_stamps;  // not the newest stamp: the gaps stay those of the real ones
      return;
    }
    if (has_last) {
      if (stamp < last) {
        ++report.backwards;
        return;  // measure gaps against the newest stamp
      }
      if (stamp == last) ++report.duplicates;
      // In seconds as doubles: a ros::Duration of a stamp near 2^32 s (a driver's -1) throws.
      const double step = stamp.toSec() - last.toSec();
      steps.emplace_back(step, last.toSec() - bag_begin.toSec());
      report.largest_gap_s = std::max(report.largest_gap_s, step);
    }
    last = stamp;
    has_last = true;
  }

  /// Gaps once the stream is read: steps longer than max_gap_s and than kPeriods times the
  /// stream's median step (a laser log with a scan every 3 s has no gap at 8 s).
  void countGaps(double max_gap_s) {
    constexpr double kPeriods = 5.0;
    if (steps.empty()) return;
    report.gap_threshold_s = max_gap_s;
    // The typical step: the median without the largest step, so that in a short stream a
    // hole does not set its own yardstick. Two steps or fewer: max_gap_s alone.
    if (steps.size() >= 3) {
      std::vector<double> sorted;
      for (const auto& s : steps) sorted.push_back(s.first);
      std::sort(sorted.begin(), sorted.end());
      sorted.pop_back();
      report.gap_threshold_s = std::max(max_gap_s, kPeriods * sorted[sorted.size() / 2]);
    }
    for (const auto& [step, at] : steps) {
      if (step <= report.gap_threshold_s) continue;
      ++report.gaps;
      if (report.first_gap_at_s < 0.0) report.first_gap_at_s = at;
    }
  }
};

std::string fixed(double v, int digits = 1) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << v;
  return out.str();
}

}  // namespace

BagReport validateBag(const std::string& path, const BagValidationOptions& options) {
  BagReport report;
  report.path = path;
  rosbag::Bag bag;
  openBagForReading(&bag, path);
  rosbag::View view(bag);
  const ros::Time begin = view.getBeginTime();
  report.duration_s = view.getEndTime().toSec() - begin.toSec();  // doubles: no Duration overflow

  std::map<std::string, StreamState> streams;  // topic or tf edge
  std::map<std::string, std::set<std::string>> tf_neighbours;
  std::map<std::string, std::set<std::string>> tf_children;  // parent -> children, as sent
  std::set<std::string> tf_child_frames;
  std::map<std::string, std::string> range_topics;  // topics of sensor_msgs/Range
  std::set<std::string> odometry_topics;            // nav_msgs/Odometry (SLAM reads tf)
  std::set<std::string> features_topics;            // rbpf_slam/FeatureArray
  std::map<std::string, long> undecodable;          // per topic: messages of a damaged bag
  for (const rosbag::MessageInstance& m : view) {
    const std::string topic = m.getTopic();
    try {
      if (const auto tf = m.instantiate<tf2_msgs::TFMessage>()) {
        const bool is_static = topic.find("tf_static") != std::string::npos;
        for (const auto& t : tf->transforms) {
          const std::string parent = stripSlash(t.header.frame_id);
          const std::string child = stripSlash(t.child_frame_id);
          const std::string edge = "tf " + parent + " -> " + child;
          StreamState& s = streams[edge];
          s.report.name = edge;
          // What tf2 refuses (it logs and drops it): a run cannot use it.
          const std::string problem = transformProblem(t);
          if (!problem.empty() && s.report.invalid_values++ == 0) s.report.first_invalid = problem;
          if (!is_static)
            s.add(t.header.stamp, begin);
          else
            ++s.report.messages;
          if (problem.empty()) {
            tf_neighbours[parent].insert(child);
            tf_neighbours[child].insert(parent);
            tf_children[parent].insert(child);
            tf_child_frames.insert(child);
          }
        }
        continue;
      }
      StreamState& s = streams[topic];
      s.report.name = topic;
      std_msgs::Header header;
      if (const auto scan = m.instantiate<sensor_msgs::LaserScan>()) {
        header = scan->header;
        for (float r : scan->ranges) {
          if (std::isnan(r) || (std::isinf(r) && r < 0)) ++s.report.invalid_values;
        }
      } else if (const auto range = m.instantiate<sensor_msgs::Range>()) {
        header = range->header;
        range_topics[topic] = topic;
        if (!std::isfinite(range->range) && !(std::isinf(range->range) && range->range > 0)) {
          ++s.report.invalid_values;
        }
      } else if (const auto cloud = m.instantiate<sensor_msgs::PointCloud>()) {
        header = cloud->header;
        for (const auto& p : cloud->points) {
          if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            ++s.report.invalid_values;
          }
        }
      } else if (const auto features = m.instantiate<FeatureArray>()) {
        header = features->header;
        features_topics.insert(topic);
        int dropped = 0;  // the features SLAM drops, by the same rule
        toFeatureSet(*features, core::Pose2::Zero(), &dropped);
        s.report.invalid_values += dropped;
      } else if (const auto odometry = m.instantiate<nav_msgs::Odometry>()) {
        header = odometry->header;
        odometry_topics.insert(topic);
        // SLAM reads odometry from tf, but a driver that sends NaN here is broken.
        const auto& p = odometry->pose.pose;
        const auto& v = odometry->twist.twist;
        for (double value : {p.position.x, p.position.y, p.position.z, p.orientation.x,
                             p.orientation.y, p.orientation.z, p.orientation.w, v.linear.x,
                             v.linear.y, v.linear.z, v.angular.x, v.angular.y, v.angular.z}) {
          if (!std::isfinite(value)) {
            ++s.report.invalid_values;
            break;  // one per message
          }
        }
      } else {
        ++s.report.messages;  // a type without a header we look at: counted only
        continue;
      }
      s.report.frames.insert(stripSlash(header.frame_id));
      // Range topics carry one stream per transducer frame: check the order per frame.
      if (range_topics.count(topic)) {
        StreamState& per_frame = streams[topic + " [" + stripSlash(header.frame_id) + "]"];
        per_frame.report.name = topic + " [" + stripSlash(header.frame_id) + "]";
        per_frame.add(header.stamp, begin);
        ++s.report.messages;
      } else {
        s.add(header.stamp, begin);
      }
    } catch (const std::exception&) {
      ++undecodable[topic];
    }
  }
  for (const auto& [topic, count] : undecodable) {
    report.problems.push_back(topic + ": " + std::to_string(count) +
                              " message(s) that do not decode (a damaged bag)");
  }

  // Frames tf can reach from the base frame (edges at any time).
  std::set<std::string> connected{options.base_frame};
  std::vector<std::string> todo{options.base_frame};
  while (!todo.empty()) {
    const std::string frame = todo.back();
    todo.pop_back();
    for (const std::string& next : tf_neighbours[frame]) {
      if (connected.insert(next).second) todo.push_back(next);
    }
  }
  if (!tf_neighbours.count(options.odom_frame) || !connected.count(options.odom_frame)) {
    // What the bag's tf does hold, as a hint: the odometry frame's children (one is most likely
    // the base frame), or without that frame the roots of its trees (one is most likely it).
    const auto list = [](const std::set<std::string>& frames) {
      std::string out;
      for (const std::string& f : frames) out += (out.empty() ? "'" : "', '") + f;
      return out + "'";
    };
    std::string hint;
    if (tf_child_frames.count(options.odom_frame) && !tf_children.count(options.odom_frame)) {
      hint = "; the bag's tf has " + options.odom_frame +
             " only as a child, with no transform from it: no odometry " + options.odom_frame +
             " -> base frame";
    } else if (tf_children.count(options.odom_frame)) {
      hint = "; the bag's tf has " + options.odom_frame + " -> " +
             list(tf_children.at(options.odom_frame)) +
             ": is one of those the base frame (--base-frame, the config's base_frame)?";
    } else {
      std::set<std::string> roots;
      for (const auto& [parent, children] : tf_children) {
        if (!tf_child_frames.count(parent)) roots.insert(parent);
      }
      hint = roots.empty() ? "; the bag has no usable tf"
                           : "; the bag's tf starts at " + list(roots) +
                                 ": is one of those the odometry frame (--odom-frame, the "
                                 "config's odom_frame)?";
    }
    report.problems.push_back("tf never connects " + options.odom_frame + " and " +
                              options.base_frame + ": no odometry for SLAM" + hint);
  }

  for (auto& [name, state] : streams) {
    state.countGaps(options.max_gap_s);
    StreamReport& r = state.report;
    const bool is_tf = name.rfind("tf ", 0) == 0;
    const bool range_topic = range_topics.count(name) > 0;
    if (r.backwards > 0) {
      report.problems.push_back(name + ": " + std::to_string(r.backwards) +
                                " stamp(s) older than the one before");
    }
    if (r.duplicates > 0 && (is_tf || odometry_topics.count(name))) {
      // Converted logs repeat odometry stamps; SLAM reads odometry from tf and skips the
      // repeats there (skipped_transforms).
      report.notes.push_back(name + ": " + std::to_string(r.duplicates) +
                             " repeated stamp(s), skipped by SLAM");
    } else if (r.duplicates > 0) {
      report.problems.push_back(name + ": " + std::to_string(r.duplicates) + " repeated stamp(s)");
    }
    if (r.far_stamps > 0) {
      report.problems.push_back(name + ": " + std::to_string(r.far_stamps) +
                                " stamp(s) near 2^32 s (a driver's -1?), which tf2 cannot handle: "
                                "SLAM drops those messages");
    }
    if (r.zero_stamps > 0) {
      report.problems.push_back(name + ": " + std::to_string(r.zero_stamps) + " zero stamp(s)");
    }
    if (r.gaps > 0) {
      // Sensors and landmark sightings may pause (a log's pauses, nothing in view): SLAM waits.
      // Odometry pausing longer than the sessions' max_time_gap (30 s by default) makes SLAM
      // treat the step as a gap (gap_action: more motion noise, or a new map): a problem.
      // Shorter odometry pauses are interpolated over, as the filter does: a note.
      const bool odometry = is_tf ? name == "tf " + options.odom_frame + " -> " + options.base_frame
                                  : odometry_topics.count(name) > 0;
      const std::string text = name + ": " + std::to_string(r.gaps) + " gap(s) longer than " +
                               fixed(r.gap_threshold_s) + " s (largest " + fixed(r.largest_gap_s) +
                               " s, first at " + fixed(r.first_gap_at_s) + " s into the bag)";
      const double session_gap_s = core::SessionOptions().max_time_gap_s;
      if (odometry && r.largest_gap_s > session_gap_s) {
        report.problems.push_back(
            text + "; over " + fixed(session_gap_s, 0) +
            " s, SLAM's default max_time_gap, the step is a gap (gap_action)");
      } else {
        report.notes.push_back(text + (odometry ? "; SLAM interpolates over these"
                                                : "; time without data, SLAM waits"));
      }
    }
    if (r.invalid_values > 0) {
      report.problems.push_back(
          name + ": " + std::to_string(r.invalid_values) +
          (is_tf ? " unusable transform(s) (the first: " + r.first_invalid + ")"
                 : (features_topics.count(name)
                        ? " unusable feature(s) (non-finite values or covariance, or a negative "
                          "range: SLAM drops them)"
                        : odometry_topics.count(name)
                              ? " message(s) with a non-finite pose or twist (SLAM reads tf, "
                                "but the driver that sent them is suspect)"
                              : " NaN or -inf value(s)")));
    }
    if (is_tf) continue;
    if (r.frames.size() > 1) {
      std::string list;
      for (const auto& f : r.frames) list += (list.empty() ? "" : ", ") + f;
      if (range_topic) {
        report.notes.push_back(name + ": one frame per transducer (" + list + ")");
      } else {
        report.problems.push_back(name + ": messages in several frames (" + list + ")");
      }
    }
    for (const std::string& frame : r.frames) {
      if (frame.empty()) {
        report.problems.push_back(name + ": message(s) with an empty frame_id");
      } else if (frame != "map" && frame != options.odom_frame && !connected.count(frame)) {
        report.problems.push_back(name + ": frame '" + frame + "' is not connected to " +
                                  options.base_frame + " by any transform in the bag");
      }
    }
  }
  for (auto& [name, state] : streams) report.streams.push_back(state.report);
  return report;
}

}  // namespace rosbridge
}  // namespace rbpf_slam

// carmen_to_bag LOG[.gz] OUT.bag [--odom-noise F] [--odom-bias F] [--seed N]
// Converts a corrected CARMEN log into a bag shaped like the shared intel.bag: /scan, /odom,
// /tf (odom -> base_link) and /tf_static (base_link -> base_laser_link), stamped
// 1262304000 + log time. The odometry is re-derived from the corrected motion with scale bias
// and random error; OUT.ref.tum gets the corrected pose at every scan (the reference).

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/require_range.h"
#include "rbpf_slam/io/carmen.h"
#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/tool_arguments.h"
#include "rbpf_slam/io/trajectory.h"
#include "rbpf_slam/ros/bag_files.h"
#include "rbpf_slam/ros/conversions.h"

namespace {

namespace io = rbpf_slam::io;
namespace core = rbpf_slam::core;
namespace rosbridge = rbpf_slam::rosbridge;

constexpr double kStampOffsetS = 1262304000.0;  // 2010-01-01, as in the shared bags
constexpr double kRangeMinM = 0.02;
constexpr double kRangeMaxM = 50.0;
constexpr double kSameOffsetTolerance = 1e-6;

const char kUsage[] =
    "usage: carmen_to_bag LOG[.gz] OUT.bag [--odom-noise F] [--odom-bias F] [--seed N]\n"
    "  --odom-noise F  odometry sigma per unit of motion (m/m, rad/rad; default 0.03)\n"
    "  --odom-bias F   systematic odometry scale error (default 0.02 = 2 %)\n"
    "  --seed N        seed of the odometry noise (default 1)\n"
    "Writes OUT.bag (/scan, /odom, /tf, /tf_static) and OUT.ref.tum (corrected scan poses).\n";

/// Command-line settings of one conversion.
struct Arguments {
  std::string log_path;
  std::string bag_path;
  io::OdometryNoiseOptions noise;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments arguments;
  std::vector<std::string> positional;
  io::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    if (cursor.arg() == "--odom-noise") {
      arguments.noise.noise_per_unit = cursor.number(io::NumberRule::kNonNegative);
    } else if (cursor.arg() == "--odom-bias") {
      arguments.noise.scale_bias = cursor.number();
    } else if (cursor.arg() == "--seed") {
      arguments.noise.seed = cursor.count();
    } else if (cursor.isOption()) {
      cursor.unknown();
    } else {
      positional.push_back(cursor.arg());
    }
  }
  // Beyond these the simulated odometry is nonsense (1e307 gave NaN odometry).
  if (!(arguments.noise.scale_bias > -0.99 && arguments.noise.scale_bias <= 1.0)) {
    throw std::invalid_argument("--odom-bias " + core::formatNumber(arguments.noise.scale_bias) +
                                " is outside (-0.99, 1] (a scale error: 0.02 is 2 %)");
  }
  if (arguments.noise.noise_per_unit > 10.0) {
    throw std::invalid_argument("--odom-noise " +
                                core::formatNumber(arguments.noise.noise_per_unit) +
                                " is above 10 (a sigma per unit travelled)");
  }
  if (positional.size() != 2) {
    throw std::invalid_argument("expected LOG and OUT.bag, got " +
                                std::to_string(positional.size()) + " file argument(s)");
  }
  arguments.log_path = positional[0];
  arguments.bag_path = positional[1];
  io::validate(arguments.noise);
  return arguments;
}

ros::Time toRosTime(double log_stamp) { return ros::Time(kStampOffsetS + log_stamp); }

// The laser in the robot frame, from the first scan; warns when later scans disagree.
core::Pose2 laserOffset(const io::CarmenLog& log) {
  const io::CarmenLaser& first = log.lasers.front();
  const core::Pose2 offset = core::between(first.robot_pose, first.laser_pose);
  double worst = 0.0;
  for (const io::CarmenLaser& laser : log.lasers) {
    const core::Pose2 difference =
        core::between(offset, core::between(laser.robot_pose, laser.laser_pose));
    worst = std::max(worst, std::max(difference.head<2>().norm(), std::abs(difference.z())));
  }
  if (worst > kSameOffsetTolerance) {
    std::cerr << "carmen_to_bag: warning: the laser offset varies between scans by up to " << worst
              << " (m or rad); using the first scan's\n";
  }
  if (offset.head<2>().norm() < kSameOffsetTolerance && std::abs(offset.z()) < 1e-9) {
    return core::Pose2::Zero();
  }
  return offset;
}

sensor_msgs::LaserScan toScan(const io::CarmenLaser& laser, std::uint32_t seq) {
  sensor_msgs::LaserScan scan;
  scan.header.seq = seq;
  scan.header.stamp = toRosTime(laser.stamp);
  scan.header.frame_id = "base_laser_link";
  const io::LaserGeometry geometry = io::flaserGeometry(laser.ranges.size());
  scan.angle_min = geometry.angle_min_rad;
  scan.angle_increment = geometry.angle_increment_rad;
  scan.angle_max = geometry.angle_min_rad +
                   geometry.angle_increment_rad *
                       static_cast<double>(std::max<std::size_t>(laser.ranges.size(), 1) - 1);
  scan.range_min = kRangeMinM;
  scan.range_max = kRangeMaxM;
  scan.ranges.reserve(laser.ranges.size());
  for (double range : laser.ranges) {
    scan.ranges.push_back(static_cast<float>(io::toRep117Range(range, kRangeMaxM)));
  }
  return scan;
}

nav_msgs::Odometry toOdometry(const io::StampedPose& pose, const io::StampedPose* previous,
                              std::uint32_t seq) {
  // Twist in the child frame: the increment since the previous reading over its duration.
  Eigen::Vector3d twist = Eigen::Vector3d::Zero();
  if (previous != nullptr && pose.stamp > previous->stamp) {
    twist = core::between(previous->pose, pose.pose) / (pose.stamp - previous->stamp);
  }
  nav_msgs::Odometry odometry =
      rosbridge::toOdometryMsg(pose.pose, twist, "odom", "base_link", toRosTime(pose.stamp));
  odometry.header.seq = seq;
  return odometry;
}

/// One message to write: what and when.
struct Event {
  double stamp;
  int kind;  // 0 tf_static, 1 odometry (+ tf), 2 scan: at equal stamps tf comes first
  std::size_t index;
};

void reportSkipped(const io::CarmenLog& log, const io::CorrectedMotionStats& motion) {
  std::size_t unknown = 0;
  std::string by_type;
  for (const auto& entry : log.unknown_messages) {
    unknown += entry.second;
    by_type += (by_type.empty() ? "" : ", ") + entry.first + ": " + std::to_string(entry.second);
  }
  std::cerr << "carmen_to_bag: skipped " << unknown << " line(s) of unknown type"
            << (by_type.empty() ? "" : " (" + by_type + ")") << " and " << log.malformed_lines
            << " malformed line(s)\n";
  for (const std::string& example : log.malformed_examples) {
    std::cerr << "carmen_to_bag:   malformed " << example << "\n";
  }
  std::cerr << "carmen_to_bag: odometry: used " << motion.odometry_used << " ODOM line(s), dropped "
            << motion.odometry_dropped
            << " with a stamp outside their scans' window or out of order, "
            << motion.duplicate_stamps << " duplicate stamp(s)\n";
  if (motion.scans_out_of_order > 0) {
    std::ostringstream stamps;  // seconds as logged (1e9 and more), to the millisecond
    stamps << std::fixed << std::setprecision(3) << motion.first_out_of_order_stamp
           << " s, after line " << motion.latest_before_line << "'s " << motion.latest_before_stamp;
    std::cerr << "carmen_to_bag: warning: " << motion.scans_out_of_order
              << " FLASER scan(s) stamped before an earlier scan, sorted by time (the first at "
                 "line "
              << motion.first_out_of_order_line << ", " << stamps.str()
              << " s; a stamp far ahead also drops the ODOM lines after it)\n";
  }
}

void writeBag(const Arguments& arguments, const io::CarmenLog& log,
              const std::vector<io::StampedPose>& odometry) {
  std::vector<Event> events;
  for (std::size_t i = 0; i < odometry.size(); ++i) events.push_back({odometry[i].stamp, 1, i});
  for (std::size_t i = 0; i < log.lasers.size(); ++i) events.push_back({log.lasers[i].stamp, 2, i});
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return a.stamp != b.stamp ? a.stamp < b.stamp : a.kind < b.kind;
  });
  events.insert(events.begin(), Event{events.front().stamp, 0, 0});

  rbpf_slam::rosbridge::PartialBag output(arguments.bag_path);  // the bag appears when complete
  std::uint32_t odometry_seq = 0, scan_seq = 0;
  for (const Event& event : events) {
    const ros::Time stamp = toRosTime(event.stamp);
    if (event.kind == 0) {
      tf2_msgs::TFMessage tf_static;
      tf_static.transforms.push_back(
          rosbridge::toTransformStamped(laserOffset(log), "base_link", "base_laser_link", stamp));
      output.write("/tf_static", stamp, tf_static,
                   rosbridge::latchedConnectionHeader<tf2_msgs::TFMessage>("/carmen_to_bag"));
    } else if (event.kind == 1) {
      const io::StampedPose* previous = event.index > 0 ? &odometry[event.index - 1] : nullptr;
      const nav_msgs::Odometry message =
          toOdometry(odometry[event.index], previous, odometry_seq++);
      output.write("/odom", stamp, message);
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(rosbridge::toTransformStamped(odometry[event.index].pose, "odom", "base_link", stamp));
      tf.transforms.back().header.seq = message.header.seq;
      output.write("/tf", stamp, tf);
    } else {
      output.write("/scan", stamp, toScan(log.lasers[event.index], scan_seq++));
    }
  }
  output.commit();
}

/// The work once the arguments are understood; the exit status.
int run(const Arguments& arguments) {
  ros::Time::init();
  const io::CarmenLog log = io::readCarmenLog(arguments.log_path);
  if (log.lasers.empty()) {
    // Why: every FLASER line may have been malformed (a NaN beam rejects its scan).
    std::string why;
    if (log.malformed_lines > 0) {
      why = " that could be used (" + std::to_string(log.malformed_lines) +
            " malformed line(s); the first: " +
            (log.malformed_examples.empty() ? std::string("?") : log.malformed_examples.front()) +
            ")";
    }
    throw std::runtime_error(arguments.log_path + ": no FLASER scan in the log" + why);
  }
  io::CorrectedMotionStats motion_stats;
  const std::vector<io::StampedPose> motion = io::correctedMotion(log, &motion_stats);
  const std::vector<io::StampedPose> odometry = io::simulateOdometry(motion, arguments.noise);
  const std::vector<io::StampedPose> scans = io::scanPoses(log);
  std::vector<io::StampedPose> reference;
  for (const io::StampedPose& pose : scans) {
    reference.push_back({kStampOffsetS + pose.stamp, pose.pose});
  }
  const std::string reference_path = io::besideBag(arguments.bag_path, ".ref.tum");
  io::requireReplaceableFile(reference_path);  // refused before the bag is written
  writeBag(arguments, log, odometry);
  io::writeTum(reference_path, reference);

  reportSkipped(log, motion_stats);
  std::cerr << "carmen_to_bag: wrote " << arguments.bag_path << " (" << log.lasers.size()
            << " scans, " << odometry.size() << " odometry messages over "
            << (odometry.back().stamp - odometry.front().stamp) << " s) and " << reference_path
            << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return io::runTool("carmen_to_bag", kUsage, argc, argv, parseArguments, run);
}

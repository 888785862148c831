// victoria_park_to_bag VICTORIA_PARK.txt OUT.bag [--dt S] [--unknown-ids] [--max-poses N]
// Converts the Victoria Park text log (ODOMETRY / LANDMARK lines, see io/victoria_park.h) into
// a bag: /tf (odom -> base_link) and /odom from the integrated odometry, /features
// (rbpf_slam/FeatureArray in base_link) with each pose's tree sightings as range, bearing and
// covariance, id = tree id (association is solved in the file; --unknown-ids writes -1).
// The log has no time: pose k of the chain is stamped 1262304000 + k * dt (dt = 0.2 s by
// default, ~23 min for the 6969 poses, close to the original run). Beside the bag:
// OUT.odom.tum (the dead-reckoned track; the dataset has no ground truth).

#include <nav_msgs/Odometry.h>
#include <rbpf_slam/FeatureArray.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/tool_arguments.h"
#include "rbpf_slam/io/trajectory.h"
#include "rbpf_slam/io/victoria_park.h"
#include "rbpf_slam/ros/bag_files.h"
#include "rbpf_slam/ros/conversions.h"

namespace {

namespace io = rbpf_slam::io;
namespace core = rbpf_slam::core;
namespace rosbridge = rbpf_slam::rosbridge;

constexpr double kStartStamp = 1262304000.0;  // 2010-01-01, as the other converted bags

const char kUsage[] =
    "usage: victoria_park_to_bag VICTORIA_PARK.txt OUT.bag [--dt S] [--unknown-ids]\n"
    "                            [--max-poses N]\n"
    "  --dt S           synthetic time between consecutive poses (default 0.2 s)\n"
    "  --unknown-ids    write id -1 on every feature (association left to the filter)\n"
    "  --max-poses N    keep only the first N poses of the chain (0: all)\n"
    "Writes OUT.bag (/tf, /odom, /features) and OUT.odom.tum.\n";

struct Arguments {
  std::string input, bag_path;
  double dt_s = 0.2;
  bool unknown_ids = false;
  long max_poses = 0;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments a;
  std::vector<std::string> positional;
  io::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    if (cursor.arg() == "--dt") {
      a.dt_s = cursor.number(io::NumberRule::kPositive);
      if (a.dt_s >= 1e3) {
        throw std::invalid_argument("--dt must be under 1000 s, got " + std::to_string(a.dt_s));
      }
    } else if (cursor.arg() == "--max-poses") {
      a.max_poses = static_cast<long>(cursor.count());
    } else if (cursor.arg() == "--unknown-ids") {
      a.unknown_ids = true;
    } else if (cursor.isOption()) {
      cursor.unknown();
    } else {
      positional.push_back(cursor.arg());
    }
  }
  if (positional.size() != 2) {
    throw std::invalid_argument("expected VICTORIA_PARK.txt OUT.bag, got " +
                                std::to_string(positional.size()) + " argument(s)");
  }
  a.input = positional[0];
  a.bag_path = positional[1];
  return a;
}

rbpf_slam::FeatureArray featureMessage(const io::VictoriaPose& pose, const ros::Time& stamp,
                                       bool unknown_ids, std::uint32_t seq) {
  rbpf_slam::FeatureArray message;
  message.header.seq = seq;
  message.header.stamp = stamp;
  message.header.frame_id = "base_link";
  for (const io::VictoriaLandmark& l : pose.landmarks) {
    rbpf_slam::PointFeature point;
    Eigen::Matrix2d covariance;
    io::toRangeBearing(l, &point.range, &point.bearing, &covariance);
    point.covariance = {covariance(0, 0), covariance(0, 1), covariance(1, 0), covariance(1, 1)};
    point.id = unknown_ids ? -1 : l.tree;
    message.points.push_back(point);
  }
  return message;
}

/// The work once the arguments are understood; the exit status.
int run(const Arguments& arguments) {
  ros::Time::init();
  const io::VictoriaParkLog log = io::loadVictoriaPark(arguments.input);
  std::size_t orphans = 0;
  std::vector<io::VictoriaPose> poses = io::victoriaParkPoses(log, &orphans);
  if (arguments.max_poses > 0 && static_cast<long>(poses.size()) > arguments.max_poses) {
    poses.resize(arguments.max_poses);
  }
  const std::string odometry_path = io::besideBag(arguments.bag_path, ".odom.tum");
  io::requireReplaceableFile(odometry_path);  // refused before the bag is written
  rbpf_slam::rosbridge::PartialBag output(arguments.bag_path);  // the bag appears when complete
  std::vector<io::StampedPose> track;
  std::uint32_t feature_seq = 0;
  std::size_t features = 0;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double t = kStartStamp + k * arguments.dt_s;
    const ros::Time stamp(t);
    const core::Pose2& pose = poses[k].odometry;
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(rosbridge::toTransformStamped(pose, "odom", "base_link", stamp));
    output.write("/tf", stamp, tf);
    Eigen::Vector3d twist = Eigen::Vector3d::Zero();
    if (k > 0) {
      const core::Pose2 d = core::between(poses[k - 1].odometry, pose);
      twist = d / arguments.dt_s;
    }
    nav_msgs::Odometry odometry = rosbridge::toOdometryMsg(pose, twist, "odom", "base_link", stamp);
    odometry.header.seq = static_cast<std::uint32_t>(k);
    output.write("/odom", stamp, odometry);
    if (!poses[k].landmarks.empty()) {
      const auto message = featureMessage(poses[k], stamp, arguments.unknown_ids, feature_seq++);
      features += message.points.size();
      output.write("/features", stamp, message);
    }
    track.push_back({t, pose});
  }
  output.commit();
  io::writeTum(odometry_path, track);
  std::cerr << "victoria_park_to_bag: " << poses.size() << " poses over "
            << (poses.size() - 1) * arguments.dt_s << " s (dt " << arguments.dt_s << " s), "
            << features << " tree sightings in " << feature_seq << " /features messages ("
            << (arguments.unknown_ids ? "unknown" : "known") << " ids; " << orphans
            << " sightings from poses off the odometry chain dropped)\n"
            << "victoria_park_to_bag: wrote " << arguments.bag_path << ", " << odometry_path
            << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return io::runTool("victoria_park_to_bag", kUsage, argc, argv, parseArguments, run);
}

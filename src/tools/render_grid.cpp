// render_grid --bag IN.bag --reference REF.tum --config CONFIG.yaml --output PREFIX
//             [--set key=value ...] [--max-dt S] [--align-to ESTIMATE.tum]
// Renders the bag's laser scans at the reference poses into one occupancy grid with the
// inverse sensor model and grid options of CONFIG (variant grid_pf's), writes PREFIX.pgm +
// PREFIX.yaml (map_server conventions) and prints cell counts as JSON: the map a perfect
// trajectory would give, to compare offline_slam's map.pgm with. --align-to moves the reference
// so that its pose at the estimate's first stamp is the estimate's first pose (offline_slam's
// map frame starts at the first odometry pose): both maps are then in the same frame.
// Exit status: 0 on success, 2 on bad usage, 1 for unreadable input or nothing rendered.

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/core/grid/grid_pf.h"
#include "rbpf_slam/core/grid/inverse_sensor_model.h"
#include "rbpf_slam/io/grid_map_file.h"
#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/io/tool_arguments.h"
#include "rbpf_slam/io/trajectory.h"
#include "rbpf_slam/ros/bag_files.h"
#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/node_support.h"

namespace {

namespace core = rbpf_slam::core;
namespace io = rbpf_slam::io;
using rbpf_slam::rosbridge::stripSlash;

const char kUsage[] =
    "usage: render_grid --bag IN.bag --reference REF.tum --config CONFIG.yaml --output PREFIX\n"
    "                   [--set key=value ...] [--max-dt S] [--align-to ESTIMATE.tum]\n"
    "  renders the laser scans at the reference poses (nearest within --max-dt, default\n"
    "  0.05 s) with the config's grid options; writes PREFIX.pgm, PREFIX.yaml; prints JSON\n";

/// The nearest reference pose within max_dt of stamp; false if none.
bool referenceAt(const std::vector<rbpf_slam::io::StampedPose>& reference, double stamp,
                 double max_dt, rbpf_slam::core::Pose2* pose) {
  auto it = std::lower_bound(reference.begin(), reference.end(), stamp,
                             [](const auto& p, double t) { return p.stamp < t; });
  double best = max_dt;
  bool found = false;
  for (auto c : {it, it == reference.begin() ? it : it - 1}) {
    if (c == reference.end()) continue;
    if (std::fabs(c->stamp - stamp) <= best) {
      best = std::fabs(c->stamp - stamp);
      *pose = c->pose;
      found = true;
    }
  }
  return found;
}

struct Arguments {
  std::string bag_path, reference_path, config_path, output, align_path;
  std::vector<std::string> overrides;
  double max_dt = 0.05;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments a;
  rbpf_slam::io::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    if (cursor.arg() == "--bag") {
      a.bag_path = cursor.value();
    } else if (cursor.arg() == "--reference") {
      a.reference_path = cursor.value();
    } else if (cursor.arg() == "--config") {
      a.config_path = cursor.value();
    } else if (cursor.arg() == "--output") {
      a.output = cursor.value();
    } else if (cursor.arg() == "--set") {
      a.overrides.push_back(cursor.keyValue());
    } else if (cursor.arg() == "--align-to") {
      a.align_path = cursor.value();
    } else if (cursor.arg() == "--max-dt") {
      a.max_dt = cursor.number(rbpf_slam::io::NumberRule::kNonNegative);
    } else {
      throw std::invalid_argument("unknown argument '" + cursor.arg() + "'");
    }
  }
  if (a.bag_path.empty() || a.reference_path.empty() || a.config_path.empty() || a.output.empty()) {
    throw std::invalid_argument("--bag, --reference, --config and --output are required");
  }
  return a;
}

/// The work once the arguments are understood; the exit status.
int run(const Arguments& arguments) {
  const std::string& bag_path = arguments.bag_path;
  const std::string& reference_path = arguments.reference_path;
  const std::string& output = arguments.output;
  const std::string& align_path = arguments.align_path;
  const double max_dt = arguments.max_dt;
  const io::SlamConfig config = io::loadSlamConfig(arguments.config_path, arguments.overrides);
  const core::GridOptions& options = config.filter.grid;
  core::validate(options);
  for (const std::string& file : io::gridMapFiles(output)) io::requireReplaceableFile(file);
  std::vector<io::StampedPose> reference = io::readTum(reference_path);
  if (reference.empty()) throw std::runtime_error(reference_path + ": no poses");
  std::sort(reference.begin(), reference.end(),
            [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
  if (!align_path.empty()) {
    const std::vector<io::StampedPose> estimate = io::readTum(align_path);
    core::Pose2 at_start;
    if (estimate.empty() || !referenceAt(reference, estimate.front().stamp, max_dt, &at_start)) {
      throw std::runtime_error(align_path + ": no first pose with a reference within --max-dt");
    }
    const core::Pose2 to_estimate = core::compose(estimate.front().pose, core::inverse(at_start));
    for (auto& p : reference) p.pose = core::compose(to_estimate, p.pose);
  }
  rosbag::Bag bag;
  rbpf_slam::rosbridge::openBagForReading(&bag, bag_path);
  // Static sensor mounts: base -> sensor frame from tf_static (identity if the same frame).
  std::vector<std::pair<std::string, rbpf_slam::rosbridge::SensorMount>> mounts;
  const std::vector<std::string> static_topics{"/tf_static", "tf_static"};
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(static_topics))) {
    const auto msg = m.instantiate<tf2_msgs::TFMessage>();
    if (!msg) continue;
    for (const auto& t : msg->transforms) {
      if (stripSlash(t.header.frame_id) == config.ros.base_frame) {
        mounts.emplace_back(stripSlash(t.child_frame_id),
                            rbpf_slam::rosbridge::toSensorMount(t.transform));
      }
    }
  }
  core::TiledLogOddsGrid grid = core::firstGrid(options, reference.front().pose);
  // The grid grows as grid_pf's does (grid.max_size_m; one table), so that the reference
  // covers what the filter could map.
  const core::GridGrowthLimits limits = core::growthLimits(options, grid, 1);
  long scans = 0, unmatched = 0, bad = 0, not_held = 0, laser_messages = 0;
  std::set<std::string> tilt_warned;  // scan frames warned about, once each
  const std::string topic = stripSlash(config.ros.scan_topic);
  for (const rosbag::MessageInstance& m :
       rosbag::View(bag, rosbag::TopicQuery(std::vector<std::string>{"/" + topic, topic}))) {
    const auto msg = m.instantiate<sensor_msgs::LaserScan>();
    if (!msg) continue;
    ++laser_messages;
    core::Pose2 pose;
    if (!referenceAt(reference, msg->header.stamp.toSec(), max_dt, &pose)) {
      ++unmatched;
      continue;
    }
    rbpf_slam::rosbridge::SensorMount mount;  // level at the base when the scan is in its frame
    const std::string frame = stripSlash(msg->header.frame_id);
    if (frame != config.ros.base_frame) {
      auto it = std::find_if(mounts.begin(), mounts.end(),
                             [&](const auto& f) { return f.first == frame; });
      if (it == mounts.end()) {
        throw std::runtime_error(bag_path + ": no tf_static " + config.ros.base_frame + " -> " +
                                 frame);
      }
      mount = it->second;
      if (rbpf_slam::rosbridge::isTilted(mount) && tilt_warned.insert(frame).second) {
        std::fprintf(stderr, "render_grid: %s\n",
                     rbpf_slam::rosbridge::tiltWarning(frame, mount).c_str());
      }
    }
    auto scan = std::make_shared<core::RangeScan>();
    std::string error;
    if (!rbpf_slam::rosbridge::toRangeScan(*msg, mount.pose, scan.get(), &error,
                                           mount.upside_down)) {
      ++bad;
      continue;
    }
    core::FeatureSet features;
    features.scan = scan;
    core::LocalMapStats stats;
    const std::vector<core::LocalMapCell> local = core::buildLocalMap(features, options, &stats);
    not_held +=
        !core::growToHold(core::localMapReach(local, options.resolution_m), pose, limits, &grid);
    core::integrateLocalMap(local, pose, options, &grid);
    ++scans;
  }
  if (laser_messages == 0) {
    throw std::runtime_error(bag_path + ": no sensor_msgs/LaserScan on /" + topic +
                             " (the config's scan_topic): render_grid renders laser scans only");
  }
  if (scans == 0) throw std::runtime_error(bag_path + ": no scan matched a reference pose");
  const core::GridMapData map = grid.toGridMap();
  io::writeGridMap(output, map, "rbpf_slam: scans rendered at the reference poses");
  std::printf(
      "{\"scans\": %ld, \"scans_without_reference\": %ld, \"bad_scans\": %ld, "
      "\"scans_beyond_the_grid\": %ld, \"occupied_cells\": %ld, \"free_cells\": %ld, "
      "\"resolution\": %g}\n",
      scans, unmatched, bad, not_held, map.count(65, 100), map.count(0, 19), map.resolution_m);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return io::runTool("render_grid", kUsage, argc, argv, parseArguments, run);
}

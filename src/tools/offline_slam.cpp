// offline_slam: runs a config over a bag as fast as the CPU allows (no roscore needed).
//   offline_slam --bag IN.bag --config config/NAME.yaml --output DIR [--seed N]
//                [--set key=value ...] [--reference REF.tum] [--no-progress]
//                [--output-bag OUT.bag]  (tf, pose, landmarks, trajectory for rviz)
//                [--initial-pose X,Y,YAW[,SIGMA_XY,SIGMA_YAW] | --global-localization]

#include <cstdio>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/io/tool_arguments.h"
#include "rbpf_slam/ros/offline_runner.h"

namespace {

namespace io = rbpf_slam::io;

const char kUsage[] =
    "usage: offline_slam --bag IN.bag --config CONFIG.yaml --output DIR [--seed N]\n"
    "                    [--set key=value ...] [--reference REF.tum] [--no-progress] [--verbose]\n"
    "                    [--output-bag OUT.bag]\n"
    "                    [--initial-pose X,Y,YAW[,SIGMA_XY,SIGMA_YAW] | --global-localization]\n"
    "  --seed N         the filter's seed (as --set seed=N)\n"
    "  --set key=value  overrides a config key (dotted for sections: motion.alpha1=0.1)\n"
    "  --reference F    TUM ground truth: ATE in summary.json\n"
    "  --output-bag F   the input's tf and sensors plus map -> odom, pose, landmarks, trajectory\n"
    "  --initial-pose P the start in the map frame (m, rad; sigmas default rviz's 0.5 m, 0.26 "
    "rad:\n"
    "                   give ones that fit the place, e.g. 0.02 m for an e-puck), as an\n"
    "                   initialpose before the first frame; the bag's initialpose messages are\n"
    "                   used too (e.g. to localize on map_file from a known start)\n"
    "  --global-localization  grid_pf on a map_server map_file with localization_only: the\n"
    "                   start is unknown, the particles start spread over the map's free cells\n"
    "                   with any heading (use thousands of particles and the likelihood field:\n"
    "                   --set grid.match_model=likelihood_field; README \"Map once, then\n"
    "                   localize\"); not with --initial-pose; as the config's\n"
    "                   global_localization: true\n"
    "Writes DIR/trajectory.tum, trajectory_online.tum, landmarks.yaml, summary.json, map.png,\n"
    "map.pgm and map.yaml (with smoothing also trajectory_filter.tum, landmarks_filter.yaml).\n"
    "Exits 2 on bad arguments, 1 when the bag or the config cannot be read, a config or --set\n"
    "value is refused, a topic carries the wrong message type, an output is a directory, a\n"
    "pipe, a device or a socket (checked before the bag is read), --output-bag names the\n"
    "input, an output cannot be written, --global-localization or the config's\n"
    "global_localization cannot be done (no grid map, mapping on, no free cell at the\n"
    "filter's resolution, the config's key with --initial-pose), no frame could be used or\n"
    "--reference could not be evaluated (the outputs are written all the same in the last\n"
    "two cases).\n";

/// --initial-pose X,Y,YAW[,SIGMA_XY,SIGMA_YAW] (m, rad): the start pose in the map frame and
/// its standard deviations (default rviz's: 0.5 m, 0.26 rad).
void parseInitialPose(const std::string& text, rbpf_slam::rosbridge::OfflineOptions* options) {
  std::vector<double> values;
  if (!text.empty() && text.back() == ',') {
    throw std::invalid_argument("--initial-pose: a number is missing after the last comma in '" +
                                text + "'");
  }
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    values.push_back(io::parseNumber("--initial-pose", item, io::NumberRule::kFinite));
  }
  if (values.size() != 3 && values.size() != 5) {
    throw std::invalid_argument(
        "--initial-pose needs X,Y,YAW or X,Y,YAW,SIGMA_XY,SIGMA_YAW "
        "(m, rad), got '" +
        text + "'");
  }
  options->has_initial_pose = true;
  options->initial_pose = rbpf_slam::core::Pose2(values[0], values[1], values[2]);
  if (values.size() == 5) {
    if (!(values[3] > 0.0 && values[4] > 0.0)) {
      throw std::invalid_argument("--initial-pose: SIGMA_XY and SIGMA_YAW must be > 0, got '" +
                                  text + "'");
    }
    options->initial_covariance =
        Eigen::Vector3d(values[3] * values[3], values[3] * values[3], values[4] * values[4])
            .asDiagonal();
  }
}

struct Arguments {
  rbpf_slam::rosbridge::OfflineOptions options;
  std::string config_path;
  std::vector<std::string> overrides;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments a;
  io::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    const std::string& arg = cursor.arg();
    if (arg == "--bag") {
      a.options.bag_path = cursor.value();
    } else if (arg == "--config") {
      a.config_path = cursor.value();
    } else if (arg == "--output") {
      a.options.output_dir = cursor.value();
    } else if (arg == "--reference") {
      a.options.reference_path = cursor.value();
    } else if (arg == "--seed") {
      a.overrides.push_back("seed=" + std::to_string(cursor.count()));
    } else if (arg == "--set") {
      a.overrides.push_back(cursor.keyValue());
    } else if (arg == "--no-progress") {
      a.options.progress = false;
    } else if (arg == "--verbose") {
      a.options.verbose = true;
    } else if (arg == "--output-bag") {
      a.options.output_bag = cursor.value();
    } else if (arg == "--initial-pose") {
      parseInitialPose(cursor.value(), &a.options);
    } else if (arg == "--global-localization") {
      a.options.global_localization = true;
    } else {
      throw std::invalid_argument("unknown argument '" + arg + "'");
    }
  }
  if (a.options.bag_path.empty() || a.config_path.empty() || a.options.output_dir.empty()) {
    throw std::invalid_argument("--bag, --config and --output are required");
  }
  if (a.options.global_localization && a.options.has_initial_pose) {
    throw std::invalid_argument(
        "--initial-pose and --global-localization exclude each other (a known start or none)");
  }
  return a;
}

/// The work once the arguments are understood; the exit status.
int run(const Arguments& arguments) {
  const rbpf_slam::rosbridge::OfflineOptions& options = arguments.options;
  const rbpf_slam::io::SlamConfig config =
      io::loadSlamConfig(arguments.config_path, arguments.overrides);
  rbpf_slam::rosbridge::OfflineRunner runner(config, options);
  const auto s = runner.run();
  std::printf(
      "offline_slam: %ld updates, %d landmarks, %d particles, %.1f s wall for %.1f s "
      "of data (%.0fx real time), update %.2f ms mean / %.2f ms p99",
      s.updates, s.landmarks, s.particles, s.wall_s, s.bag_duration_s,
      s.wall_s > 0 ? s.bag_duration_s / s.wall_s : 0.0, s.update_ms_mean, s.update_ms_p99);
  if (s.has_reference) std::printf(", ATE %.3f m", s.ate_rmse_m);
  if (s.has_map_frame_ate) {
    std::printf(" (%.3f m in the map frame, unaligned)", s.ate_map_frame_rmse_m);
  }
  std::printf(
      "\noffline_slam: wrote %s/{trajectory.tum,trajectory_online.tum,landmarks.yaml,%s"
      "summary.json,map.png,map.pgm,map.yaml}%s%s\n",
      options.output_dir.c_str(),
      config.smoothing.enabled ? "trajectory_filter.tum,landmarks_filter.yaml," : "",
      options.output_bag.empty() ? "" : " and ", options.output_bag.c_str());
  bool failed = false;
  for (const std::string& line :
       rbpf_slam::rosbridge::describeOutcome(s, options, config.filter.variant, &failed)) {
    std::fprintf(stderr, "offline_slam: %s\n", line.c_str());
  }
  // The outputs are written either way (they show what happened), but a run that used no
  // frame, or whose requested reference could not be evaluated, did not do its work.
  return failed ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  return io::runTool("offline_slam", kUsage, argc, argv, parseArguments, run);
}

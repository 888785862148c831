// offline_slam: runs a config over a bag as fast as the CPU allows (no roscore needed).
//   offline_slam --bag IN.bag --config config/NAME.yaml --output DIR [--seed N]
//                [--set key=value ...] [--reference REF.tum] [--no-progress]
//                [--output-bag OUT.bag]  (tf, pose, landmarks, trajectory for rviz)

#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/ros/offline_runner.h"

namespace {

int usage(const char* message) {
  std::fprintf(stderr,
               "offline_slam: %s\nusage: offline_slam --bag IN.bag --config CONFIG.yaml "
               "--output DIR [--seed N] [--set key=value ...] [--reference REF.tum] "
               "[--no-progress] [--verbose] [--output-bag OUT.bag]\n",
               message);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  rbpf_slam::rosbridge::OfflineOptions options;
  std::string config_path;
  std::vector<std::string> overrides;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](const char* name) -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(name) + " needs a value");
      return argv[++i];
    };
    try {
      if (arg == "--bag") options.bag_path = value("--bag");
      else if (arg == "--config") config_path = value("--config");
      else if (arg == "--output") options.output_dir = value("--output");
      else if (arg == "--reference") options.reference_path = value("--reference");
      else if (arg == "--seed") overrides.push_back("seed=" + value("--seed"));
      else if (arg == "--set") overrides.push_back(value("--set"));
      else if (arg == "--no-progress") options.progress = false;
      else if (arg == "--verbose") options.verbose = true;
      else if (arg == "--output-bag") options.output_bag = value("--output-bag");
      else return usage(("unknown argument '" + arg + "'").c_str());
    } catch (const std::invalid_argument& e) {
      return usage(e.what());
    }
  }
  if (options.bag_path.empty() || config_path.empty() || options.output_dir.empty()) {
    return usage("--bag, --config and --output are required");
  }
  try {
    const rbpf_slam::io::SlamConfig config = rbpf_slam::io::loadSlamConfig(config_path, overrides);
    rbpf_slam::rosbridge::OfflineRunner runner(config, options);
    const auto s = runner.run();
    std::printf("offline_slam: %ld updates, %d landmarks, %d particles, %.1f s wall for %.1f s "
                "of data (%.0fx real time), update %.2f ms mean / %.2f ms p99",
                s.updates, s.landmarks, s.particles, s.wall_s, s.bag_duration_s,
                s.wall_s > 0 ? s.bag_duration_s / s.wall_s : 0.0, s.update_ms_mean,
                s.update_ms_p99);
    if (s.has_reference) std::printf(", ATE %.3f m", s.ate_rmse_m);
    std::printf("\noffline_slam: wrote %s/{trajectory.tum,landmarks.yaml,summary.json,map.png}\n",
                options.output_dir.c_str());
    if (s.dropped_no_tf + s.dropped_bad_message > 0) {
      std::fprintf(stderr, "offline_slam: dropped %ld frames without tf, %ld malformed\n",
                   s.dropped_no_tf, s.dropped_bad_message);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "offline_slam: %s\n", e.what());
    return 1;
  }
  return 0;
}

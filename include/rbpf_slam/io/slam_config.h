#pragma once
// The one loader that turns a config YAML (a file from config/, the ROS parameter tree of
// the node, plus --set overrides) into the options of every part of the pipeline.

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "rbpf_slam/core/features/laser_line_extractor.h"
#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/slam/map_smoother.h"
#include "rbpf_slam/core/slam/slam_pipeline.h"
#include "rbpf_slam/io/yaml_section.h"

namespace rbpf_slam {
namespace io {

/// Names and periods used by the ROS node and the bag reader (no ROS types here).
struct RosOptions {
  std::string map_frame = "map";
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";
  std::string scan_topic = "scan";
  std::string features_topic = "features";
  // sensor_msgs/Range, one message per transducer; config key sonar_topic, one topic or a list
  // (drivers that give each sensor its own topic, e.g. the e-puck's proximity0 .. proximity7)
  std::vector<std::string> sonar_topics{"sonar"};
  std::string sonar_cloud_topic = "sonar_cloud";  // sensor_msgs/PointCloud (RosAria)
  std::string sonar_source = "range";             // range | cloud: which of the two to use
  std::string sonar_frame_prefix = "sonar_";      // cloud: transducers are PREFIX0, PREFIX1...
  double sonar_cloud_fov = 0.5236;                // cloud: cone of each transducer, rad
  double sonar_cloud_max_range = 5.0;             // cloud: the transducers' maximum range, m
  double transform_publish_period = 0.05;  // s; 0 disables tf publishing
  double transform_tolerance = 0.1;        // s, how far map -> odom is post-dated
  // Wall s between ~trajectory publications (0: every update). The whole path is rebuilt and
  // sent each time, so on long runs publishing it at every update dominates the node's time.
  double trajectory_publish_period = 0.5;
  int queue_size = 20;
  bool publish_particles = true;
  std::string map_save_prefix = "rbpf_slam_map";  // ~save_map with no path: PREFIX.{yaml,pgm}
  double map_update_period = 5.0;  // s between ~map publications (0: never)
  double map_resolution = 0.05;    // m per cell of the rasterised landmark map (~map, map.pgm)
};

/// Everything a config file configures.
struct SlamConfig {
  std::string frontend = "laser";  // laser | sonar | features (range-bearing landmark data)
  core::FilterOptions filter;
  core::SessionOptions session;
  core::LaserExtractorOptions laser;
  core::ScanMatcherOptions scan_matching;
  core::SonarExtractorOptions sonar;
  core::SmoothingOptions smoothing;  // after the run (session.keep_frames follows enabled)
  RosOptions ros;
  std::string map_file;            // landmarks YAML to start from ("" = empty map)
  bool localization_only = false;  // true: track the robot on map_file, add no landmarks
  // true: the start is unknown: the particles start spread over map_file's free cells (grid_pf,
  // with localization_only), as ~global_localization called before the first frame, and again
  // after ~reset (applyMapConfig).
  bool global_localization = false;

  core::PipelineOptions pipeline() const {
    return {filter, session, laser, scan_matching, sonar};
  }
};

/// Parses a whole config tree; `source` names it in errors (a file name or "~ parameters").
/// Throws ConfigError naming the key, the value and the allowed range.
SlamConfig parseSlamConfig(const YAML::Node& root, const std::string& source);
/// Loads a YAML file and applies "key=value" overrides before parsing.
SlamConfig loadSlamConfig(const std::string& path, const std::vector<std::string>& overrides = {});

/// Reads the map file at path and gives it to the session as its prior map: a landmarks YAML
/// (save_map's landmarks.yaml) for the landmark variants, an occupancy-grid map (map_server's
/// map.yaml + image, as save_map writes for grid_pf) for the variants that map cells. Returns
/// what was loaded ("12 landmarks", "a 240 x 200 grid of 0.05 m cells"); throws ConfigError
/// naming the file and what is wrong with it (a map of the other kind named as such).
std::string loadPriorMap(const std::string& path, core::SlamSession* session);
/// Gives the session config.map_file as its prior map (loadPriorMap), turns mapping off when
/// config.localization_only and, when config.global_localization, makes every run start spread
/// over the map (SlamSession::GlobalStart::kConfigured); throws ConfigError naming what failed
/// (for global_localization the session's reason). Returns what was loaded,
/// with notes on a map likely to localize badly (coarser than the filter's cells, mostly
/// occupied); "" without map_file.
std::string applyMapConfig(const SlamConfig& config, core::SlamSession* session);
/// Settings that are valid but do not do what they seem to in this config (e.g. the likelihood
/// field in a mapping run), one sentence each, for the node and the offline runner to print.
std::vector<std::string> configNotes(const SlamConfig& config);

}  // namespace io
}  // namespace rbpf_slam

#pragma once
// Occupancy grids on disk in map_server conventions (PREFIX.pgm + PREFIX.yaml, trinary:
// occupied 0, free 254, unknown 205) and drawn into the run picture.

#include <string>
#include <vector>

#include "rbpf_slam/core/grid/grid_map_data.h"

namespace rbpf_slam {
namespace io {

/// Occupancy (nav_msgs, 0..100) from which a cell counts as occupied (map_server's
/// occupied_thresh 0.65), and up to which it counts as free (below free_thresh 0.196); the files
/// written, the run picture and the map loader's counts use both.
constexpr int kOccupiedPercent = 65;
constexpr int kFreePercent = 19;

/// The two files writeGridMap writes for PREFIX: PREFIX.pgm and PREFIX.yaml.
std::vector<std::string> gridMapFiles(const std::string& prefix);

/// Writes PREFIX.pgm and PREFIX.yaml (image, resolution, origin, negate 0, occupied_thresh
/// 0.65, free_thresh 0.196); cells >= 65 are occupied, 0..19 free, the rest unknown. Returns
/// the two paths; throws std::runtime_error naming the file on failure.
std::vector<std::string> writeGridMap(const std::string& prefix, const core::GridMapData& grid,
                                      const std::string& comment = "rbpf_slam map");

/// Reads a map_server map (a map written by writeGridMap or map_saver; binary PGM images) back:
/// mode trinary (the default) gives 100, 0 or -1 per cell, scale also 1..99 between the
/// thresholds, raw the pixel values (after negate; over 100: -1). Throws std::runtime_error naming
/// the file and what is wrong (an image given instead of the YAML, a yaw in the origin, ...).
core::GridMapData readGridMap(const std::string& yaml_path);

/// The run picture over a grid: grey unknown, white free, black occupied, the reference
/// (grey line) and the trajectory (blue line) on top.
void drawGridRunMap(const std::string& path, const core::GridMapData& grid,
                    const std::vector<core::Pose2>& trajectory,
                    const std::vector<core::Pose2>& reference);

}  // namespace io
}  // namespace rbpf_slam

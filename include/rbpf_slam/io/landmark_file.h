#pragma once
// Landmark maps on disk: the YAML that offline_slam and ~save_map write and ~load_map reads,
// and a map_server-style occupancy picture (PGM + YAML) of the same landmarks.

#include <string>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace io {

/// Writes landmarks (map frame) as YAML: `landmarks: [{id, type, x/y or rho/theta,
/// covariance, start/end for lines, observations}]`. Throws std::runtime_error on I/O errors.
void writeLandmarksYaml(const std::string& path, const std::vector<core::LandmarkEstimate>& landmarks);

/// Reads a file written by writeLandmarksYaml. Throws std::runtime_error naming the file and
/// the entry on anything missing, non-finite or not positive definite.
std::vector<core::LandmarkEstimate> loadLandmarksYaml(const std::string& path);

struct GridMapOptions {
  double resolution_m = 0.05;  // cell size
  double margin_m = 1.0;       // around the landmarks' bounding box
  double point_radius_m = 0.1; // drawn radius of a point landmark
};

/// Rasterises the landmarks into PREFIX.pgm (occupied 0, unknown 205, as map_server expects)
/// and PREFIX.yaml (image, resolution, origin, negate, thresholds). Returns the two paths.
std::vector<std::string> writeLandmarkGrid(const std::string& prefix,
                                           const std::vector<core::LandmarkEstimate>& landmarks,
                                           const GridMapOptions& options = GridMapOptions());

}  // namespace io
}  // namespace rbpf_slam

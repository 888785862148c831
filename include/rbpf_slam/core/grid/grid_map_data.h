#pragma once
// A finished occupancy grid in the conventions of nav_msgs/OccupancyGrid, ROS-free: what the
// node publishes on ~map, what offline_slam writes as map.pgm + map.yaml.

#include <cstdint>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace core {

/// Row-major cells, row 0 at origin_y (the bottom of the map); -1 unknown, 0..100 occupancy.
struct GridMapData {
  double resolution_m = 0.05;
  double origin_x_m = 0.0;  // map-frame position of cell (0, 0)'s corner
  double origin_y_m = 0.0;
  int width = 0;
  int height = 0;
  std::vector<int8_t> cells;

  int8_t at(int x, int y) const { return cells[static_cast<size_t>(y) * width + x]; }
  long count(int8_t min_value, int8_t max_value) const;  // cells with a value in [min, max]
};

/// Why a robot at pose cannot be on the map ("(5, 5) is outside the map, x -0.1 .. 1.3 m, y -0.1
/// .. 1 m", or on an occupied cell), "" when it can.
std::string poseOffMapProblem(const GridMapData& map, const Pose2& pose);

/// Rasterises landmarks: lines as their observed segments, points as discs of point_radius_m,
/// occupied (100) on unknown (-1), with margin_m around them. Throws std::runtime_error when
/// the grid would exceed max_cells.
GridMapData rasterizeLandmarks(const std::vector<LandmarkEstimate>& landmarks,
                               double resolution_m, double margin_m, double point_radius_m,
                               double max_cells = 2.5e8);

}  // namespace core
}  // namespace rbpf_slam

#include "rbpf_slam/core/grid/grid_map_data.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace rbpf_slam {
namespace core {

long GridMapData::count(int8_t min_value, int8_t max_value) const {
  return static_cast<long>(std::count_if(cells.begin(), cells.end(), [&](int8_t v) {
    return v >= min_value && v <= max_value;
  }));
}

std::string poseOffMapProblem(const GridMapData& map, const Pose2& pose) {
  const double fx = (pose.x() - map.origin_x_m) / map.resolution_m;
  const double fy = (pose.y() - map.origin_y_m) / map.resolution_m;
  auto number = [](double v) {
    char text[32];
    std::snprintf(text, sizeof(text), "%g", std::round(v * 1e6) / 1e6 + 0.0);  // no 5.55e-17
    return std::string(text);
  };
  const std::string at = "(" + number(pose.x()) + ", " + number(pose.y()) + ")";
  if (!(fx >= 0.0 && fy >= 0.0 && fx < map.width && fy < map.height)) {
    return at + " is outside the map, x " + number(map.origin_x_m) + " .. " +
           number(map.origin_x_m + map.width * map.resolution_m) + " m, y " +
           number(map.origin_y_m) + " .. " +
           number(map.origin_y_m + map.height * map.resolution_m) + " m";
  }
  if (map.at(static_cast<int>(fx), static_cast<int>(fy)) >= 65) {
    return at + " is on an occupied cell of the map (inside a wall)";
  }
  return "";
}

GridMapData rasterizeLandmarks(const std::vector<LandmarkEstimate>& landmarks,
                               double resolution_m, double margin_m, double point_radius_m,
                               double max_cells) {
  if (!(resolution_m > 0.0)) throw std::invalid_argument("grid resolution must be > 0");
  double min_x = std::numeric_limits<double>::max(), min_y = min_x;
  double max_x = -min_x, max_y = -min_x;
  auto extend = [&](const Eigen::Vector2d& p) {
    if (!p.allFinite()) return;
    min_x = std::min(min_x, p.x());
    min_y = std::min(min_y, p.y());
    max_x = std::max(max_x, p.x());
    max_y = std::max(max_y, p.y());
  };
  for (const auto& l : landmarks) {
    if (l.type == LandmarkType::kLine) {
      extend(l.start);
      extend(l.end);
    } else {
      extend(l.mean + Eigen::Vector2d(point_radius_m, point_radius_m));
      extend(l.mean - Eigen::Vector2d(point_radius_m, point_radius_m));
    }
  }
  if (min_x > max_x) min_x = min_y = max_x = max_y = 0.0;
  GridMapData grid;
  grid.resolution_m = resolution_m;
  grid.origin_x_m = min_x - margin_m;
  grid.origin_y_m = min_y - margin_m;
  const double width = std::ceil((max_x + margin_m - grid.origin_x_m) / resolution_m);
  const double height = std::ceil((max_y + margin_m - grid.origin_y_m) / resolution_m);
  if (width * height > max_cells) {
    throw std::runtime_error("grid of " + std::to_string(width) + " x " + std::to_string(height) +
                             " cells is too large: raise the resolution");
  }
  grid.width = std::max(1, static_cast<int>(width));
  grid.height = std::max(1, static_cast<int>(height));
  grid.cells.assign(static_cast<size_t>(grid.width) * grid.height, -1);
  auto mark = [&](const Eigen::Vector2d& p) {
    const double fx = (p.x() - grid.origin_x_m) / resolution_m;
    const double fy = (p.y() - grid.origin_y_m) / resolution_m;
    if (!(fx >= 0.0 && fy >= 0.0 && fx < grid.width && fy < grid.height)) return;
    grid.cells[static_cast<size_t>(fy) * grid.width + static_cast<size_t>(fx)] = 100;
  };
  for (const auto& l : landmarks) {
    if (l.type == LandmarkType::kLine) {
      if (!l.start.allFinite() || !l.end.allFinite()) continue;
      const double length = (l.end - l.start).norm();
      const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * length / resolution_m)));
      for (int i = 0; i <= steps; ++i) mark(l.start + (l.end - l.start) * (double(i) / steps));
    } else {
      const double r = point_radius_m;
      for (double dx = -r; dx <= r; dx += 0.5 * resolution_m) {
        for (double dy = -r; dy <= r; dy += 0.5 * resolution_m) {
          if (dx * dx + dy * dy <= r * r) mark(l.mean + Eigen::Vector2d(dx, dy));
        }
      }
    }
  }
  return grid;
}

}  // namespace core
}  // namespace rbpf_slam

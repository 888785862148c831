#pragma once
// Draws landmarks and trajectories to scale into an RGB picture and writes it as PNG.

#include <cstdint>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace io {

/// An RGB raster with a metric frame: pixel (0, 0) is the top-left corner.
class MapImage {
 public:
  /// Covers [min, max] (metres) plus margin at resolution metres per pixel, coarsened where
  /// needed so that neither side exceeds 8000 pixels.
  MapImage(const Eigen::Vector2d& min, const Eigen::Vector2d& max, double resolution,
           double margin_m = 1.0);
  void line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const uint8_t rgb[3]);
  void dot(const Eigen::Vector2d& p, int radius_px, const uint8_t rgb[3]);
  /// Paints the pixels whose centres lie in the axis-aligned box [min, max) (metres).
  void fill(const Eigen::Vector2d& min, const Eigen::Vector2d& max, const uint8_t rgb[3]);
  /// Writes an 8-bit RGB PNG; throws std::runtime_error naming the path on failure.
  void writePng(const std::string& path) const;
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  void setPixel(int x, int y, const uint8_t rgb[3]);
  Eigen::Vector2d origin_;
  double resolution_;
  int width_, height_;
  std::vector<uint8_t> pixels_;
};

/// The standard picture of a run: trajectory (blue), reference (grey, optional), lines
/// (black segments) and points (red), with a 1 m grid (10 m, 100 m, ... on extents that would
/// need more than 200 lines a side).
void drawRunMap(const std::string& path, const std::vector<core::Pose2>& trajectory,
                const std::vector<core::Pose2>& reference,
                const std::vector<core::LandmarkEstimate>& landmarks, double resolution = 0.05);

}  // namespace io
}  // namespace rbpf_slam

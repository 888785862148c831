#include "rbpf_slam/io/map_image.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

namespace rbpf_slam {
namespace io {
namespace {

void putU32(std::vector<uint8_t>* out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back((v >> shift) & 0xff);
}

void writeChunk(std::ofstream& file, const char* type, const std::vector<uint8_t>& data) {
  std::vector<uint8_t> chunk;
  putU32(&chunk, static_cast<uint32_t>(data.size()));
  chunk.insert(chunk.end(), type, type + 4);
  chunk.insert(chunk.end(), data.begin(), data.end());
  const uint32_t crc = crc32(0L, chunk.data() + 4, static_cast<uInt>(chunk.size() - 4));
  putU32(&chunk, crc);
  file.write(reinterpret_cast<const char*>(chunk.data()), chunk.size());
}

}  // namespace

MapImage::MapImage(const Eigen::Vector2d& min, const Eigen::Vector2d& max, double resolution,
                   double margin_m)
    : origin_(min - Eigen::Vector2d::Constant(margin_m)), resolution_(resolution) {
  const Eigen::Vector2d size = (max - min).cwiseMax(0.0) + Eigen::Vector2d::Constant(2 * margin_m);
  // Coarser than asked when the extent would not fit in kMaxSidePx (a run that flew off, a
  // map point far away): the whole extent stays in the picture.
  constexpr double kMaxSidePx = 8000.0;
  if (std::isfinite(size.maxCoeff())) {
    resolution_ = std::max(resolution_, size.maxCoeff() / kMaxSidePx);
  }
  width_ = std::clamp(static_cast<int>(std::ceil(std::min(size.x() / resolution_, kMaxSidePx))),
                      1, static_cast<int>(kMaxSidePx));
  height_ = std::clamp(static_cast<int>(std::ceil(std::min(size.y() / resolution_, kMaxSidePx))),
                       1, static_cast<int>(kMaxSidePx));
  pixels_.assign(static_cast<size_t>(width_) * height_ * 3, 255);
}

void MapImage::setPixel(int x, int y, const uint8_t rgb[3]) {
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
  uint8_t* p = &pixels_[(static_cast<size_t>(y) * width_ + x) * 3];
  p[0] = rgb[0];
  p[1] = rgb[1];
  p[2] = rgb[2];
}

void MapImage::line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const uint8_t rgb[3]) {
  if (!a.allFinite() || !b.allFinite()) return;
  const Eigen::Vector2d pa = (a - origin_) / resolution_, pb = (b - origin_) / resolution_;
  const int steps = std::min(20000, static_cast<int>(std::ceil((pb - pa).norm())) + 1);
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector2d p = pa + (pb - pa) * (static_cast<double>(i) / steps);
    setPixel(static_cast<int>(p.x()), height_ - 1 - static_cast<int>(p.y()), rgb);
  }
}

void MapImage::dot(const Eigen::Vector2d& c, int radius_px, const uint8_t rgb[3]) {
  if (!c.allFinite()) return;
  const Eigen::Vector2d p = (c - origin_) / resolution_;
  for (int dy = -radius_px; dy <= radius_px; ++dy) {
    for (int dx = -radius_px; dx <= radius_px; ++dx) {
      if (dx * dx + dy * dy <= radius_px * radius_px) {
        setPixel(static_cast<int>(p.x()) + dx, height_ - 1 - static_cast<int>(p.y()) + dy, rgb);
      }
    }
  }
}

void MapImage::fill(const Eigen::Vector2d& min, const Eigen::Vector2d& max,
                    const uint8_t rgb[3]) {
  if (!min.allFinite() || !max.allFinite()) return;
  const Eigen::Vector2d a = (min - origin_) / resolution_, b = (max - origin_) / resolution_;
  const int x0 = std::max(0, static_cast<int>(std::ceil(a.x() - 0.5)));
  const int x1 = std::min(width_, static_cast<int>(std::ceil(b.x() - 0.5)));
  const int y0 = std::max(0, static_cast<int>(std::ceil(a.y() - 0.5)));
  const int y1 = std::min(height_, static_cast<int>(std::ceil(b.y() - 0.5)));
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) setPixel(x, height_ - 1 - y, rgb);
  }
}

void MapImage::writePng(const std::string& path) const {
  std::ofstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error(path + ": cannot open for writing");
  const uint8_t signature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
  file.write(reinterpret_cast<const char*>(signature), 8);
  std::vector<uint8_t> header;
  putU32(&header, width_);
  putU32(&header, height_);
  header.insert(header.end(), {8, 2, 0, 0, 0});  // 8-bit RGB, no interlace
  writeChunk(file, "IHDR", header);
  std::vector<uint8_t> raw;
  raw.reserve(pixels_.size() + height_);
  for (int y = 0; y < height_; ++y) {
    raw.push_back(0);  // filter: none
    const auto row = pixels_.begin() + static_cast<size_t>(y) * width_ * 3;
    raw.insert(raw.end(), row, row + width_ * 3);
  }
  uLongf size = compressBound(raw.size());
  std::vector<uint8_t> compressed(size);
  if (compress2(compressed.data(), &size, raw.data(), raw.size(), 6) != Z_OK) {
    throw std::runtime_error(path + ": PNG compression failed");
  }
  compressed.resize(size);
  writeChunk(file, "IDAT", compressed);
  writeChunk(file, "IEND", {});
  if (!file) throw std::runtime_error(path + ": write failed");
}

void drawRunMap(const std::string& path, const std::vector<core::Pose2>& trajectory,
                const std::vector<core::Pose2>& reference,
                const std::vector<core::LandmarkEstimate>& landmarks, double resolution) {
  Eigen::Vector2d min = Eigen::Vector2d::Constant(1e300), max = -min;
  auto extend = [&](const Eigen::Vector2d& p) {
    if (!p.allFinite()) return;
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  };
  for (const auto& p : trajectory) extend(p.head<2>());
  for (const auto& p : reference) extend(p.head<2>());
  for (const auto& l : landmarks) {
    extend(l.start);
    extend(l.end);
  }
  if (min.x() > max.x()) min = max = Eigen::Vector2d::Zero();
  MapImage image(min, max, resolution);
  const uint8_t grid[3] = {235, 235, 235}, grey[3] = {160, 160, 160}, blue[3] = {30, 90, 220};
  const uint8_t black[3] = {0, 0, 0}, red[3] = {220, 30, 30};
  // A 1 m grid, coarsened by tens to at most kMaxGridLines lines a side on a vast extent.
  constexpr double kMaxGridLines = 200.0;
  const double span = (max - min).maxCoeff();
  double spacing = 1.0;
  while (std::isfinite(span) && span / spacing > kMaxGridLines) spacing *= 10.0;
  const Eigen::Vector2d first = (min / spacing).array().floor() * spacing - spacing;
  const Eigen::Vector2d lines = ((max - first) / spacing).array().floor() + 1.0;
  for (int k = 0; std::isfinite(span) && k <= static_cast<int>(lines.x()); ++k) {
    const double x = first.x() + k * spacing;
    image.line({x, min.y() - spacing}, {x, max.y() + spacing}, grid);
  }
  for (int k = 0; std::isfinite(span) && k <= static_cast<int>(lines.y()); ++k) {
    const double y = first.y() + k * spacing;
    image.line({min.x() - spacing, y}, {max.x() + spacing, y}, grid);
  }
  for (size_t i = 1; i < reference.size(); ++i) {
    image.line(reference[i - 1].head<2>(), reference[i].head<2>(), grey);
  }
  for (size_t i = 1; i < trajectory.size(); ++i) {
    image.line(trajectory[i - 1].head<2>(), trajectory[i].head<2>(), blue);
  }
  for (const auto& l : landmarks) {
    if (l.type == core::LandmarkType::kLine) {
      image.line(l.start, l.end, black);
    } else {
      image.dot(l.mean, 2, red);
    }
  }
  image.writePng(path);
}

}  // namespace io
}  // namespace rbpf_slam

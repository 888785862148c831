#include "rbpf_slam/core/grid/tiled_grid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_set>

namespace rbpf_slam {
namespace core {

TiledLogOddsGrid::TiledLogOddsGrid(double resolution_m, double origin_x_m, double origin_y_m,
                                   int width, int height, int tile_cells)
    : resolution_m_(resolution_m),
      inverse_resolution_(1.0 / resolution_m),
      origin_x_m_(origin_x_m),
      origin_y_m_(origin_y_m),
      base_x_m_(origin_x_m),
      base_y_m_(origin_y_m),
      width_(width),
      height_(height),
      tile_cells_(tile_cells) {
  if (!(resolution_m > 0.0) || width <= 0 || height <= 0 || tile_cells <= 0) {
    throw std::invalid_argument("TiledLogOddsGrid: resolution, size and tile size must be > 0");
  }
  tiles_x_ = (width + tile_cells - 1) / tile_cells;
  tiles_y_ = (height + tile_cells - 1) / tile_cells;
  tiles_.resize(static_cast<size_t>(tiles_x_) * tiles_y_);
}

void TiledLogOddsGrid::add(int cx, int cy, float delta, float clamp) {
  std::shared_ptr<Tile>& tile = tiles_[tileIndex(cx, cy)];
  if (!tile) {
    tile = std::make_shared<Tile>();
    tile->cells.assign(static_cast<size_t>(tile_cells_) * tile_cells_, 0.0f);
  } else if (tile.use_count() > 1) {
    tile = std::make_shared<Tile>(*tile);  // copy on first write
  }
  float& cell = tile->cells[cellIndex(cx, cy)];
  cell = std::max(-clamp, std::min(clamp, cell + delta));
}

namespace {

/// One axis of TiledLogOddsGrid::grow: the tile range [first, end) grown toward the box's tiles
/// lo .. hi (doubles: a far corner must not overflow an int), at most `limit` tiles long and
/// never losing [first, end). When the box does not fit, a window of `limit` tiles as nearly
/// centred on the box (the robot) as [first, end) allows. Returns whether the box is held.
bool growAxis(int first, int end, double lo, double hi, int limit, bool extra, int* new_first,
              int* new_end) {
  const double need_first = std::min<double>(first, lo);
  const double need_end = std::max<double>(end, hi + 1.0);
  if (need_end - need_first <= limit) {
    *new_first = static_cast<int>(need_first);
    *new_end = static_cast<int>(need_end);
    // One tile more on a side that grows, when it fits: the next growth comes a tile later.
    int slack = extra ? limit - (*new_end - *new_first) : 0;
    if (*new_first < first && slack > 0) --*new_first, --slack;
    if (*new_end > end && slack > 0) ++*new_end;
    return true;
  }
  *new_first = first;
  *new_end = end;
  if (end - first >= limit) return false;
  double centre = std::floor(0.5 * (lo + hi));
  if (!std::isfinite(centre)) centre = 0.5 * (first + end);
  double start = std::clamp(centre - std::floor(0.5 * limit), static_cast<double>(end - limit),
                            static_cast<double>(first));
  start = std::max(start, need_first);
  *new_first = static_cast<int>(start);
  *new_end = static_cast<int>(std::min(start + limit, need_end));
  return false;
}

}  // namespace

bool TiledLogOddsGrid::grow(const Eigen::Vector2d& min, const Eigen::Vector2d& max, int max_tiles_x,
                            int max_tiles_y, long max_tiles) {
  if (!min.allFinite() || !max.allFinite() || tiles_.empty()) return false;
  if (contains(min, max)) return true;
  const double tile_m = tile_cells_ * resolution_m_;
  const double lo_x = std::floor((min.x() - base_x_m_) / tile_m);
  const double hi_x = std::floor((max.x() - base_x_m_) / tile_m);
  const double lo_y = std::floor((min.y() - base_y_m_) / tile_m);
  const double hi_y = std::floor((max.y() - base_y_m_) / tile_m);
  int x0, x1, y0, y1;
  bool whole_x = false, whole_y = false;
  for (const bool extra : {true, false}) {  // without the extra tiles when memory is short
    whole_x =
        growAxis(first_tile_x_, first_tile_x_ + tiles_x_, lo_x, hi_x, max_tiles_x, extra, &x0, &x1);
    whole_y =
        growAxis(first_tile_y_, first_tile_y_ + tiles_y_, lo_y, hi_y, max_tiles_y, extra, &y0, &y1);
    if (static_cast<double>(x1 - x0) * (y1 - y0) <= static_cast<double>(max_tiles)) break;
  }
  if (static_cast<double>(x1 - x0) * (y1 - y0) > static_cast<double>(max_tiles)) return false;
  reshape(x0, x1, y0, y1);
  if (!(whole_x && whole_y)) return false;
  if (contains(min, max)) return true;
  // The box's tiles come from the lattice, cellOf from the origin: at an edge the two can round
  // apart. One tile more on each side cellOf still refuses, within the limits.
  const double fx0 = (min.x() - origin_x_m_) * inverse_resolution_;
  const double fy0 = (min.y() - origin_y_m_) * inverse_resolution_;
  const double fx1 = (max.x() - origin_x_m_) * inverse_resolution_;
  const double fy1 = (max.y() - origin_y_m_) * inverse_resolution_;
  x0 -= fx0 < 0.0;
  y0 -= fy0 < 0.0;
  x1 += fx1 >= width_;
  y1 += fy1 >= height_;
  if (x1 - x0 > max_tiles_x || y1 - y0 > max_tiles_y ||
      static_cast<double>(x1 - x0) * (y1 - y0) > static_cast<double>(max_tiles)) {
    return false;
  }
  reshape(x0, x1, y0, y1);
  return contains(min, max);
}

void TiledLogOddsGrid::reshape(int first_x, int end_x, int first_y, int end_y) {
  if (first_x == first_tile_x_ && first_y == first_tile_y_ && end_x - first_x == tiles_x_ &&
      end_y - first_y == tiles_y_) {
    width_ = tiles_x_ * tile_cells_;  // a first extent cut inside its last tile is completed
    height_ = tiles_y_ * tile_cells_;
    return;
  }
  const int nx = end_x - first_x, ny = end_y - first_y;
  std::vector<std::shared_ptr<Tile>> tiles(static_cast<size_t>(nx) * ny);
  for (int ty = 0; ty < tiles_y_; ++ty) {
    for (int tx = 0; tx < tiles_x_; ++tx) {
      const size_t to =
          static_cast<size_t>(first_tile_y_ + ty - first_y) * nx + (first_tile_x_ + tx - first_x);
      tiles[to] = std::move(tiles_[static_cast<size_t>(ty) * tiles_x_ + tx]);
    }
  }
  tiles_ = std::move(tiles);
  first_tile_x_ = first_x;
  first_tile_y_ = first_y;
  tiles_x_ = nx;
  tiles_y_ = ny;
  width_ = tiles_x_ * tile_cells_;
  height_ = tiles_y_ * tile_cells_;
  const double tile_m = tile_cells_ * resolution_m_;
  origin_x_m_ = base_x_m_ + first_tile_x_ * tile_m;
  origin_y_m_ = base_y_m_ + first_tile_y_ * tile_m;
}

int TiledLogOddsGrid::allocatedTiles() const {
  int n = 0;
  for (const auto& t : tiles_) n += t ? 1 : 0;
  return n;
}

int TiledLogOddsGrid::exclusiveTiles() const {
  int n = 0;
  for (const auto& t : tiles_) n += (t && t.use_count() == 1) ? 1 : 0;
  return n;
}

long TiledLogOddsGrid::distinctTiles(const std::vector<const TiledLogOddsGrid*>& grids) {
  std::unordered_set<const void*> seen;
  for (const TiledLogOddsGrid* g : grids) {
    for (const auto& t : g->tiles_) {
      if (t) seen.insert(t.get());
    }
  }
  return static_cast<long>(seen.size());
}

GridMapData TiledLogOddsGrid::toGridMap() const {
  GridMapData out;
  out.resolution_m = resolution_m_;
  int min_tx = tiles_x_, min_ty = tiles_y_, max_tx = -1, max_ty = -1;
  for (int ty = 0; ty < tiles_y_; ++ty) {
    for (int tx = 0; tx < tiles_x_; ++tx) {
      if (!tiles_[static_cast<size_t>(ty) * tiles_x_ + tx]) continue;
      min_tx = std::min(min_tx, tx);
      max_tx = std::max(max_tx, tx);
      min_ty = std::min(min_ty, ty);
      max_ty = std::max(max_ty, ty);
    }
  }
  if (max_tx < 0) {
    out.origin_x_m = origin_x_m_;
    out.origin_y_m = origin_y_m_;
    return out;
  }
  const int x0 = min_tx * tile_cells_, y0 = min_ty * tile_cells_;
  const int x1 = std::min(width_, (max_tx + 1) * tile_cells_);
  const int y1 = std::min(height_, (max_ty + 1) * tile_cells_);
  out.origin_x_m = origin_x_m_ + x0 * resolution_m_;
  out.origin_y_m = origin_y_m_ + y0 * resolution_m_;
  out.width = x1 - x0;
  out.height = y1 - y0;
  out.cells.assign(static_cast<size_t>(out.width) * out.height, -1);
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      const float l = logOdds(x, y);
      if (l == 0.0f) continue;
      const double p = 1.0 - 1.0 / (1.0 + std::exp(static_cast<double>(l)));
      out.cells[static_cast<size_t>(y - y0) * out.width + (x - x0)] =
          static_cast<int8_t>(std::lround(100.0 * p));
    }
  }
  return out;
}

}  // namespace core
}  // namespace rbpf_slam

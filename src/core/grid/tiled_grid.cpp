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

bool TiledLogOddsGrid::grow(const Eigen::Vector2d& min, const Eigen::Vector2d& max, int max_tiles_x,
                            int max_tiles_y, long max_tiles) {
  if (!min.allFinite() || !max.allFinite() || tiles_.empty()) return false;
  if (contains(min, max)) return true;
  const double tile_m = tile_cells_ * resolution_m_;
  // The box's tiles on the lattice, in doubles first: a far corner must not overflow an int.
  const double lo_x = std::floor((min.x() - base_x_m_) / tile_m);
  const double lo_y = std::floor((min.y() - base_y_m_) / tile_m);
  const double hi_x = std::floor((max.x() - base_x_m_) / tile_m);
  const double hi_y = std::floor((max.y() - base_y_m_) / tile_m);
  const double first_x = std::min<double>(first_tile_x_, lo_x);
  const double first_y = std::min<double>(first_tile_y_, lo_y);
  const double end_x = std::max<double>(first_tile_x_ + tiles_x_, hi_x + 1);
  const double end_y = std::max<double>(first_tile_y_ + tiles_y_, hi_y + 1);
  if (end_x - first_x > max_tiles_x || end_y - first_y > max_tiles_y ||
      (end_x - first_x) * (end_y - first_y) > static_cast<double>(max_tiles)) {
    return false;
  }
  // Each side that must grow gets at least a quarter of the extent more, within the limits.
  auto widen = [](int first, int end, int limit, int* need_first, int* need_end) {
    int slack = limit - (*need_end - *need_first);
    const int extra = std::max(1, (end - first) / 4);
    if (*need_first < first) {
      const int more = std::min(extra, slack);
      *need_first -= more;
      slack -= more;
    }
    if (*need_end > end) *need_end += std::min(extra, slack);
  };
  const int need_x0 = static_cast<int>(first_x), need_x1 = static_cast<int>(end_x);
  const int need_y0 = static_cast<int>(first_y), need_y1 = static_cast<int>(end_y);
  int nx0 = need_x0, nx1 = need_x1, ny0 = need_y0, ny1 = need_y1;
  widen(first_tile_x_, first_tile_x_ + tiles_x_, max_tiles_x, &nx0, &nx1);
  widen(first_tile_y_, first_tile_y_ + tiles_y_, max_tiles_y, &ny0, &ny1);
  if (static_cast<double>(nx1 - nx0) * (ny1 - ny0) > static_cast<double>(max_tiles)) {
    nx0 = need_x0, nx1 = need_x1, ny0 = need_y0, ny1 = need_y1;  // no margin beyond the box
  }
  std::vector<std::shared_ptr<Tile>> tiles(static_cast<size_t>(nx1 - nx0) * (ny1 - ny0));
  for (int ty = 0; ty < tiles_y_; ++ty) {
    for (int tx = 0; tx < tiles_x_; ++tx) {
      const size_t to =
          static_cast<size_t>(first_tile_y_ + ty - ny0) * (nx1 - nx0) + (first_tile_x_ + tx - nx0);
      tiles[to] = std::move(tiles_[static_cast<size_t>(ty) * tiles_x_ + tx]);
    }
  }
  tiles_ = std::move(tiles);
  first_tile_x_ = nx0;
  first_tile_y_ = ny0;
  tiles_x_ = nx1 - nx0;
  tiles_y_ = ny1 - ny0;
  width_ = tiles_x_ * tile_cells_;
  height_ = tiles_y_ * tile_cells_;
  origin_x_m_ = base_x_m_ + first_tile_x_ * tile_m;
  origin_y_m_ = base_y_m_ + first_tile_y_ * tile_m;
  return true;
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

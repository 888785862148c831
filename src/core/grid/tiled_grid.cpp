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

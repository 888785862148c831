#pragma once
// A log-odds occupancy grid stored in square tiles held by shared_ptr: copying a grid copies
// pointers, and a tile is duplicated only when a grid that shares it writes to it
// (copy-on-write), so N particles cost one map plus the tiles each has changed.

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "rbpf_slam/core/grid/grid_map_data.h"

namespace rbpf_slam {
namespace core {

/// One particle's log-odds map; cells never written read 0 (unknown). Its extent is set when
/// it is made and can grow by whole tiles (grow): tiles stay on the lattice of the first
/// extent, so grids that grew differently still share their tiles.
class TiledLogOddsGrid {
 public:
  TiledLogOddsGrid() = default;
  /// width x height cells of resolution_m, cell (0, 0)'s corner at (origin_x_m, origin_y_m).
  TiledLogOddsGrid(double resolution_m, double origin_x_m, double origin_y_m, int width,
                   int height, int tile_cells);

  /// Cell containing p; false when p is outside the grid.
  bool cellOf(const Eigen::Vector2d& p, int* cx, int* cy) const {
    const double fx = (p.x() - origin_x_m_) * inverse_resolution_;
    const double fy = (p.y() - origin_y_m_) * inverse_resolution_;
    if (!(fx >= 0.0 && fy >= 0.0 && fx < width_ && fy < height_)) return false;
    *cx = static_cast<int>(fx);
    *cy = static_cast<int>(fy);
    return true;
  }
  /// True when the box [min, max] lies inside the grid.
  bool contains(const Eigen::Vector2d& min, const Eigen::Vector2d& max) const {
    int cx, cy;
    return cellOf(min, &cx, &cy) && cellOf(max, &cx, &cy);
  }
  /// Extends the grid by whole tiles so that it contains the box [min, max] (and one tile more
  /// on each side that grows, when that fits). Cell indices change when the grid grows to -x or
  /// -y; world positions keep their log odds. The grid never grows beyond max_tiles_x x
  /// max_tiles_y tiles: along an axis where the box does not fit, it grows up to that limit as
  /// nearly centred on the box's centre as the present extent allows. Returns whether the grid
  /// holds the whole box. A box with a non-finite corner, or a growth to more than max_tiles
  /// tiles in all (the memory limit), leaves the grid as it was.
  bool grow(const Eigen::Vector2d& min, const Eigen::Vector2d& max, int max_tiles_x,
            int max_tiles_y, long max_tiles);

  /// Moves the whole grid so that cell (0, 0)'s corner is at (origin_x_m, origin_y_m): every
  /// cell keeps its index and value, the tile lattice moves with it.
  void moveTo(double origin_x_m, double origin_y_m) {
    base_x_m_ = origin_x_m - (origin_x_m_ - base_x_m_);  // exactly the origin when they agree
    base_y_m_ = origin_y_m - (origin_y_m_ - base_y_m_);
    origin_x_m_ = origin_x_m;
    origin_y_m_ = origin_y_m;
  }
  /// Log odds of an inside cell (0 when its tile was never written).
  float logOdds(int cx, int cy) const {
    const Tile* tile = tiles_[tileIndex(cx, cy)].get();
    return tile ? tile->cells[cellIndex(cx, cy)] : 0.0f;
  }
  /// Adds delta to an inside cell and clamps to [-clamp, clamp]; copies the tile first when
  /// another grid shares it.
  void add(int cx, int cy, float delta, float clamp);

  double resolution() const { return resolution_m_; }
  double originX() const { return origin_x_m_; }
  double originY() const { return origin_y_m_; }
  int width() const { return width_; }
  int height() const { return height_; }
  int tileCells() const { return tile_cells_; }
  int tilesX() const { return tiles_x_; }
  int tilesY() const { return tiles_y_; }
  /// Tiles this grid has allocated (shared or not).
  int allocatedTiles() const;
  /// Tiles this grid holds that no other grid holds.
  int exclusiveTiles() const;
  /// Bytes of one tile's cells.
  size_t tileBytes() const { return sizeof(float) * tile_cells_ * tile_cells_; }
  /// Distinct tiles over a set of grids (the memory they really use is this times tileBytes).
  static long distinctTiles(const std::vector<const TiledLogOddsGrid*>& grids);

  /// Occupancy in nav_msgs/OccupancyGrid conventions over the bounding box of the allocated
  /// tiles: -1 where the log odds are 0, else round(100 p).
  GridMapData toGridMap() const;

 private:
  struct Tile {
    std::vector<float> cells;
  };
  int tileIndex(int cx, int cy) const {
    return (cy / tile_cells_) * tiles_x_ + cx / tile_cells_;
  }
  /// Tiles first_x .. end_x - 1 x first_y .. end_y - 1 of the lattice, a range holding the
  /// present one: moves the tile pointers (no tile is copied).
  void reshape(int first_x, int end_x, int first_y, int end_y);
  int cellIndex(int cx, int cy) const {
    return (cy % tile_cells_) * tile_cells_ + cx % tile_cells_;
  }

  double resolution_m_ = 0.05;
  double inverse_resolution_ = 20.0;
  double origin_x_m_ = 0.0, origin_y_m_ = 0.0;  // cell (0, 0)'s corner
  // The first extent's corner and this grid's first tile on that lattice (<= 0 after growing
  // to -x / -y): origin = base + first tile x tile side, computed the same way in every grid.
  double base_x_m_ = 0.0, base_y_m_ = 0.0;
  int first_tile_x_ = 0, first_tile_y_ = 0;
  int width_ = 0, height_ = 0;
  int tile_cells_ = 64;
  int tiles_x_ = 0, tiles_y_ = 0;
  std::vector<std::shared_ptr<Tile>> tiles_;
};

}  // namespace core
}  // namespace rbpf_slam

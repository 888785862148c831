// Occupancy-grid PF-SLAM (variant grid_pf, Yatim and Buniyamin 2015): the wheel model's
// statistics (eqs. 11, 12), the inverse sensor models on hand cases (eq. 13), copy-on-write
// tile sharing, the map-matching weight (eq. 14), raw readings through the pipeline, and the
// landmark rasterisation every other variant's map uses.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <memory>
#include <random>
#include <set>
#include <vector>

#include "rbpf_slam/core/filters/pose_moments.h"
#include "rbpf_slam/core/grid/grid_map_data.h"
#include "rbpf_slam/core/grid/grid_pf.h"
#include "rbpf_slam/core/grid/inverse_sensor_model.h"
#include "rbpf_slam/core/grid/tiled_grid.h"
#include "rbpf_slam/core/slam/slam_pipeline.h"
#include "rbpf_slam/core/slam/slam_session.h"
#include "rbpf_slam/io/grid_map_file.h"
#include "rbpf_slam/io/slam_config.h"

namespace rbpf_slam {
namespace core {
namespace {

TEST(WheelModel, SigmasFollowEquation12) {
  double sl, sr;
  wheelTravelSigmas(0.10, 0.14, 0.05, 0.2, &sl, &sr);
  EXPECT_NEAR(sl, std::sqrt(std::pow(0.05 * 0.10, 2) + std::pow(0.2 * 0.04, 2)), 1e-12);
  EXPECT_NEAR(sr, std::sqrt(std::pow(0.05 * 0.14, 2) + std::pow(0.2 * 0.04, 2)), 1e-12);
  double l, r;
  wheelTravel(Pose2(0.12, 0.0, 0.4 / 0.5 * 0.1), 0.5, &l, &r);  // dtheta = (r - l) / b
  EXPECT_NEAR(l + r, 0.24, 1e-12);
  EXPECT_NEAR(r - l, 0.5 * 0.08, 1e-12);
}

TEST(WheelModel, SampledWheelTravelHasTheEquation12Statistics) {
  MotionOptions o;
  o.model = "diff_drive";
  o.wheel_base_m = 0.2;
  o.wheel_alpha1 = 0.1;
  o.wheel_alpha2 = 0.3;
  o.min_sigma_xy_m = 0.0;
  o.min_sigma_theta_rad = 0.0;
  const auto model = createMotionModel(o);
  MotionInput motion;
  // Equation 11 with l = 0.2, r = 0.3: d = 0.25, dtheta = 0.5; the chord is at dtheta / 2.
  motion.delta = Pose2(0.25 * std::cos(0.25), 0.25 * std::sin(0.25), 0.5);
  double l0, r0, sl, sr;
  wheelTravel(motion.delta, o.wheel_base_m, &l0, &r0);
  ASSERT_NEAR(l0, 0.2, 1e-9);
  ASSERT_NEAR(r0, 0.3, 1e-9);
  wheelTravelSigmas(l0, r0, o.wheel_alpha1, o.wheel_alpha2, &sl, &sr);
  Rng rng(7);
  const int n = 40000;
  double sum_l = 0, sum_r = 0, sq_l = 0, sq_r = 0, cross = 0;
  const Pose2 start(1.0, -2.0, 0.3);
  for (int i = 0; i < n; ++i) {
    const Pose2 delta = between(start, model->sample(start, motion, rng));
    double l, r;  // back from the sampled pose to the sampled wheel travel
    wheelTravel(delta, o.wheel_base_m, &l, &r);
    sum_l += l;
    sum_r += r;
    sq_l += l * l;
    sq_r += r * r;
    cross += l * r;
  }
  const double ml = sum_l / n, mr = sum_r / n;
  EXPECT_NEAR(ml, 0.2, 4.0 * sl / std::sqrt(n));
  EXPECT_NEAR(mr, 0.3, 4.0 * sr / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(sq_l / n - ml * ml), sl, 0.03 * sl);
  EXPECT_NEAR(std::sqrt(sq_r / n - mr * mr), sr, 0.03 * sr);
  // l and r are drawn independently.
  EXPECT_NEAR((cross / n - ml * mr) / (sl * sr), 0.0, 0.03);
}

int countCells(const std::vector<LocalMapCell>& cells, bool occupied) {
  int n = 0;
  for (const auto& c : cells) n += c.occupied == occupied ? 1 : 0;
  return n;
}

TEST(InverseSensorModel, LaserBeamFreesItsPathAndOccupiesItsEnd) {
  GridOptions o;
  o.resolution_m = 0.05;
  auto scan = std::make_shared<RangeScan>();
  scan->angle_min = 0.0;
  scan->angle_increment = 0.1;
  scan->range_min = 0.1;
  scan->range_max = 10.0;
  scan->ranges = {1.0f, NAN, INFINITY};
  FeatureSet features;
  features.scan = scan;
  LocalMapStats stats;
  const std::vector<LocalMapCell> cells = buildLocalMap(features, o, &stats);
  EXPECT_EQ(stats.readings, 3);
  EXPECT_EQ(stats.echoes, 1);
  EXPECT_EQ(stats.rejected, 1);  // NaN
  EXPECT_EQ(stats.no_echo, 1);   // +inf frees nothing with laser_no_return_free_m = 0
  ASSERT_EQ(countCells(cells, true), 1);
  EXPECT_EQ(countCells(cells, false), 20);  // [0, 0.95] in 5 cm cells
  for (const auto& c : cells) {
    if (c.occupied) {
      EXPECT_NEAR(c.center.x(), 1.025, 1e-9);
      EXPECT_NEAR(c.center.y(), 0.025, 1e-9);
    } else {
      EXPECT_LT(c.center.x(), 1.0);
    }
  }
}

TEST(InverseSensorModel, ConeEchoOccupiesTheArcAndFreesTheConeInside) {
  GridOptions o;
  o.resolution_m = 0.01;
  ConeReading r;
  r.range = 0.5;
  r.min_range = 0.02;
  r.max_range = 3.0;
  r.field_of_view = 0.3;
  r.sensor_pose = Pose2(0.1, 0.0, M_PI / 2);  // looking along +y
  LocalMapBuilder builder(o.resolution_m);
  LocalMapStats stats;
  ASSERT_TRUE(addConeReading(r, o, &builder, &stats));
  const std::vector<LocalMapCell> cells = builder.finish();
  EXPECT_EQ(stats.echoes, 1);
  int occupied = 0, free = 0;
  for (const auto& c : cells) {
    const Eigen::Vector2d v = c.center - Eigen::Vector2d(0.1, 0.0);
    EXPECT_GT(v.y(), 0.0);  // nothing behind the transducer
    const double off_axis = std::fabs(std::atan2(v.x(), v.y()));
    EXPECT_LE(off_axis, 0.15 + std::atan(0.005 / v.norm()) + 1e-9);
    if (c.occupied) {
      ++occupied;
      EXPECT_NEAR(v.norm(), 0.5, 0.005 + 1e-9);
    } else {
      ++free;
      EXPECT_LT(v.norm(), 0.5);
    }
  }
  // The arc spans 0.3 rad at 0.5 m: about 15 cells; the sector about 0.5^2 * 0.15 / 1e-4 cells.
  EXPECT_GE(occupied, 12);
  EXPECT_LE(occupied, 40);
  EXPECT_GT(free, 250);
  EXPECT_LT(free, 500);
}

TEST(InverseSensorModel, ConeAtMaxRangeOnlyFrees) {
  GridOptions o;
  o.resolution_m = 0.01;
  ConeReading r;
  r.range = 0.07;
  r.max_range = 0.07;
  r.field_of_view = 0.35;
  LocalMapBuilder builder(o.resolution_m);
  LocalMapStats stats;
  ASSERT_TRUE(addConeReading(r, o, &builder, &stats));
  const std::vector<LocalMapCell> cells = builder.finish();
  EXPECT_EQ(stats.no_echo, 1);
  EXPECT_EQ(countCells(cells, true), 0);
  EXPECT_GT(countCells(cells, false), 3);
  for (const auto& c : cells) EXPECT_LE(c.center.norm(), 0.07);
  // Rejected: NaN, below the minimum range, a cone of zero width.
  r.range = NAN;
  EXPECT_FALSE(addConeReading(r, o, &builder, &stats));
  r.range = 0.001;
  r.min_range = 0.005;
  EXPECT_FALSE(addConeReading(r, o, &builder, &stats));
  r.range = 0.05;
  r.field_of_view = 0.0;
  EXPECT_FALSE(addConeReading(r, o, &builder, &stats));
  EXPECT_EQ(stats.rejected, 3);
  EXPECT_TRUE(builder.finish().empty());
}

// grid_pf_sonar.yaml's case: cone_max_range_m 3, no_echo_free_range_m 1, sonar max 5 m. An
// echo at 4 m counts as none: it frees 1 m of the cone, as a reading without an echo, and
// marks no arc (freeing up to 3 m made the sonar world worse, inverse_sensor_model.cpp).
TEST(InverseSensorModel, AnEchoBeyondTheConeMaximumCountsAsNone) {
  GridOptions o;
  o.resolution_m = 0.1;
  o.cone_max_range_m = 3.0;
  o.no_echo_free_range_m = 1.0;
  ConeReading r;
  r.max_range = 5.0;
  r.field_of_view = 0.3;
  auto farthest = [&](double range, LocalMapStats* stats) {
    r.range = range;
    LocalMapBuilder builder(o.resolution_m);
    EXPECT_TRUE(addConeReading(r, o, &builder, stats));
    double far = 0.0;
    for (const auto& c : builder.finish()) {
      EXPECT_FALSE(c.occupied) << range;
      far = std::max(far, c.center.norm());
    }
    return far;
  };
  LocalMapStats stats;
  EXPECT_NEAR(farthest(4.0, &stats), 1.0, 0.1);
  EXPECT_NEAR(farthest(5.0, &stats), 1.0, 0.1);  // at max range: no echo
  EXPECT_EQ(stats.no_echo, 2);
  EXPECT_EQ(stats.echoes, 0);
  // Within cone_max_range_m: an echo, its arc occupied.
  r.range = 2.5;
  LocalMapBuilder builder(o.resolution_m);
  EXPECT_TRUE(addConeReading(r, o, &builder, &stats));
  EXPECT_GT(countCells(builder.finish(), true), 0);
  EXPECT_EQ(stats.echoes, 1);
}

// A reading beyond the grid's diagonal is refused: one 100 m glitch (or a driver's max_range
// left at 0, read as unbounded) visited 25 million cells at 1 cm. No cone reaches further than
// the diagonal either.
TEST(InverseSensorModel, ReadingsBeyondTheGridAreRefusedAndNoConeOutgrowsIt) {
  GridOptions o;
  o.resolution_m = 0.01;
  o.size_x_m = o.size_y_m = 2.0;
  ConeReading r;
  r.max_range = INFINITY;
  r.field_of_view = 0.3;
  r.range = 100.0;
  LocalMapBuilder builder(o.resolution_m);
  LocalMapStats stats;
  EXPECT_FALSE(addConeReading(r, o, &builder, &stats));
  EXPECT_EQ(stats.rejected, 1);
  EXPECT_EQ(stats.beyond_reach, 1) << "counted apart: the grid's first extent is too small";
  EXPECT_TRUE(builder.finish().empty());
  // A sensor whose maximum is far beyond the grid, without an echo: freed to the diagonal.
  r.max_range = 1e6;
  r.range = 1e6;
  EXPECT_TRUE(addConeReading(r, o, &builder, &stats));
  double far = 0.0;
  for (const auto& c : builder.finish()) far = std::max(far, c.center.norm());
  EXPECT_LE(far, std::hypot(2.0, 2.0));
  EXPECT_EQ(stats.no_echo, 1);
  // An unset maximum (ConeReading's default 0) is refused, not taken as "no echo".
  r.max_range = 0.0;
  r.range = 0.5;
  EXPECT_FALSE(addConeReading(r, o, &builder, &stats));
  EXPECT_EQ(stats.rejected, 2);
  EXPECT_EQ(stats.beyond_reach, 1);
}

TEST(InverseSensorModel, NoLaserBeamIsTracedBeyondTheGrid) {
  // laser_no_return_free_m = 1000 m at 1 cm: 100000 cells a beam before; the grid is 2 m.
  GridOptions o;
  o.resolution_m = 0.01;
  o.size_x_m = o.size_y_m = 2.0;
  o.laser_no_return_free_m = 1000.0;
  o.laser_max_range_m = 1000.0;
  RangeScan scan;
  scan.angle_min = -1.0;
  scan.angle_increment = 0.5;
  scan.range_min = 0.1;
  scan.range_max = 2000.0;
  scan.ranges = {INFINITY, 2000.0, 900.0, 1.0, INFINITY};  // none, max, far echo, echo, none
  LocalMapBuilder builder(o.resolution_m);
  LocalMapStats stats;
  addRangeScan(scan, o, &builder, &stats);
  const auto cells = builder.finish();
  double far = 0.0;
  for (const auto& c : cells) far = std::max(far, c.center.norm());
  EXPECT_LE(far, std::hypot(2.0, 2.0) + o.resolution_m);
  EXPECT_LT(cells.size(), 5u * 300u);
  EXPECT_EQ(stats.echoes, 1);
  EXPECT_EQ(stats.no_echo, 4);
  EXPECT_EQ(stats.beyond_reach, 1);  // the echo at 900 m
}

TEST(TiledGrid, CopiesShareTilesUntilTheFirstWrite) {
  TiledLogOddsGrid a(0.05, -10.0, -10.0, 400, 400, 64);  // 20 m x 20 m, 7 x 7 tiles
  EXPECT_EQ(a.allocatedTiles(), 0);
  EXPECT_EQ(a.logOdds(10, 10), 0.0f);
  a.add(10, 10, 1.0f, 5.0f);
  a.add(300, 300, 1.0f, 5.0f);
  EXPECT_EQ(a.allocatedTiles(), 2);
  EXPECT_EQ(a.exclusiveTiles(), 2);

  std::vector<TiledLogOddsGrid> copies(99, a);  // 100 grids, still 2 tiles
  EXPECT_EQ(a.exclusiveTiles(), 0);
  std::vector<const TiledLogOddsGrid*> all{&a};
  for (const auto& c : copies) all.push_back(&c);
  EXPECT_EQ(TiledLogOddsGrid::distinctTiles(all), 2);

  copies[0].add(11, 10, -0.5f, 5.0f);  // one write: one tile copied, in that grid only
  EXPECT_EQ(TiledLogOddsGrid::distinctTiles(all), 3);
  EXPECT_EQ(copies[0].exclusiveTiles(), 1);
  EXPECT_EQ(copies[0].allocatedTiles(), 2);
  EXPECT_FLOAT_EQ(copies[0].logOdds(11, 10), -0.5f);
  EXPECT_FLOAT_EQ(copies[0].logOdds(10, 10), 1.0f);  // the copy kept the shared content
  EXPECT_FLOAT_EQ(a.logOdds(11, 10), 0.0f);          // the original did not change
  EXPECT_FLOAT_EQ(copies[1].logOdds(11, 10), 0.0f);
  copies[0].add(11, 10, -0.5f, 5.0f);  // writing again: no further copy
  EXPECT_EQ(TiledLogOddsGrid::distinctTiles(all), 3);
  // Clamp.
  for (int i = 0; i < 20; ++i) copies[0].add(11, 10, -1.0f, 5.0f);
  EXPECT_FLOAT_EQ(copies[0].logOdds(11, 10), -5.0f);
  int cx, cy;
  EXPECT_FALSE(a.cellOf(Eigen::Vector2d(10.0, 0.0), &cx, &cy));
  ASSERT_TRUE(a.cellOf(Eigen::Vector2d(-9.97, -9.92), &cx, &cy));
  EXPECT_EQ(cx, 0);
  EXPECT_EQ(cy, 1);
}

// Growing moves the tile table, not the tiles: every world position keeps its log odds, grids
// that grew differently still share the tiles they had, and cells are found at their new
// indices. Growth stops at the limits, and a box with a non-finite corner grows nothing.
TEST(TiledGrid, GrowingKeepsEveryCellAndTheSharing) {
  TiledLogOddsGrid a(0.1, -1.0, -1.0, 20, 20, 8);  // 2 m x 2 m, 3 x 3 tiles of 0.8 m
  const Eigen::Vector2d p(0.35, -0.55), q(0.95, 0.95);
  int cx, cy;
  ASSERT_TRUE(a.cellOf(p, &cx, &cy));
  a.add(cx, cy, 2.0f, 5.0f);
  ASSERT_TRUE(a.cellOf(q, &cx, &cy));  // in the last tile, which the first extent cuts at 20
  a.add(cx, cy, -1.0f, 5.0f);
  TiledLogOddsGrid b = a;  // shares both tiles

  const Eigen::Vector2d far(-3.3, 2.1);  // 2.3 m beyond -x, 0.1 m beyond +y
  EXPECT_FALSE(a.cellOf(far, &cx, &cy));
  ASSERT_TRUE(a.grow(far, far, 100, 100, 10000));
  ASSERT_TRUE(a.cellOf(far, &cx, &cy));
  // -x: 3 tiles needed and 1 more; +y: the cut tile completed, then 1 more.
  EXPECT_EQ(a.tilesX(), 3 + 3 + 1);
  EXPECT_EQ(a.tilesY(), 3 + 1 + 1);
  EXPECT_NEAR(a.originX(), -1.0 - 4 * 0.8, 1e-12);
  EXPECT_NEAR(a.originY(), -1.0, 1e-12);
  EXPECT_EQ(a.width(), 7 * 8);
  ASSERT_TRUE(a.cellOf(p, &cx, &cy));
  EXPECT_FLOAT_EQ(a.logOdds(cx, cy), 2.0f);
  ASSERT_TRUE(a.cellOf(q, &cx, &cy));
  EXPECT_FLOAT_EQ(a.logOdds(cx, cy), -1.0f);
  std::vector<const TiledLogOddsGrid*> both{&a, &b};
  EXPECT_EQ(TiledLogOddsGrid::distinctTiles(both), 2) << "growing copies no tile";

  // b grows the other way; the tiles stay on one lattice, so the two still share.
  ASSERT_TRUE(b.grow(Eigen::Vector2d(2.5, -2.5), Eigen::Vector2d(2.6, -2.4), 100, 100, 10000));
  EXPECT_NEAR(b.originY(), -1.0 - 3 * 0.8, 1e-12);
  ASSERT_TRUE(b.cellOf(p, &cx, &cy));
  EXPECT_FLOAT_EQ(b.logOdds(cx, cy), 2.0f);
  EXPECT_EQ(TiledLogOddsGrid::distinctTiles(both), 2);
  ASSERT_TRUE(b.cellOf(q, &cx, &cy));
  b.add(cx, cy, -1.0f, 5.0f);  // copy on write still works after growing
  EXPECT_EQ(TiledLogOddsGrid::distinctTiles(both), 3);
  ASSERT_TRUE(a.cellOf(q, &cx, &cy));
  EXPECT_FLOAT_EQ(a.logOdds(cx, cy), -1.0f);

  // The map drawn from a grown grid puts the cells where they were.
  const GridMapData m = a.toGridMap();
  const int mx = static_cast<int>(std::floor((p.x() - m.origin_x_m) / m.resolution_m));
  const int my = static_cast<int>(std::floor((p.y() - m.origin_y_m) / m.resolution_m));
  EXPECT_GT(m.at(mx, my), 65);

  // At most 12 tiles along x: a box at x = 10 m is beyond them. The grid grows to the limit
  // toward it, keeping what it had, and says the box is not held.
  const int tiles_y = a.tilesY();
  EXPECT_FALSE(a.grow(Eigen::Vector2d(10.0, 0.0), Eigen::Vector2d(10.0, 0.0), 12, 100, 10000));
  EXPECT_EQ(a.tilesX(), 12);
  EXPECT_NEAR(a.originX(), -1.0 - 4 * 0.8, 1e-12);
  EXPECT_TRUE(a.cellOf(Eigen::Vector2d(5.3, 0.0), &cx, &cy));
  EXPECT_FALSE(a.cellOf(Eigen::Vector2d(10.0, 0.0), &cx, &cy));
  ASSERT_TRUE(a.cellOf(p, &cx, &cy));
  EXPECT_FLOAT_EQ(a.logOdds(cx, cy), 2.0f);
  // Exactly at the memory limit the extra tile is left out rather than the growth.
  TiledLogOddsGrid e(0.1, 0.0, 0.0, 24, 24, 8);  // 3 x 3 tiles
  ASSERT_TRUE(e.grow(Eigen::Vector2d(3.0, 1.0), Eigen::Vector2d(3.0, 1.0), 100, 100, 12));
  EXPECT_EQ(e.tilesX(), 4);
  EXPECT_EQ(e.tilesY(), 3);
  // More than 90 tiles in all (y to 5 m: 12 x 8 at least), or a non-finite corner: nothing
  // grows.
  EXPECT_FALSE(a.grow(Eigen::Vector2d(0.0, 5.0), Eigen::Vector2d(0.0, 5.0), 100, 100, 90));
  EXPECT_FALSE(a.grow(Eigen::Vector2d(NAN, 0.0), Eigen::Vector2d(0.0, 0.0), 100, 100, 10000));
  EXPECT_EQ(a.tilesX(), 12);
  EXPECT_EQ(a.tilesY(), tiles_y);
  // A corner 1e300 m away: the limit, toward it, and no overflow.
  EXPECT_FALSE(a.grow(Eigen::Vector2d(-1e300, 0.0), Eigen::Vector2d(0.0, 0.0), 20, 100, 1e9));
  EXPECT_EQ(a.tilesX(), 20);
  EXPECT_NEAR(a.originX(), -1.0 - 12 * 0.8, 1e-12);

  // Within the limits the extra tile is left out when it does not fit: tiles 0 .. 4.
  TiledLogOddsGrid c(0.1, -1.0, -1.0, 20, 20, 8);
  ASSERT_TRUE(c.grow(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(2.7, 0.0), 5, 100, 10000));
  EXPECT_EQ(c.tilesX(), 5);
  // Beyond the limits on both sides, the window is centred on the box: tiles -3 .. 5 (the
  // first three kept) for a box around tile 1 that reaches -9 .. 11.
  TiledLogOddsGrid d(0.1, -1.0, -1.0, 20, 20, 8);
  EXPECT_FALSE(d.grow(Eigen::Vector2d(-8.0, 0.0), Eigen::Vector2d(8.5, 0.0), 9, 100, 10000));
  EXPECT_EQ(d.tilesX(), 9);
  EXPECT_NEAR(d.originX(), -1.0 - 3 * 0.8, 1e-12);
}

// The box's tiles come from the lattice and cellOf from the origin: at a grid's edge the two can
// round apart. Whenever grow says it holds a box, cellOf must agree (else the grid would be
// grown again at every update).
TEST(TiledGrid, AGrownGridHoldsWhatGrowSaysItHolds) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> ulps(-6, 6);
  const double resolutions[] = {0.01, 0.05, 0.1, 0.03, 0.07};
  const int tiles[] = {4, 16, 64, 5, 7};
  int held = 0;
  for (int i = 0; i < 5000; ++i) {
    const double resolution = resolutions[i % 5];
    const double ox = 100.0 * u(rng), oy = 100.0 * u(rng);
    TiledLogOddsGrid g(resolution, ox, oy, 40, 40, tiles[(i / 5) % 5]);
    for (int k = 0; k < 2; ++k) {  // grown a little, to -x or +x
      const Eigen::Vector2d c(ox + 100.0 * resolution * u(rng), oy + 20.0 * resolution);
      g.grow(c, c, 1 << 20, 1 << 20, 1L << 30);
    }
    // A point on the grid's lower or upper x edge, moved by a few units in the last place.
    double x = u(rng) < 0.0 ? g.originX() : g.originX() + g.width() * resolution;
    const int n = ulps(rng);
    for (int k = 0; k < std::abs(n); ++k) x = std::nextafter(x, n > 0 ? 1e9 : -1e9);
    const Eigen::Vector2d at(x, g.originY() + 0.5 * resolution * g.height());
    if (g.contains(at, at)) continue;
    ASSERT_TRUE(g.grow(at, at, 1 << 20, 1 << 20, 1L << 30));
    ++held;
    int cx, cy;
    ASSERT_TRUE(g.cellOf(at, &cx, &cy)) << std::setprecision(17) << at.transpose();
  }
  EXPECT_GT(held, 1000);
}

TEST(TiledGrid, ToGridMapFollowsOccupancyGridConventions) {
  TiledLogOddsGrid g(0.1, -1.0, -1.0, 20, 20, 8);
  g.add(12, 3, 2.0f, 5.0f);
  g.add(13, 3, -2.0f, 5.0f);
  const GridMapData m = g.toGridMap();
  EXPECT_EQ(m.width, 8);  // one tile: cells 8..15 x 0..7
  EXPECT_EQ(m.height, 8);
  EXPECT_NEAR(m.origin_x_m, -1.0 + 0.8, 1e-12);
  EXPECT_NEAR(m.origin_y_m, -1.0, 1e-12);
  EXPECT_EQ(m.at(4, 3), static_cast<int8_t>(std::lround(100.0 / (1.0 + std::exp(-2.0)))));
  EXPECT_EQ(m.at(5, 3), static_cast<int8_t>(std::lround(100.0 / (1.0 + std::exp(2.0)))));
  EXPECT_EQ(m.at(0, 0), -1);
  EXPECT_EQ(m.count(-1, -1), 62);
}

TEST(MapMatching, MatchIsTheAgreementOfLocalAndGlobalCells) {
  GridOptions o;
  o.resolution_m = 0.1;
  TiledLogOddsGrid g(0.1, -5.0, -5.0, 100, 100, 16);
  std::vector<LocalMapCell> local(2);
  local[0].center = Eigen::Vector2d(1.05, 0.05);
  local[0].occupied = true;
  local[1].center = Eigen::Vector2d(0.55, 0.05);
  EXPECT_EQ(matchLocalMap(local, Pose2::Zero(), g, o), 0.0);  // unknown map: no evidence
  integrateLocalMap(local, Pose2::Zero(), o, &g);
  const double expected = std::tanh(0.5 * o.log_odds_occupied) - std::tanh(0.5 * o.log_odds_free);
  EXPECT_NEAR(matchLocalMap(local, Pose2::Zero(), g, o), expected, 1e-6);
  // Shifted by 0.5 m the occupied cell lands on the free one: disagreement.
  EXPECT_NEAR(matchLocalMap(local, Pose2(-0.5, 0.0, 0.0), g, o),
              std::tanh(0.5 * o.log_odds_free), 1e-6);
}

FilterOptions gridOptions(int particles) {
  FilterOptions o;
  o.variant = "grid_pf";
  o.particles = particles;
  o.seed = 3;
  o.resample_threshold = 0.0;  // keep the weights to look at them
  o.motion.model = "diff_drive";
  o.grid.resolution_m = 0.05;
  o.grid.size_x_m = 20.0;
  o.grid.size_y_m = 20.0;
  return o;
}

/// A 360-beam scan (one beam a degree, from -pi), 5 cm to 10 m, without ranges yet.
std::shared_ptr<RangeScan> fullCircleScan() {
  auto scan = std::make_shared<RangeScan>();
  scan->angle_min = -M_PI;
  scan->angle_increment = 2.0 * M_PI / 360;
  scan->range_min = 0.05;
  scan->range_max = 10.0;
  return scan;
}

/// A room 6 m x 4 m seen from (x, y, 0) by a 360-beam scan.
FeatureSet roomScan(double x, double y) {
  auto scan = fullCircleScan();
  for (int i = 0; i < 360; ++i) {
    const double a = scan->angle_min + i * scan->angle_increment;
    const double c = std::cos(a), s = std::sin(a);
    double r = 1e9;
    if (c > 1e-9) r = std::min(r, (3.0 - x) / c);
    if (c < -1e-9) r = std::min(r, (-3.0 - x) / c);
    if (s > 1e-9) r = std::min(r, (2.0 - y) / s);
    if (s < -1e-9) r = std::min(r, (-2.0 - y) / s);
    scan->ranges.push_back(static_cast<float>(r));
  }
  FeatureSet f;
  f.scan = scan;
  return f;
}

// The tile tables are allocated for every particle when the filter starts: a map whose tables
// cannot fit is refused with the memory it would need, not met by std::bad_alloc (or the OOM
// killer) later. 1264 m square at 0.02 m in tiles of 4 cells: 2.5e8 tiles, 4 GB per table.
TEST(GridParticleFilter, TileTablesBeyondTheMemoryLimitAreRefused) {
  FilterOptions o = gridOptions(2);
  o.grid.resolution_m = 0.02;
  o.grid.size_x_m = 1264.0;
  o.grid.size_y_m = 1264.0;
  o.grid.tile_cells = 4;
  try {
    GridParticleFilter filter(o);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tile tables would take 18.6 GiB at the peak (2 x 2 "
                                         "particles"),
              std::string::npos)
        << e.what();
  }
  o.grid.tile_cells = 64;  // 988 x 988 tiles: 15.6 MB per table
  EXPECT_NO_THROW(GridParticleFilter filter(o));
}

TEST(GridParticleFilter, WeightsFollowEquation14) {
  const FilterOptions o = gridOptions(30);
  GridParticleFilter filter(o);
  filter.reset(Pose2::Zero());
  filter.update(roomScan(0.0, 0.0));  // every particle maps the room from the origin
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  spread.diagonal() << 0.04, 0.04, 0.01;
  ASSERT_TRUE(filter.resetPose(Pose2::Zero(), spread));
  const std::vector<WeightedPose> before = filter.particles();
  const FeatureSet second = roomScan(0.0, 0.0);
  const UpdateStats stats = filter.update(second);
  EXPECT_FALSE(stats.resampled);
  const std::vector<WeightedPose> after = filter.particles();
  LocalMapStats ignored;
  const std::vector<LocalMapCell> local = buildLocalMap(second, o.grid, &ignored);
  // All maps are the same (built before the spread), so w_i / w_j = exp((m_i - m_j) / f).
  const TiledLogOddsGrid& map = filter.bestGrid();
  std::vector<double> match;
  TiledLogOddsGrid reference(o.grid.resolution_m, -10.0, -10.0, 400, 400, o.grid.tile_cells);
  integrateLocalMap(local, Pose2::Zero(), o.grid, &reference);
  for (const auto& p : before) match.push_back(matchLocalMap(local, p.pose, reference, o.grid));
  int best = 0, nearest = 0;
  for (size_t i = 1; i < after.size(); ++i) {
    const double ratio = after[i].weight / after[0].weight;
    EXPECT_NEAR(std::log(ratio), (match[i] - match[0]) / o.grid.match_f, 1e-6) << i;
    if (after[i].weight > after[best].weight) best = static_cast<int>(i);
    if (before[i].pose.head<2>().norm() + std::fabs(before[i].pose.z()) <
        before[nearest].pose.head<2>().norm() + std::fabs(before[nearest].pose.z())) {
      nearest = static_cast<int>(i);
    }
  }
  EXPECT_EQ(best, nearest);
  EXPECT_GT(map.allocatedTiles(), 0);
}

// A fixed grid (grid.max_size_m 0): updates with the robot beyond it map and match nothing,
// and are counted (FilterStats::outside_grid; the node warns, offline_slam says so) instead of
// the filter silently turning into dead reckoning.
TEST(GridParticleFilter, UpdatesOutsideTheGridAreCounted) {
  FilterOptions o = gridOptions(5);
  o.grid.max_size_m = 0.0;
  GridParticleFilter filter(o);
  filter.reset(Pose2::Zero());
  filter.update(roomScan(0.0, 0.0));
  EXPECT_EQ(filter.stats().outside_grid, 0);
  ASSERT_TRUE(filter.resetPose(Pose2(15.0, 0.0, 0.0), Eigen::Matrix3d::Zero()));  // 20 m grid
  filter.update(roomScan(0.0, 0.0));
  filter.update(roomScan(0.0, 0.0));
  EXPECT_EQ(filter.stats().outside_grid, 2);
  ASSERT_TRUE(filter.resetPose(Pose2(9.0, 0.0, 0.0), Eigen::Matrix3d::Zero()));
  filter.update(roomScan(0.0, 0.0));
  EXPECT_EQ(filter.stats().outside_grid, 2) << "inside again";
}

// While mapping, each particle's grid grows to hold what it sees: a robot 15 m from the start of
// a 4 m grid maps the room around it, and the published map reaches it. Growth stops at
// grid.max_size_m, and such updates are counted.
TEST(GridParticleFilter, TheGridGrowsToHoldTheReadings) {
  FilterOptions o = gridOptions(5);
  o.grid.size_x_m = o.grid.size_y_m = 4.0;
  o.grid.max_size_m = 40.0;
  o.grid.tile_cells = 16;
  GridParticleFilter filter(o);
  filter.reset(Pose2::Zero());
  filter.update(roomScan(0.0, 0.0));  // the room's walls 3 m along x: beyond the first 4 m
  // A wall is occupied in one of the cells it touches.
  auto wall_mapped = [&filter](const Eigen::Vector2d& at) {
    const TiledLogOddsGrid& g = filter.bestGrid();
    int cx, cy;
    if (!g.cellOf(at, &cx, &cy)) return false;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        if (cx + dx >= 0 && cy + dy >= 0 && cx + dx < g.width() && cy + dy < g.height() &&
            g.logOdds(cx + dx, cy + dy) > 0.0f) {
          return true;
        }
      }
    }
    return false;
  };
  const Eigen::Vector2d wall(3.0, 0.5);
  EXPECT_TRUE(wall_mapped(wall));
  ASSERT_TRUE(filter.resetPose(Pose2(15.0, -12.0, 0.0), Eigen::Matrix3d::Zero()));
  filter.update(roomScan(0.0, 0.0));
  EXPECT_EQ(filter.stats().outside_grid, 0);
  EXPECT_EQ(filter.stats().grid_growth_refused, 0);
  for (const Eigen::Vector2d& at :
       {Eigen::Vector2d(18.0, -12.5),  // the moved room's walls
        Eigen::Vector2d(12.0, -11.5), Eigen::Vector2d(15.5, -10.0), Eigen::Vector2d(14.5, -14.0)}) {
    EXPECT_TRUE(wall_mapped(at)) << at.transpose();
  }
  EXPECT_TRUE(wall_mapped(wall)) << "the first room is kept";
  GridMapData map;
  ASSERT_TRUE(filter.occupancyGrid(map));
  EXPECT_LE(map.origin_x_m, -3.0);
  EXPECT_GE(map.origin_x_m + map.width * map.resolution_m, 18.0);
  EXPECT_LE(map.origin_y_m, -14.0);
  EXPECT_LE(map.width * map.resolution_m, 40.0 + 1e-9);

  // 40 m along x at most: at 45 m the grid cannot follow; it grows as far as it may toward
  // the robot, so a room at 30 m is then mapped whole.
  ASSERT_TRUE(filter.resetPose(Pose2(45.0, 0.0, 0.0), Eigen::Matrix3d::Zero()));
  filter.update(roomScan(0.0, 0.0));
  EXPECT_EQ(filter.stats().outside_grid, 1);
  EXPECT_EQ(filter.stats().grid_growth_refused, 1);
  const TiledLogOddsGrid& at_limit = filter.bestGrid();
  EXPECT_LE(at_limit.width() * at_limit.resolution(), 40.0 + 1e-9);
  EXPECT_GT(at_limit.originX() + at_limit.width() * at_limit.resolution(), 34.0)
      << "the grid did not grow toward the robot";
  ASSERT_TRUE(filter.resetPose(Pose2(30.0, 0.0, 0.0), Eigen::Matrix3d::Zero()));
  filter.update(roomScan(0.0, 0.0));
  EXPECT_EQ(filter.stats().grid_growth_refused, 1);
  EXPECT_TRUE(wall_mapped(Eigen::Vector2d(33.0, 0.5)));
  EXPECT_TRUE(wall_mapped(Eigen::Vector2d(27.0, 0.5)));
  // Localizing (mapping off) never grows the grid.
  ASSERT_TRUE(filter.setMapping(false));
  ASSERT_TRUE(filter.resetPose(Pose2(0.0, 25.0, 0.0), Eigen::Matrix3d::Zero()));
  filter.update(roomScan(0.0, 0.0));
  EXPECT_EQ(filter.stats().outside_grid, 2);
  EXPECT_EQ(filter.stats().grid_growth_refused, 1);
}

TEST(GridParticleFilter, ResampledParticlesShareTiles) {
  FilterOptions o = gridOptions(200);
  o.resample_threshold = 1.0;  // resample every update
  o.grid.match_f = 1.0;        // sharp weights: few ancestors survive
  o.motion.min_sigma_xy_m = 0.05;
  GridParticleFilter filter(o);
  filter.reset(Pose2::Zero());
  filter.update(roomScan(0.0, 0.0));
  const long tiles_one_map = filter.bestGrid().allocatedTiles();
  ASSERT_GT(tiles_one_map, 4);
  // Before any resampling every particle wrote its own tiles.
  EXPECT_EQ(filter.distinctTiles(), tiles_one_map * 200);
  MotionInput motion;
  motion.delta = Pose2(0.2, 0.0, 0.0);
  filter.predict(motion);
  const UpdateStats stats = filter.update(roomScan(0.2, 0.0));  // weigh, write, resample
  ASSERT_TRUE(stats.resampled);
  std::vector<std::pair<double, double>> ancestors;
  for (const auto& p : filter.particles()) ancestors.emplace_back(p.pose.x(), p.pose.y());
  std::sort(ancestors.begin(), ancestors.end());
  const long unique = std::unique(ancestors.begin(), ancestors.end()) - ancestors.begin();
  EXPECT_LT(unique, 100);
  // Copies of one ancestor share every tile: memory follows ancestors, not particles.
  EXPECT_LE(filter.distinctTiles(), unique * (tiles_one_map + 4));
  EXPECT_GE(filter.distinctTiles(), unique * tiles_one_map);
  EXPECT_EQ(filter.gridBytes(), filter.distinctTiles() * sizeof(float) * 64 * 64);
  const PoseEstimate e = filter.estimate();
  EXPECT_NEAR(e.mean.x(), 0.2, 0.05);
  EXPECT_NEAR(e.mean.y(), 0.0, 0.05);
  GridMapData map;
  ASSERT_TRUE(filter.occupancyGrid(map));
  EXPECT_GT(map.count(66, 100), 300);  // the walls (20 m of wall at 5 cm)
  EXPECT_GT(map.count(0, 40), 3000);   // the room's inside, seen free twice
}

/// A map of 3 x 2 cells of 0.1 m (row 0 at the bottom) with its corner at (x, y).
GridMapData smallMap(const std::vector<int8_t>& cells, double x = 0.0, double y = 0.0) {
  GridMapData map;
  map.resolution_m = 0.1;
  map.origin_x_m = x;
  map.origin_y_m = y;
  map.width = 3;
  map.height = 2;
  map.cells = cells;
  return map;
}

// A saved map becomes log odds at the filter's resolution: a finer cell takes the map cell
// holding it, a coarser one the highest of those it overlaps (a thin wall must not vanish);
// occupied the clamp, free minus the clamp, unknown (and 50 %) nothing; the origin is kept. A
// map that is empty, lacks cells or would take more than 1e9 cells is refused by name.
TEST(GridMapLoading, AMapBecomesLogOddsAtTheFilterResolution) {
  const GridMapData map = smallMap({100, 0, -1, 50, 100, 0}, -0.3, 1.0);
  GridOptions o;
  o.resolution_m = 0.05;
  o.log_odds_clamp = 4.0;
  o.tile_cells = 4;
  const TiledLogOddsGrid grid = gridFromMap(map, o);
  EXPECT_EQ(grid.width(), 6);
  EXPECT_EQ(grid.height(), 4);
  EXPECT_DOUBLE_EQ(grid.originX(), -0.3);
  EXPECT_DOUBLE_EQ(grid.originY(), 1.0);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 6; ++x) {
      const int value = map.at(x / 2, y / 2);
      const float expected = value == 100 ? 4.0f : value == 0 ? -4.0f : 0.0f;
      EXPECT_FLOAT_EQ(grid.logOdds(x, y), expected) << x << ", " << y;
    }
  }
  int cx, cy;
  ASSERT_TRUE(grid.cellOf(Eigen::Vector2d(-0.25 + 1e-6, 1.17), &cx, &cy));  // map cell (0, 1)
  EXPECT_EQ(cx, 1);
  EXPECT_EQ(cy, 3);
  EXPECT_EQ(grid.toGridMap().count(65, 100), 8);  // back to occupancy: 2 map cells x 4
  o.resolution_m = 0.2;  // coarser: each cell takes the highest of the map cells it overlaps
  const TiledLogOddsGrid coarse = gridFromMap(map, o);
  EXPECT_EQ(coarse.width(), 2);
  EXPECT_EQ(coarse.height(), 1);
  EXPECT_FLOAT_EQ(coarse.logOdds(0, 0), 4.0f);   // map cells x 0-1: 100, 0, 50, 100
  EXPECT_FLOAT_EQ(coarse.logOdds(1, 0), -4.0f);  // map cells x 2 (-1, 0) and beyond: free

  // A wall one map cell thick stays whole in cells of 2 and 3 map cells, wherever it lies.
  for (int wall_x : {4, 5}) {
    GridMapData thin;
    thin.resolution_m = 0.01;
    thin.width = 12;
    thin.height = 12;
    thin.cells.assign(144, 0);
    for (int y = 0; y < 12; ++y) thin.cells[y * 12 + wall_x] = 100;
    for (double resolution : {0.02, 0.03}) {
      o.resolution_m = resolution;
      const TiledLogOddsGrid g = gridFromMap(thin, o);
      const int column = static_cast<int>(wall_x * 0.01 / resolution + 1e-9);
      for (int y = 0; y < g.height(); ++y) {
        EXPECT_FLOAT_EQ(g.logOdds(column, y), 4.0f) << wall_x << " at " << resolution << ", " << y;
        EXPECT_FLOAT_EQ(g.logOdds(column == 0 ? 1 : 0, y), -4.0f) << wall_x << ", " << y;
      }
    }
  }

  auto error = [&](const GridMapData& m) -> std::string {
    try {
      gridFromMap(m, o);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  GridMapData bad = map;
  bad.cells.pop_back();
  EXPECT_NE(error(bad).find("5 cell values for 3 x 2 cells"), std::string::npos) << error(bad);
  bad = map;
  bad.width = 0;
  EXPECT_NE(error(bad).find("empty"), std::string::npos) << error(bad);
  bad = map;
  bad.origin_x_m = std::nan("");
  EXPECT_NE(error(bad).find("origin"), std::string::npos) << error(bad);
  bad = map;
  bad.resolution_m = 1000.0;  // 3 km x 2 km in cells of 5 cm: 2.4e9 cells
  o.resolution_m = 0.05;
  EXPECT_NE(error(bad).find("more than 1e9"), std::string::npos) << error(bad);
}

// A start off the map is named: outside it, or in a wall.
TEST(GridMapLoading, AStartOffTheMapIsNamed) {
  const GridMapData map = smallMap({100, 0, -1, 0, 0, 0}, -0.3, 1.0);  // x -0.3 .. 0, y 1 .. 1.2
  EXPECT_EQ(poseOffMapProblem(map, Pose2(-0.15, 1.05, 0.0)), "");      // free
  EXPECT_EQ(poseOffMapProblem(map, Pose2(-0.05, 1.15, 0.0)), "");      // unknown: may be free
  EXPECT_EQ(poseOffMapProblem(map, Pose2(-0.25, 1.05, 0.0)),
            "(-0.25, 1.05) is on an occupied cell of the map (inside a wall)");
  EXPECT_EQ(poseOffMapProblem(map, Pose2(5.0, 5.0, 0.0)),
            "(5, 5) is outside the map, x -0.3 .. 0 m, y 1 .. 1.2 m");
  EXPECT_NE(poseOffMapProblem(map, Pose2(std::nan(""), 1.05, 0.0)), "");
}

// A map whose tile tables would not fit is refused before anything is built (one cell of 1.5 km
// is 30000 x 30000 cells of 5 cm, 900 MB of tables per particle in tiles of 4 cells), and the
// filter keeps what it had.
TEST(GridMapLoading, AMapTooLargeForTheTablesIsRefusedFirst) {
  FilterOptions o = gridOptions(2);
  o.grid.tile_cells = 4;
  GridParticleFilter filter(o);
  filter.reset(Pose2::Zero());
  filter.update(roomScan(0.0, 0.0));
  GridMapData before;
  ASSERT_TRUE(filter.occupancyGrid(before));
  GridMapData huge;
  huge.resolution_m = 1500.0;
  huge.width = huge.height = 1;
  huge.cells = {100};
  try {
    filter.loadGridMap(huge);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("the map: the grid's tile tables would take"),
              std::string::npos)
        << e.what();
  }
  GridMapData after;
  ASSERT_TRUE(filter.occupancyGrid(after));
  EXPECT_EQ(after.cells, before.cells);
}

/// The occupancy grid of the 6 m x 4 m room of roomScan, mapped from a few poses.
GridMapData roomMap(const GridOptions& o) {
  TiledLogOddsGrid grid(o.resolution_m, -4.0, -3.0, 160, 120, o.tile_cells);
  LocalMapStats ignored;
  for (const Eigen::Vector2d& at : {Eigen::Vector2d(0, 0), Eigen::Vector2d(-2, 1),
                                    Eigen::Vector2d(2, -1), Eigen::Vector2d(1.5, 1.2)}) {
    for (int k = 0; k < 4; ++k) {
      integrateLocalMap(buildLocalMap(roomScan(at.x(), at.y()), o, &ignored),
                        Pose2(at.x(), at.y(), 0.0), o, &grid);
    }
  }
  return grid.toGridMap();
}

// Localization on a loaded map (mapping off): particles spread around a wrong guess find the
// robot from one scan, and the map stays as loaded; on an empty map the same scan tells
// nothing and the estimate stays at the guess. Through a session that centres the filter on
// the first pose (filter_origin start), the map keeps its place in the map frame and comes
// back after a reset.
TEST(GridMapLoading, ParticlesFindTheRobotOnALoadedMap) {
  FilterOptions o = gridOptions(400);
  o.resample_threshold = 0.5;
  const GridMapData map = roomMap(o.grid);
  const Pose2 truth(0.8, -0.5, 0.0), guess(1.0, -0.35, 0.0);
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  spread.diagonal() << 0.15 * 0.15, 0.15 * 0.15, 0.05 * 0.05;
  auto locate = [&](bool with_map) {
    GridParticleFilter filter(o);
    filter.reset(guess);
    if (with_map) {
      EXPECT_TRUE(filter.loadGridMap(map));
    }
    EXPECT_TRUE(filter.setMapping(false));
    EXPECT_TRUE(filter.resetPose(guess, spread));
    for (int k = 0; k < 3; ++k) filter.update(roomScan(truth.x(), truth.y()));
    GridMapData after;
    EXPECT_TRUE(filter.occupancyGrid(after));
    if (with_map) {
      EXPECT_EQ(after.cells, map.cells);  // nothing mapped
    }
    return filter.estimate().mean;
  };
  const Pose2 found = locate(true), unaided = locate(false);
  EXPECT_LT((found.head<2>() - truth.head<2>()).norm(), 0.05) << found.transpose();
  EXPECT_LT(std::fabs(found.z()), 0.03) << found.transpose();
  EXPECT_GT((unaided.head<2>() - truth.head<2>()).norm(), 0.15) << unaided.transpose();

  SessionOptions session_options;
  session_options.filter_origin = "start";
  SlamSession session(createFilter(o), session_options);
  EXPECT_EQ(session.offPriorMapProblem(Pose2(50.0, 50.0, 0.0)), "");  // no map: nothing to say
  ASSERT_TRUE(session.setPriorGridMap(map));
  EXPECT_EQ(session.offPriorMapProblem(guess), "");
  EXPECT_NE(session.offPriorMapProblem(Pose2(50.0, 50.0, 0.0)), "");
  ASSERT_TRUE(session.setMapping(false));
  ASSERT_TRUE(session.setPose(guess, spread));
  const Pose2 odom_start(5.0, 7.0, 0.3);  // the odometry frame is not the map frame
  for (int k = 0; k < 3; ++k) {
    FeatureSet scan = roomScan(truth.x(), truth.y());
    session.process(1.0 + k, odom_start, scan);
  }
  EXPECT_LT((session.filter().estimate().mean.head<2>() - truth.head<2>()).norm(), 0.05)
      << session.filter().estimate().mean.transpose();
  GridMapData reported;
  ASSERT_TRUE(session.filter().occupancyGrid(reported));
  EXPECT_NEAR(reported.origin_x_m, map.origin_x_m, 1e-9);
  EXPECT_NEAR(reported.origin_y_m, map.origin_y_m, 1e-9);
  EXPECT_EQ(reported.cells, map.cells);
  // A reset (a bag played again, ~reset) starts the next run at the start given before the
  // first frame, on the map: not at the odometry's coordinates.
  session.reset();
  for (int k = 0; k < 3; ++k) {
    FeatureSet scan = roomScan(truth.x(), truth.y());
    session.process(10.0 + k, odom_start, scan);
  }
  ASSERT_TRUE(session.filter().occupancyGrid(reported));
  EXPECT_EQ(reported.cells, map.cells);
  EXPECT_NEAR(reported.origin_x_m, map.origin_x_m, 1e-9);
  EXPECT_LT((session.filter().estimate().mean.head<2>() - truth.head<2>()).norm(), 0.05)
      << "after a reset: " << session.filter().estimate().mean.transpose();
  // ~reset (requested) starts from scratch: the old start is forgotten, map = odom.
  session.reset(SlamSession::ResetCause::kRequested);
  FeatureSet scan = roomScan(truth.x(), truth.y());
  session.process(20.0, odom_start, scan);
  EXPECT_LT((session.filter().estimate().mean.head<2>() - odom_start.head<2>()).norm(), 1e-6)
      << "after ~reset: " << session.filter().estimate().mean.transpose();
}

// An odometry gap with gap_action "reset" on a prior map: the new run starts where the robot
// is on the map (the last correction applied to the odometry), not at its odometry coordinates,
// which on a map that is not the odometry's frame are somewhere else.
TEST(GridMapLoading, AGapResetOnAMapKeepsTheRobotWhereItWas) {
  FilterOptions o = gridOptions(200);
  o.resample_threshold = 0.5;
  SessionOptions session_options;
  session_options.gap_action = "reset";  // a frame more than max_time_gap_s (30) after the last
  SlamSession session(createFilter(o), session_options);
  ASSERT_TRUE(session.setPriorGridMap(roomMap(o.grid)));
  ASSERT_TRUE(session.setMapping(false));
  const Pose2 start(0.8, -0.5, 0.0);
  ASSERT_TRUE(session.setPose(start, Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal()));
  const Pose2 odom_start(5.0, 7.0, 0.0);
  for (int k = 0; k < 3; ++k) {
    FeatureSet scan = roomScan(start.x(), start.y());
    session.process(1.0 + k, odom_start, scan);
  }
  // 40 s later, 0.6 m on (the odometry tells it right): a gap, and a new run.
  const Pose2 there(1.4, -0.5, 0.0);
  for (int k = 0; k < 3; ++k) {
    FeatureSet scan = roomScan(there.x(), there.y());
    const FrameResult result = session.process(43.0 + k, Pose2(5.6, 7.0, 0.0), scan);
    if (k == 0) {
      EXPECT_EQ(result, FrameResult::kReset);
    }
  }
  EXPECT_EQ(session.gaps(), 1);
  const Pose2 now = session.filter().estimate().mean;
  // Found within the spread it restarts with (its covariance plus rviz's 0.5 m).
  EXPECT_LT((now.head<2>() - there.head<2>()).norm(), 0.15) << now.transpose();
  EXPECT_LT(std::fabs(now.z()), 0.05) << now.transpose();
}

// An odometry jump (an increment over max_odometry_jump_m) with gap_action "inflate": the
// increment is not taken, the robot stays where it was within the inflated noise, and map ->
// odom absorbs the jump so that the next increments go on from there. A measured (scan-matched)
// increment across it is taken as it is.
TEST(SessionResets, AnOdometryJumpIsNotTakenAsMotion) {
  FilterOptions o = gridOptions(50);
  SessionOptions session_options;
  session_options.max_odometry_jump_m = 2.0;  // gap_action "inflate" (the default)
  const FeatureSet none;
  SlamSession session(createFilter(o), session_options);
  session.process(1.0, Pose2(0.0, 0.0, 0.0), none);
  session.process(2.0, Pose2(0.5, 0.0, 0.0), none);
  EXPECT_EQ(session.process(3.0, Pose2(5.5, 1.0, 0.0), none), FrameResult::kUpdated);
  EXPECT_EQ(session.gaps(), 1);
  Pose2 at = session.filter().estimate().mean;
  EXPECT_LT((at.head<2>() - Eigen::Vector2d(0.5, 0.0)).norm(), 0.3) << at.transpose();
  session.process(4.0, Pose2(6.0, 1.0, 0.0), none);  // 0.5 m on from the jumped odometry
  at = session.filter().estimate().mean;
  EXPECT_LT((at.head<2>() - Eigen::Vector2d(1.0, 0.0)).norm(), 0.3) << at.transpose();
  EXPECT_EQ(session.gaps(), 1);
  // A measured increment across the jump is kept.
  SlamSession measured(createFilter(o), session_options);
  measured.process(1.0, Pose2(0.0, 0.0, 0.0), none);
  MotionInput matched;
  matched.delta = Pose2(0.4, 0.0, 0.0);
  measured.process(2.0, Pose2(5.0, 0.0, 0.0), none, &matched);
  at = measured.filter().estimate().mean;
  EXPECT_LT((at.head<2>() - Eigen::Vector2d(0.4, 0.0)).norm(), 0.1) << at.transpose();
}

// Gap resets without a prior map: with a start given, the new run goes on where the robot is
// (after a time gap where the odometry puts it, after an odometry jump where it was), not back
// at the start; with none, it starts at its odometry coordinates as before.
TEST(SessionResets, AGapResetGoesOnFromWhereTheRobotIs) {
  FilterOptions o = gridOptions(20);
  SessionOptions session_options;
  session_options.gap_action = "reset";
  session_options.max_odometry_jump_m = 2.0;
  const Eigen::Matrix3d tight = Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  auto after_gap = [&](bool given_start, bool jump) {
    SlamSession session(createFilter(o), session_options);
    if (given_start) {
      EXPECT_TRUE(session.setPose(Pose2(10.0, 20.0, 0.0), tight));
    }
    const FeatureSet none;
    session.process(1.0, Pose2(0.0, 0.0, 0.0), none);
    session.process(2.0, Pose2(0.5, 0.0, 0.0), none);
    // A time gap of 40 s and 1 m on, or a 3 m odometry jump 1 s later.
    const FrameResult result = jump ? session.process(3.0, Pose2(3.5, 0.0, 0.0), none)
                                    : session.process(42.0, Pose2(1.5, 0.0, 0.0), none);
    EXPECT_EQ(result, FrameResult::kReset);
    return Eigen::Vector2d(session.filter().estimate().mean.head<2>());
  };
  // The restarted run's spread: the last estimate's (its motion noise) plus the given start's.
  EXPECT_LT((after_gap(true, false) - Eigen::Vector2d(11.5, 20.0)).norm(), 0.05);
  EXPECT_LT((after_gap(true, true) - Eigen::Vector2d(10.5, 20.0)).norm(), 0.05);
  EXPECT_LT((after_gap(false, false) - Eigen::Vector2d(1.5, 0.0)).norm(), 1e-6);  // map = odom
}

/// An asymmetric room for global localization: the 6 m x 4 m room of roomScan
/// with a wall from (1, -2) to (1, 0) and one from (-1.5, 1) to (-0.5, 1), seen from pose by a
/// 360-beam scan.
FeatureSet asymmetricRoomScan(const Pose2& pose) {
  const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls = {
      {{-3, -2}, {3, -2}}, {{3, -2}, {3, 2}}, {{3, 2}, {-3, 2}},
      {{-3, 2}, {-3, -2}}, {{1, -2}, {1, 0}}, {{-1.5, 1}, {-0.5, 1}}};
  auto scan = fullCircleScan();
  for (int i = 0; i < 360; ++i) {
    const double a = pose.z() + scan->angle_min + i * scan->angle_increment;
    const Eigen::Vector2d o = pose.head<2>(), d(std::cos(a), std::sin(a));
    double r = scan->range_max;
    for (const auto& [p, q] : walls) {
      // o + t d = p + u (q - p), t > 0, u in [0, 1]
      const Eigen::Vector2d e = q - p;
      const double den = d.x() * e.y() - d.y() * e.x();
      if (std::fabs(den) < 1e-12) continue;
      const Eigen::Vector2d w = p - o;
      const double t = (w.x() * e.y() - w.y() * e.x()) / den;
      const double u = (w.x() * d.y() - w.y() * d.x()) / den;
      if (t > 0.0 && u >= 0.0 && u <= 1.0) r = std::min(r, t);
    }
    scan->ranges.push_back(static_cast<float>(r));
  }
  FeatureSet f;
  f.scan = scan;
  return f;
}

/// The asymmetric room's occupancy grid, mapped from known poses.
GridMapData asymmetricRoomMap(const GridOptions& o) {
  TiledLogOddsGrid grid(o.resolution_m, -4.0, -3.0, static_cast<int>(8.0 / o.resolution_m),
                        static_cast<int>(6.0 / o.resolution_m), o.tile_cells);
  LocalMapStats ignored;
  for (const Pose2& at : {Pose2(-2, -1, 0), Pose2(-2, 1.5, 0), Pose2(0, 0, 0), Pose2(2, -1, 0),
                          Pose2(2, 1, 0), Pose2(-1, 1.5, 0), Pose2(0, -1.5, 0)}) {
    for (int k = 0; k < 4; ++k) {
      integrateLocalMap(buildLocalMap(asymmetricRoomScan(at), o, &ignored), at, o, &grid);
    }
  }
  return grid.toGridMap();
}

/// Global localization in the asymmetric room: 10 cm cells, the particles diffusing while the
/// robot stands, and free local cells weighing a fifth of occupied ones. With the paper's equal
/// weights the 883 free cells of a scan (of 1011) agree with the map almost anywhere in open
/// space, and the spread settles on a wrong pose (docs/results.md, grid PF, session 46).
FilterOptions globalOptions(int particles) {
  FilterOptions o = gridOptions(particles);
  o.resample_threshold = 0.5;
  o.grid.resolution_m = 0.1;
  o.grid.match_free_weight = 0.2;
  o.motion.min_sigma_xy_m = 0.02;
  o.motion.min_sigma_theta_rad = 0.02;
  return o;
}

/// One standing step: predict without motion, then the scan from where the robot really is.
void standingStep(SlamFilter* filter, const Pose2& truth) {
  MotionInput still;
  still.dt = 0.1;
  filter->predict(still);
  filter->update(asymmetricRoomScan(truth));
}

/// Seeds 1-6 of global localization in the asymmetric room with these options: how many found
/// the standing robot within 15 cm and 0.1 rad after 40 scans.
int foundInTheAsymmetricRoom(FilterOptions o) {
  const GridMapData map = asymmetricRoomMap(o.grid);
  const Pose2 truth(1.8, -1.2, 2.0);
  int found = 0;
  for (int seed = 1; seed <= 6; ++seed) {
    o.seed = seed;
    GridParticleFilter filter(o);
    EXPECT_FALSE(filter.spreadOverMap());
    EXPECT_TRUE(filter.loadGridMap(map));
    EXPECT_TRUE(filter.setMapping(false));
    EXPECT_TRUE(filter.spreadOverMap());
    // Spread over the free cells: inside the room, headings all round.
    double min_x = 1e9, max_x = -1e9, min_yaw = 1e9, max_yaw = -1e9;
    for (const WeightedPose& p : filter.particles()) {
      min_x = std::min(min_x, p.pose.x());
      max_x = std::max(max_x, p.pose.x());
      min_yaw = std::min(min_yaw, p.pose.z());
      max_yaw = std::max(max_yaw, p.pose.z());
      EXPECT_LT(std::fabs(p.pose.x()), 3.0);
      EXPECT_LT(std::fabs(p.pose.y()), 2.0);
    }
    EXPECT_LT(min_x, -2.5);
    EXPECT_GT(max_x, 2.5);
    EXPECT_LT(min_yaw, -3.0);
    EXPECT_GT(max_yaw, 3.0);
    for (int k = 0; k < 40; ++k) standingStep(&filter, truth);
    const Pose2 at = filter.estimate().mean;
    found += (at.head<2>() - truth.head<2>()).norm() < 0.15 &&
             std::fabs(wrapAngle(at.z() - truth.z())) < 0.1;
  }
  return found;
}

// Global localization: the particles start anywhere on the map's free cells, with any heading,
// and gather on the robot. Standing still in the asymmetric room (nearly symmetric under a half
// turn but for its two inner walls), 3000 particles find it in 7 of seeds 1-8 (1 of 8 with free
// cells weighing as much as occupied ones, 3 of 8 with 1500 particles): asserted over six seeds.
// Without a loaded map there is nothing to spread over.
TEST(GlobalLocalization, FindsTheRobotInAnAsymmetricRoomMostOfTheTime) {
  EXPECT_GE(foundInTheAsymmetricRoom(globalOptions(3000)), 4) << "of 6 seeds";
}

// The likelihood field (grid.match_model, amcl's model) scores only the scan's hits, by their
// distance to the map's walls, so free space cannot drown them: found with the paper's free
// weight (unused by it) and fewer particles.
TEST(GlobalLocalization, TheLikelihoodFieldFindsTheRobotWithFewerParticles) {
  FilterOptions o = globalOptions(1000);
  o.grid.match_free_weight = 1.0;
  o.grid.match_model = "likelihood_field";
  const int found = foundInTheAsymmetricRoom(o);
  EXPECT_GE(found, 4) << "of 6 seeds";  // 5 when written
  // grid.spread_match_f replaces f until the particles gather: weights flattened by a huge f
  // find nothing while they never count as gathered, and change nothing when they count as
  // gathered before the first scan is weighed.
  o.grid.spread_match_f = 1e9;
  o.grid.spread_gathered_m = 0.0;
  EXPECT_EQ(foundInTheAsymmetricRoom(o), 0) << "with f = 1e9 throughout";
  o.grid.spread_gathered_m = 1e6;
  EXPECT_EQ(foundInTheAsymmetricRoom(o), found) << "gathered at the first scan";
}

// Weighing the first scan at many more uniform poses than there are particles (and drawing the
// particles from them) finds the robot with a fraction of the particles.
TEST(GlobalLocalization, CandidatePosesAtTheFirstScanNeedFewerParticles) {
  FilterOptions o = globalOptions(100);
  o.grid.match_free_weight = 1.0;
  o.grid.match_model = "likelihood_field";
  o.grid.spread_candidates = 20;
  const int with = foundInTheAsymmetricRoom(o);  // 5 when written
  o.grid.spread_candidates = 1;
  const int without = foundInTheAsymmetricRoom(o);  // 3
  EXPECT_GE(with, 4) << "of 6 seeds";
  EXPECT_GT(with, without) << "of 6 seeds";
}

// The same cloud, two answers: while localizing, estimate() reports the mean of a cluster
// holding most of the weight (heaviestClusterMoments, cells of ten filter cells and 10 deg), not
// the point between the places the cloud holds; while mapping, the whole cloud's moments.
TEST(GlobalLocalization, LocalizingReportsTheHeaviestClusterMappingTheWholeCloud) {
  FilterOptions o = globalOptions(1000);
  o.grid.match_free_weight = 1.0;
  o.grid.match_model = "likelihood_field";
  const Pose2 truth(1.8, -1.2, 2.0);
  GridParticleFilter filter(o);
  ASSERT_TRUE(filter.loadGridMap(asymmetricRoomMap(o.grid)));
  ASSERT_TRUE(filter.setMapping(false));
  ASSERT_TRUE(filter.spreadOverMap());
  PoseEstimate clustered, plain;
  double apart = 0.0;
  for (int k = 0; k < 40 && apart < 0.2; ++k) {
    standingStep(&filter, truth);
    std::vector<Pose2> poses;
    std::vector<double> weights;
    for (const WeightedPose& p : filter.particles()) {
      poses.push_back(p.pose);
      weights.push_back(p.weight);
    }
    clustered = heaviestClusterMoments(poses, weights, 10.0 * o.grid.resolution_m, M_PI / 18.0);
    plain = poseMoments(poses, weights);
    apart = (clustered.mean.head<2>() - plain.mean.head<2>()).norm();
  }
  ASSERT_GE(apart, 0.2) << "no step left a majority cluster away from the cloud's mean";
  const auto same = [](const Pose2& a, const Pose2& b) {
    return (a.head<2>() - b.head<2>()).norm() < 1e-9 && std::fabs(wrapAngle(a.z() - b.z())) < 1e-9;
  };
  EXPECT_TRUE(same(filter.estimate().mean, clustered.mean)) << "localizing";
  EXPECT_TRUE(filter.estimate().covariance.isApprox(clustered.covariance, 1e-6));
  ASSERT_TRUE(filter.setMapping(true));
  EXPECT_TRUE(same(filter.estimate().mean, plain.mean)) << "mapping";
  EXPECT_TRUE(filter.estimate().covariance.isApprox(plain.covariance, 1e-6));
}

// KLD-sampling (grid.kld_min_particles): spread over the map, the filter holds all its
// particles; once they gather on the robot a resampling keeps only what the few bins they occupy
// need (93 / 50 / 50 of 1000 at the end when written), and still finds it. A new spread, a start
// pose, a map loaded and mapping restore them all; without KLD the count never changes.
TEST(GlobalLocalization, KldSamplingKeepsFewerParticlesOnceGathered) {
  FilterOptions o = globalOptions(1000);
  o.grid.match_free_weight = 1.0;
  o.grid.match_model = "likelihood_field";
  o.grid.kld_min_particles = 50;
  o.grid.kld_error = 0.05;
  const Pose2 truth(1.8, -1.2, 2.0);
  const GridMapData map = asymmetricRoomMap(o.grid);
  const auto count = [](const SlamFilter& f) { return f.particles().size(); };
  int found = 0;
  for (int seed = 1; seed <= 3; ++seed) {
    o.seed = seed;
    GridParticleFilter filter(o);
    ASSERT_TRUE(filter.loadGridMap(map));
    ASSERT_TRUE(filter.setMapping(false));
    ASSERT_TRUE(filter.spreadOverMap());
    EXPECT_EQ(count(filter), 1000u);
    size_t fewest = 1000;
    for (int k = 0; k < 40; ++k) {
      standingStep(&filter, truth);
      fewest = std::min(fewest, count(filter));
      EXPECT_GE(count(filter), 50u);
      EXPECT_LE(count(filter), 1000u);
    }
    const Pose2 at = filter.estimate().mean;
    const bool here = (at.head<2>() - truth.head<2>()).norm() < 0.15 &&
                      std::fabs(wrapAngle(at.z() - truth.z())) < 0.1;
    found += here;
    if (here) EXPECT_LT(count(filter), 300u) << "seed " << seed << ": gathered, yet kept";
    EXPECT_LT(fewest, 1000u) << "seed " << seed;
    ASSERT_TRUE(filter.spreadOverMap());
    EXPECT_EQ(count(filter), 1000u) << "a spread takes them all again";
    const auto gather = [&] {
      for (int k = 0; k < 40; ++k) standingStep(&filter, truth);
      ASSERT_LT(count(filter), 1000u) << "seed " << seed << ": not gathered again";
    };
    gather();
    ASSERT_TRUE(filter.resetPose(truth, Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal()));
    EXPECT_EQ(count(filter), 1000u) << "a start pose takes them all again";
    gather();
    ASSERT_TRUE(filter.loadGridMap(map));
    EXPECT_EQ(count(filter), 1000u) << "a map loaded takes them all again";
    gather();
    ASSERT_TRUE(filter.setMapping(true));
    EXPECT_EQ(count(filter), 1000u) << "mapping takes them all again";
    std::set<std::pair<double, double>> distinct;
    for (const WeightedPose& p : filter.particles()) distinct.insert({p.pose.x(), p.pose.y()});
    EXPECT_GT(distinct.size(), 1u) << "drawn by weight, not one copied";
    standingStep(&filter, truth);
    EXPECT_EQ(count(filter), 1000u) << "and keeps them while mapping";
  }
  EXPECT_GE(found, 2) << "of 3 seeds";
  o.grid.kld_min_particles = 0;
  o.seed = 1;
  GridParticleFilter fixed(o);
  ASSERT_TRUE(fixed.loadGridMap(map));
  ASSERT_TRUE(fixed.setMapping(false));
  ASSERT_TRUE(fixed.spreadOverMap());
  for (int k = 0; k < 40; ++k) {
    standingStep(&fixed, truth);
    ASSERT_EQ(count(fixed), 1000u) << "without KLD-sampling";
  }
  // More than `particles` at least is refused, naming both.
  o.grid.kld_min_particles = 1001;
  try {
    GridParticleFilter refused(o);
    ADD_FAILURE() << "kld_min_particles above particles accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("grid.kld_min_particles = 1001 is above particles = 1000"),
              std::string::npos)
        << e.what();
  }
}

// The candidates wait for a scan with a hit (a scan of free cells only scores every pose alike
// under the likelihood field), and mapping ends a spread: with resampling otherwise off, only a
// draw from the candidates resamples.
TEST(GlobalLocalization, CandidatesWaitForAHitAndMappingEndsTheSpread) {
  FilterOptions o = globalOptions(100);
  o.grid.match_model = "likelihood_field";
  o.grid.spread_candidates = 20;
  o.resample_threshold = 0.0;
  o.grid.laser_no_return_free_m = 2.0;  // a beam without a return clears 2 m
  const Pose2 truth(1.8, -1.2, 2.0);
  GridParticleFilter filter(o);
  ASSERT_TRUE(filter.loadGridMap(asymmetricRoomMap(o.grid)));
  ASSERT_TRUE(filter.setMapping(false));
  ASSERT_TRUE(filter.spreadOverMap());
  FeatureSet no_hit = asymmetricRoomScan(truth);
  auto open = std::make_shared<RangeScan>(*no_hit.scan);
  for (float& r : open->ranges) r = open->range_max;
  no_hit.scan = open;
  LocalMapStats ignored;
  const std::vector<LocalMapCell> free_only = buildLocalMap(no_hit, o.grid, &ignored);
  ASSERT_FALSE(free_only.empty());
  ASSERT_TRUE(std::none_of(free_only.begin(), free_only.end(),
                           [](const LocalMapCell& c) { return c.occupied; }));
  const std::vector<WeightedPose> spread = filter.particles();
  UpdateStats step = filter.update(no_hit);
  EXPECT_FALSE(step.resampled) << "drawn from candidates at a scan without a hit";
  const std::vector<WeightedPose> after = filter.particles();
  for (size_t i = 0; i < spread.size(); ++i) {
    ASSERT_EQ(after[i].pose, spread[i].pose) << i;
  }
  step = filter.update(asymmetricRoomScan(truth));
  EXPECT_TRUE(step.resampled) << "not drawn from candidates at the first scan with a hit";
  ASSERT_TRUE(filter.spreadOverMap());
  ASSERT_TRUE(filter.setMapping(true));
  ASSERT_TRUE(filter.setMapping(false));
  step = filter.update(asymmetricRoomScan(truth));
  EXPECT_FALSE(step.resampled) << "a spread pending after mapping was turned on";
}

// The distance transform is exact (against every occupied cell) and capped.
TEST(LikelihoodField, DistancesAreExactAndCapped) {
  TiledLogOddsGrid grid(0.1, -1.0, 2.0, 37, 23, 8);
  std::mt19937 rng(7);
  std::vector<std::pair<int, int>> occupied;
  for (int k = 0; k < 12; ++k) {
    const int x = static_cast<int>(rng() % 37), y = static_cast<int>(rng() % 23);
    grid.add(x, y, 1.0f, 6.0f);
    occupied.emplace_back(x, y);
  }
  grid.add(3, 3, -1.0f, 6.0f);  // free cells are not walls
  const double cap = 0.9;
  const std::vector<float> d = distanceToOccupied(grid, cap);
  ASSERT_EQ(d.size(), 37u * 23u);
  for (int y = 0; y < 23; ++y) {
    for (int x = 0; x < 37; ++x) {
      double best = 1e9;
      for (const auto& [ox, oy] : occupied) best = std::min(best, std::hypot(x - ox, y - oy) * 0.1);
      EXPECT_NEAR(d[y * 37 + x], std::min(best, cap), 1e-5) << x << ", " << y;
    }
  }
  // No wall at all: everything is as far as the cap.
  const std::vector<float> empty = distanceToOccupied(TiledLogOddsGrid(0.1, 0, 0, 5, 4, 8), cap);
  for (float v : empty) EXPECT_FLOAT_EQ(v, cap);
}

// A misspelt model or an unusable field or spread parameter is refused by name.
TEST(LikelihoodField, BadOptionsAreRefusedByName) {
  auto error = [](const GridOptions& g) -> std::string {
    FilterOptions o = gridOptions(5);
    o.grid = g;
    try {
      GridParticleFilter filter(o);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  GridOptions g = gridOptions(5).grid;
  EXPECT_EQ(error(g), "");
  g.match_model = "likelihood-field";
  EXPECT_NE(error(g).find("grid.match_model"), std::string::npos) << error(g);
  EXPECT_NE(error(g).find("likelihood-field"), std::string::npos) << error(g);
  g = gridOptions(5).grid;
  g.field_sigma_m = 0.0;
  EXPECT_NE(error(g).find("grid.field_sigma_m"), std::string::npos) << error(g);
  g = gridOptions(5).grid;
  g.field_z_hit = std::nan("");
  EXPECT_NE(error(g).find("grid.field_z_hit"), std::string::npos) << error(g);
  g = gridOptions(5).grid;
  g.spread_candidates = 0;
  EXPECT_NE(error(g).find("grid.spread_candidates"), std::string::npos) << error(g);
  g = gridOptions(5).grid;
  g.spread_match_f = -1.0;
  EXPECT_NE(error(g).find("grid.spread_match_f"), std::string::npos) << error(g);
}

// A scan scores best where it was taken; hits off the map count as the farthest.
TEST(LikelihoodField, ScoresTheTruePoseAboveShiftedOnes) {
  FilterOptions o = globalOptions(10);
  const GridMapData map = asymmetricRoomMap(o.grid);
  const TiledLogOddsGrid grid = gridFromMap(map, o.grid);
  const LikelihoodField field = likelihoodField(grid, o.grid);
  // The table holds each cell's log likelihood of a hit, from its distance to a wall.
  const std::vector<float> d = distanceToOccupied(grid, o.grid.field_max_dist_m);
  ASSERT_EQ(field.cell_log_likelihood.size(), d.size());
  const double sigma = o.grid.field_sigma_m, z_hit = o.grid.field_z_hit;
  for (size_t i = 0; i < d.size(); ++i) {
    const double expected =
        std::log(z_hit * std::exp(-d[i] * d[i] / (2 * sigma * sigma)) + 1.0 - z_hit);
    ASSERT_NEAR(field.cell_log_likelihood[i], expected, 1e-6 * (1.0 + std::fabs(expected))) << i;
  }
  const Pose2 truth(1.8, -1.2, 2.0);
  LocalMapStats ignored;
  const auto local = buildLocalMap(asymmetricRoomScan(truth), o.grid, &ignored);
  const double at_truth = fieldLogLikelihood(local, truth, grid, field);
  EXPECT_GT(at_truth, -0.1 * local.size());  // nearly every hit on a wall
  for (const Pose2& off : {Pose2(2.0, -1.2, 2.0), Pose2(1.8, -1.0, 2.0), Pose2(1.8, -1.2, 2.1),
                           Pose2(-1.8, 1.2, 2.0 - M_PI)}) {
    EXPECT_LT(fieldLogLikelihood(local, off, grid, field), at_truth - 1.0) << off.transpose();
  }
  const double z_miss = std::log(1.0 - o.grid.field_z_hit);
  int hits = 0;
  for (const auto& c : local) hits += c.occupied;
  EXPECT_NEAR(fieldLogLikelihood(local, Pose2(100, 100, 0), grid, field), hits * z_miss,
              1e-9 * hits);
}

// Through a session: global localization needs a prior grid map; asked before the first frame
// it is the start of this run and of a restarted one (bag played again); ~reset forgets it, a
// start pose given after it replaces it; asked during a run it spreads the particles at once.
TEST(GlobalLocalization, TheSessionSpreadsWhenAndAsOftenAsAsked) {
  FilterOptions o = globalOptions(500);
  SessionOptions session_options;
  session_options.filter_origin = "start";
  SlamSession session(createFilter(o), session_options);
  std::string why;
  EXPECT_FALSE(session.localizeGlobally(&why));
  EXPECT_NE(why.find("no grid map is loaded"), std::string::npos) << why;
  const GridMapData map = asymmetricRoomMap(o.grid);
  ASSERT_TRUE(session.setPriorGridMap(map));
  EXPECT_FALSE(session.localizeGlobally(&why));  // thousands of maps from random poses
  EXPECT_NE(why.find("mapping is on"), std::string::npos) << why;
  ASSERT_TRUE(session.setMapping(false));
  // A map whose free space is all unknown has nowhere to spread over.
  GridMapData unknown = map;
  for (auto& cell : unknown.cells) {
    if (cell >= 0 && cell < 50) cell = -1;
  }
  ASSERT_TRUE(session.setPriorGridMap(unknown));
  EXPECT_FALSE(session.localizeGlobally(&why));
  EXPECT_NE(why.find("no free cell"), std::string::npos) << why;
  ASSERT_TRUE(session.setPriorGridMap(map));
  ASSERT_TRUE(session.localizeGlobally());
  const Pose2 truth(1.8, -1.2, 2.0), odom(5.0, 7.0, 0.3);
  const FeatureSet none;  // frames without readings: the spread stays as drawn
  // Spread over the room (6 m x 4 m: a uniform spread has variances 3 and 1.3 m^2), in the
  // map frame although the filter runs centred on the first odometry pose (5, 7); 10 cm of
  // margin for a step of motion.
  auto spread = [&]() {
    for (const WeightedPose& p : session.filter().particles()) {
      if (!(std::fabs(p.pose.x()) < 3.1 && std::fabs(p.pose.y()) < 2.1)) return false;
    }
    return session.filter().estimate().covariance(0, 0) > 1.0;
  };
  session.process(1.0, odom, none);
  EXPECT_TRUE(spread());
  session.process(2.0, Pose2(odom.x() + 0.01, odom.y(), odom.z()), none);
  EXPECT_TRUE(spread());
  // A grid map loaded during the run keeps the global start for a restarted run.
  ASSERT_TRUE(session.setPriorGridMap(map));
  session.reset();  // the clock went back: spread again
  session.process(1.0, odom, none);
  EXPECT_TRUE(spread()) << "after a restart";
  session.reset(SlamSession::ResetCause::kRequested);  // forgotten: map = odom at the start
  session.process(1.0, odom, none);
  EXPECT_FALSE(spread());
  EXPECT_LT((session.filter().estimate().mean.head<2>() - odom.head<2>()).norm(), 1e-6);
  // Asked during a run (the node's ~global_localization): spread at once; map -> odom stays
  // until the next update.
  const Pose2 map_to_odom = session.mapToOdom();
  ASSERT_TRUE(session.localizeGlobally());
  EXPECT_TRUE(spread()) << "asked during a run";
  EXPECT_LT((session.mapToOdom() - map_to_odom).norm(), 1e-12);
  // A start pose given before the first frame replaces a global start asked before it.
  session.reset(SlamSession::ResetCause::kRequested);
  ASSERT_TRUE(session.localizeGlobally());
  ASSERT_TRUE(session.setPose(truth, Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal()));
  session.process(1.0, odom, none);
  EXPECT_FALSE(spread());
  EXPECT_LT((session.filter().estimate().mean.head<2>() - truth.head<2>()).norm(), 0.05);
  // ... and a global start the start pose given before it.
  session.reset(SlamSession::ResetCause::kRequested);
  ASSERT_TRUE(session.setPose(truth, Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal()));
  ASSERT_TRUE(session.localizeGlobally());
  session.process(1.0, odom, none);
  EXPECT_TRUE(spread()) << "global after a start pose";
  session.reset();
  session.process(1.0, odom, none);
  EXPECT_TRUE(spread()) << "global after a start pose, restarted";
}

// The config's global_localization (GlobalStart::kConfigured, as applyMapConfig asks): unlike a
// global start asked through ~global_localization, ~reset keeps it; a start pose given before a
// run's first frame wins for that run only; a grid without a free cell loaded since is named.
TEST(GlobalLocalization, TheConfiguredStartOutlivesARequestedReset) {
  FilterOptions o = globalOptions(500);
  SessionOptions session_options;
  session_options.filter_origin = "start";
  SlamSession session(createFilter(o), session_options);
  const GridMapData map = asymmetricRoomMap(o.grid);
  ASSERT_TRUE(session.setPriorGridMap(map));
  ASSERT_TRUE(session.setMapping(false));
  std::string why;
  ASSERT_TRUE(session.localizeGlobally(&why, SlamSession::GlobalStart::kConfigured)) << why;
  EXPECT_TRUE(session.startsGlobally());
  const Pose2 truth(1.8, -1.2, 2.0), odom(5.0, 7.0, 0.3);
  const FeatureSet none;
  auto spread = [&]() { return session.filter().estimate().covariance(0, 0) > 1.0; };
  session.process(1.0, odom, none);
  EXPECT_TRUE(spread());
  EXPECT_FALSE(session.startsGlobally());  // this run has started
  for (int i = 0; i < 2; ++i) {            // twice: the start is not used up by the first reset
    session.reset(SlamSession::ResetCause::kRequested);
    EXPECT_TRUE(session.startsGlobally()) << i;
    session.process(1.0, odom, none);
    EXPECT_TRUE(spread()) << "after ~reset " << i;
  }
  // A start pose before the next first frame: that run (and its restarts) starts there ...
  session.reset(SlamSession::ResetCause::kRequested);
  ASSERT_TRUE(session.setPose(truth, Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal()));
  EXPECT_FALSE(session.startsGlobally());
  session.process(1.0, odom, none);
  EXPECT_FALSE(spread());
  EXPECT_LT((session.filter().estimate().mean.head<2>() - truth.head<2>()).norm(), 0.05);
  session.reset();  // the clock went back
  EXPECT_FALSE(session.startsGlobally());
  session.process(1.0, odom, none);
  EXPECT_LT((session.filter().estimate().mean.head<2>() - truth.head<2>()).norm(), 0.05);
  // ... until ~reset forgets it: the configured start again.
  session.reset(SlamSession::ResetCause::kRequested);
  EXPECT_TRUE(session.startsGlobally());
  session.process(1.0, odom, none);
  EXPECT_TRUE(spread()) << "after ~reset forgot the start pose";
  // The service's global start, by contrast, is forgotten by ~reset.
  SlamSession asked(createFilter(o), session_options);
  ASSERT_TRUE(asked.setPriorGridMap(map));
  ASSERT_TRUE(asked.setMapping(false));
  ASSERT_TRUE(asked.localizeGlobally());
  asked.process(1.0, odom, none);
  asked.reset(SlamSession::ResetCause::kRequested);
  why = "stale";
  EXPECT_FALSE(asked.startsGlobally(&why));
  EXPECT_EQ(why, "") << "none asked for: no reason";
  // A grid without a free cell loaded since: asked for, but it cannot be done, and says why.
  GridMapData unknown = map;
  for (auto& cell : unknown.cells) {
    if (cell >= 0 && cell < 50) cell = -1;
  }
  ASSERT_TRUE(session.setPriorGridMap(unknown));
  session.reset(SlamSession::ResetCause::kRequested);
  EXPECT_FALSE(session.startsGlobally(&why));
  EXPECT_NE(why.find("no free cell"), std::string::npos) << why;
  ASSERT_TRUE(session.setPriorGridMap(map));
  EXPECT_TRUE(session.startsGlobally(&why)) << why;
  ASSERT_TRUE(session.setMapping(true));
  EXPECT_FALSE(session.startsGlobally(&why));
  EXPECT_NE(why.find("mapping is on"), std::string::npos) << why;
}

// A gap reset while the particles are still spread over the map (global localization under
// way) spreads them again: the cloud's mean is no place to restart around (a Gaussian with the
// cloud's covariance would put particles outside the room). Once the robot is placed, a gap
// restarts where it is, as on any prior map.
TEST(GlobalLocalization, AGapResetWhileSpreadSpreadsAgain) {
  FilterOptions o = globalOptions(500);
  SessionOptions session_options;
  session_options.gap_action = "reset";  // a frame more than max_time_gap_s (30) after the last
  SlamSession session(createFilter(o), session_options);
  ASSERT_TRUE(session.setPriorGridMap(asymmetricRoomMap(o.grid)));
  ASSERT_TRUE(session.setMapping(false));
  ASSERT_TRUE(session.localizeGlobally());
  const FeatureSet none;  // frames without readings: the spread stays as drawn
  auto spread = [&]() {   // over the 6 m x 4 m room (variances 3 and 1.3 m^2)
    for (const WeightedPose& p : session.filter().particles()) {
      if (!(std::fabs(p.pose.x()) < 3.1 && std::fabs(p.pose.y()) < 2.1)) return false;
    }
    return session.filter().estimate().covariance(0, 0) > 1.0;
  };
  session.process(1.0, Pose2(5.0, 7.0, 0.3), none);
  ASSERT_TRUE(spread());
  EXPECT_TRUE(session.filter().stillSpread());
  EXPECT_EQ(session.process(41.0, Pose2(5.5, 7.0, 0.3), none), FrameResult::kReset);
  EXPECT_EQ(session.gaps(), 1);
  EXPECT_TRUE(spread()) << "after a gap while spread";
  EXPECT_TRUE(session.filter().stillSpread());
  // Placed (rviz's 2D Pose Estimate during the run): no longer spread; a gap goes on from there.
  const Pose2 truth(1.8, -1.2, 0.0);
  ASSERT_TRUE(session.setPose(truth, Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal()));
  EXPECT_FALSE(session.filter().stillSpread());
  EXPECT_EQ(session.process(81.0, Pose2(5.5, 7.0, 0.3), none), FrameResult::kReset);
  EXPECT_EQ(session.gaps(), 2);
  EXPECT_FALSE(spread());
  EXPECT_LT((session.filter().estimate().mean.head<2>() - truth.head<2>()).norm(), 0.1);
}

TEST(SlamPipeline, ConeReadingsReachTheFilterInTheBaseFrameOfTheUpdate) {
  PipelineOptions o;
  o.filter = gridOptions(5);
  o.sonar.extract_lines = false;
  o.sonar.extract_points = false;
  o.sonar.extract_distance_m = 0.1;
  SlamPipeline pipeline(o);
  ConeReading r;
  r.range = 1.0;
  r.max_range = 5.0;
  r.field_of_view = 0.3;
  r.sensor_pose = Pose2(0.1, 0.0, 0.0);
  EXPECT_EQ(pipeline.processSonar({r}, Pose2::Zero(), 1.0), FrameResult::kFirstFrame);
  ASSERT_EQ(pipeline.lastFeatures().cones.size(), 1u);
  EXPECT_EQ(pipeline.processSonar({r}, Pose2(0.02, 0.0, 0.0), 1.1), FrameResult::kUpdated);
  ASSERT_EQ(pipeline.lastFeatures().cones.size(), 1u);
  // Two readings 5 cm apart (the second does not move enough), then an update 12 cm on.
  EXPECT_EQ(pipeline.processSonar({r}, Pose2(0.07, 0.0, 0.0), 1.2),
            FrameResult::kBuffered);
  r.sensor_pose = Pose2(0.0, 0.1, M_PI / 2);
  EXPECT_EQ(pipeline.processSonar({r}, Pose2(0.14, 0.0, 0.0), 1.3), FrameResult::kUpdated);
  const std::vector<ConeReading>& cones = pipeline.lastFeatures().cones;
  ASSERT_EQ(cones.size(), 2u);
  EXPECT_NEAR(cones[0].sensor_pose.x(), 0.1 - 0.07, 1e-12);  // fired 7 cm behind
  EXPECT_NEAR(cones[1].sensor_pose.y(), 0.1, 1e-12);
  EXPECT_NEAR(cones[1].sensor_pose.z(), M_PI / 2, 1e-12);
  // The landmark variants get them too, and ignore them.
  o.filter.variant = "fastslam2";
  SlamPipeline landmarks(o);
  EXPECT_EQ(landmarks.processSonar({r}, Pose2::Zero(), 1.0), FrameResult::kFirstFrame);
  EXPECT_TRUE(landmarks.session().filter().landmarks().empty());
}

TEST(LandmarkRaster, LinesAndPointsBecomeOccupiedCells) {
  LandmarkEstimate wall;
  wall.type = LandmarkType::kLine;
  wall.start = Eigen::Vector2d(0.0, 0.0);
  wall.end = Eigen::Vector2d(2.0, 0.0);
  LandmarkEstimate post;
  post.mean = Eigen::Vector2d(1.0, 1.0);
  const GridMapData g = rasterizeLandmarks({wall, post}, 0.1, 0.5, 0.1);
  EXPECT_NEAR(g.origin_x_m, -0.5, 1e-12);
  EXPECT_NEAR(g.origin_y_m, -0.5, 1e-12);
  EXPECT_NEAR(g.width, 30, 1);   // x from -0.5 to 2.0 + 0.5
  EXPECT_NEAR(g.height, 21, 1);  // y from -0.5 to 1.1 + 0.5
  const long occupied = g.count(100, 100);
  EXPECT_GE(occupied, 20 + 1);
  EXPECT_LE(occupied, 21 + 9);
  EXPECT_EQ(g.at(5, 5), 100);   // (0.05, 0.05): the wall's first cell
  EXPECT_EQ(g.at(15, 15), 100); // (1.05, 1.05): the post
  EXPECT_EQ(g.at(15, 10), -1);
  EXPECT_EQ(g.count(-1, -1) + occupied, static_cast<long>(g.cells.size()));
}

TEST(GridConfig, ShippedGridConfigsSelectTheVariantAndItsSensors) {
  const std::string dir = std::string(RBPF_SOURCE_DIR) + "/config/";
  const io::SlamConfig ir = io::loadSlamConfig(dir + "grid_pf.yaml");
  EXPECT_EQ(ir.filter.variant, "grid_pf");
  EXPECT_EQ(ir.frontend, "sonar");
  EXPECT_EQ(ir.ros.sonar_topics, std::vector<std::string>{"ir"});  // the simulator's infrared topic
  EXPECT_EQ(ir.filter.motion.model, "diff_drive");
  EXPECT_DOUBLE_EQ(ir.filter.motion.wheel_base_m, 0.053);
  EXPECT_DOUBLE_EQ(ir.filter.grid.resolution_m, 0.01);
  EXPECT_DOUBLE_EQ(ir.filter.grid.match_f, 100.0);
  EXPECT_EQ(io::loadSlamConfig(dir + "grid_pf_sonar.yaml").ros.sonar_topics,
            std::vector<std::string>{"sonar"});
  const io::SlamConfig laser = io::loadSlamConfig(dir + "grid_pf_laser.yaml");
  EXPECT_EQ(laser.frontend, "laser");
  EXPECT_TRUE(laser.scan_matching.enabled);
  EXPECT_NO_THROW(createFilter(laser.filter));
}

/// The ConfigError applyMapConfig throws for config (with map_file set), "" when it loads.
std::string mapConfigError(const io::SlamConfig& config, SlamPipeline* pipeline) {
  try {
    io::applyMapConfig(config, &pipeline->session());
  } catch (const io::ConfigError& e) {
    return e.what();
  }
  return "";
}

// grid_pf starts from an occupancy-grid map (map_server's map.yaml), the landmark variants from
// a landmarks YAML: a file of the other kind is named as such, not met by a parser's complaint
// about a missing key; a missing file is named; a good map loads, and localization_only turns
// mapping off.
TEST(GridConfig, EachVariantStartsFromItsKindOfMapFile) {
  char dir[] = "/tmp/grid_map_configXXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const GridMapData g = smallMap({100, 0, -1, 100, 0, -1});
  const std::string grid_yaml = io::writeGridMap(std::string(dir) + "/m", g)[1];
  const std::string landmarks_yaml = std::string(dir) + "/landmarks.yaml";
  std::ofstream(landmarks_yaml) << "landmarks: []\n";
  const std::string configs = std::string(RBPF_SOURCE_DIR) + "/config/";

  io::SlamConfig grid = io::loadSlamConfig(configs + "grid_pf.yaml");
  grid.map_file = landmarks_yaml;
  SlamPipeline grid_pipeline(grid.pipeline());
  EXPECT_NE(mapConfigError(grid, &grid_pipeline).find("a landmarks YAML; variant grid_pf maps cells"),
            std::string::npos)
      << mapConfigError(grid, &grid_pipeline);
  grid.map_file = std::string(dir) + "/missing.yaml";
  EXPECT_NE(mapConfigError(grid, &grid_pipeline).find("map_file: " + grid.map_file),
            std::string::npos)
      << mapConfigError(grid, &grid_pipeline);
  EXPECT_FALSE(grid_pipeline.session().hasPriorMap());
  grid.map_file = grid_yaml;
  grid.localization_only = true;
  EXPECT_EQ(mapConfigError(grid, &grid_pipeline), "");
  {
    SlamPipeline described(grid.pipeline());  // what was loaded, and a note: 0.1 m over 0.01 m
    const std::string loaded = io::applyMapConfig(grid, &described.session());
    EXPECT_NE(loaded.find("a 3 x 2 grid of 0.1 m cells (2 occupied, 2 free); note: its cells are "
                          "coarser than grid.resolution_m (0.01 m)"),
              std::string::npos)
        << loaded;
    EXPECT_EQ(loaded.find("inverted"), std::string::npos) << loaded;
    EXPECT_EQ(loaded.find("likelihood_field"), std::string::npos) << loaded;
  }
  {
    // The likelihood field weighs only while localizing: a mapping run (with a map or without)
    // is told it weighs by eq. 14.
    io::SlamConfig mapping = grid;
    mapping.localization_only = false;
    mapping.filter.grid.match_model = "likelihood_field";
    for (const std::string& map_file : {grid_yaml, std::string()}) {
      mapping.map_file = map_file;
      const std::vector<std::string> notes = io::configNotes(mapping);
      ASSERT_EQ(notes.size(), 1u) << map_file;
      EXPECT_NE(notes[0].find("grid.match_model likelihood_field weighs only while localizing"),
                std::string::npos)
          << notes[0];
    }
    mapping.localization_only = true;
    EXPECT_TRUE(io::configNotes(mapping).empty());
    mapping.localization_only = false;
    mapping.filter.grid.match_model = "map_matching";
    EXPECT_TRUE(io::configNotes(mapping).empty());
  }
  {
    // global_localization: every run starts spread, the first and one after ~reset; a landmark
    // variant is told what the key needs.
    io::SlamConfig global = grid;
    global.global_localization = true;
    SlamPipeline spread(global.pipeline());
    EXPECT_EQ(mapConfigError(global, &spread), "");
    EXPECT_TRUE(spread.session().startsGlobally());
    spread.session().reset(SlamSession::ResetCause::kRequested);
    EXPECT_TRUE(spread.session().startsGlobally()) << "after ~reset";
    SlamPipeline plain(grid.pipeline());
    EXPECT_EQ(mapConfigError(grid, &plain), "");
    EXPECT_FALSE(plain.session().startsGlobally());
  }
  EXPECT_TRUE(grid_pipeline.session().hasPriorMap());
  EXPECT_FALSE(grid_pipeline.session().mapping());
  GridMapData loaded;
  ASSERT_TRUE(grid_pipeline.session().filter().occupancyGrid(loaded));
  EXPECT_EQ(loaded.count(65, 100), 200);  // 2 map cells of 0.1 m, each 100 cells of 0.01 m
  EXPECT_EQ(loaded.count(0, 19), 200);

  io::SlamConfig landmarks = io::loadSlamConfig(configs + "laser_fastslam2.yaml");
  landmarks.map_file = grid_yaml;
  SlamPipeline landmark_pipeline(landmarks.pipeline());
  EXPECT_NE(mapConfigError(landmarks, &landmark_pipeline)
                .find("an occupancy-grid map (map_server's map.yaml); variant fastslam2 maps "
                      "landmarks"),
            std::string::npos)
      << mapConfigError(landmarks, &landmark_pipeline);
  landmarks.map_file = landmarks_yaml;
  EXPECT_EQ(mapConfigError(landmarks, &landmark_pipeline), "");
  landmarks.localization_only = landmarks.global_localization = true;
  SlamPipeline landmark_global(landmarks.pipeline());
  const std::string refused = mapConfigError(landmarks, &landmark_global);
  EXPECT_NE(refused.find("global_localization: true (grid_pf on a map_server map with"),
            std::string::npos)
      << refused;
  EXPECT_NE(refused.find("variant fastslam2 localizes on a landmark map"), std::string::npos)
      << refused;
  for (const std::string& f : {grid_yaml, std::string(dir) + "/m.pgm", landmarks_yaml}) {
    std::remove(f.c_str());
  }
  rmdir(dir);
}

// The map files a user can get wrong, each named: the image given for the YAML, a directory, a
// missing image, and a map with nothing occupied (nothing to localize on).
TEST(GridConfig, UnusableGridMapFilesAreNamed) {
  char dir[] = "/tmp/grid_map_unusableXXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string d = dir;
  io::SlamConfig config = io::loadSlamConfig(std::string(RBPF_SOURCE_DIR) + "/config/grid_pf.yaml");
  SlamPipeline pipeline(config.pipeline());
  auto error = [&](const std::string& file) {
    config.map_file = file;
    return mapConfigError(config, &pipeline);
  };
  const std::vector<std::string> files =
      io::writeGridMap(d + "/m", smallMap({100, 0, -1, 0, 0, 0}));
  EXPECT_EQ(error(files[1]), "");
  EXPECT_NE(error(files[0]).find("an image; give the map's .yaml"), std::string::npos)
      << error(files[0]);
  EXPECT_NE(error(d).find("cannot be read (not a file)"), std::string::npos) << error(d);
  const std::vector<std::string> empty = io::writeGridMap(d + "/e", smallMap({0, 0, -1, 0, 0, -1}));
  EXPECT_NE(error(empty[1]).find("the map has no occupied cell (4 free, 2 unknown, 0 between"),
            std::string::npos)
      << error(empty[1]);
  std::remove(empty[0].c_str());
  EXPECT_NE(error(empty[1]).find("e.pgm (the image of " + empty[1] + "): cannot be read"),
            std::string::npos)
      << error(empty[1]);
  for (const std::string& f : {files[0], files[1], empty[1]}) std::remove(f.c_str());
  rmdir(dir);
}

TEST(GridConfig, ErrorsNameTheGridKey) {
  auto error = [](const std::string& yaml) -> std::string {
    try {
      io::parseSlamConfig(YAML::Load(yaml), "t.yaml");
    } catch (const io::ConfigError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error("variant: grid_pf\ngrid: {resolution_m: 0}").find("grid.resolution_m"),
            std::string::npos);
  EXPECT_NE(error("variant: grid_pf\ngrid: {match_f: -1}").find("grid.match_f"),
            std::string::npos);
  EXPECT_NE(error("grid: {resolutoin_m: 0.1}").find("resolutoin_m"), std::string::npos);
  EXPECT_NE(error("variant: grid_pf\ngrid: {max_size_m: -1}").find("grid.max_size_m"),
            std::string::npos);
  EXPECT_EQ(error("variant: grid_pf\ngrid: {size_x_m: 50, max_size_m: 0}"), "");
  EXPECT_NE(error("map_update_period: -1").find("map_update_period"), std::string::npos);
  EXPECT_NE(error("variant: grid_pf\nparticles: 100\ngrid: {kld_min_particles: 200}")
                .find("grid.kld_min_particles = 200 is above particles = 100"),
            std::string::npos);
  EXPECT_NE(error("variant: grid_pf\ngrid: {kld_error: 0}").find("grid.kld_error"),
            std::string::npos);
  // global_localization: a start spread over the map is for localization only.
  EXPECT_NE(error("variant: grid_pf\nmap_file: m.yaml\nglobal_localization: true")
                .find("global_localization = true needs localization_only"),
            std::string::npos);
  EXPECT_EQ(error("variant: grid_pf\nmap_file: m.yaml\nlocalization_only: true\n"
                  "global_localization: true"),
            "");
  EXPECT_NE(error("variant: grid_pf\nglobal_localization: maybe").find("global_localization"),
            std::string::npos);
}

TEST(GridMapFile, WritesAndReadsMapServerFiles) {
  const GridMapData g = smallMap({100, 0, -1, 70, 19, 50}, -1.5, 2.0);
  char dir[] = "/tmp/grid_map_fileXXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::vector<std::string> files = io::writeGridMap(std::string(dir) + "/m", g);
  ASSERT_EQ(files.size(), 2u);
  const GridMapData back = io::readGridMap(files[1]);
  EXPECT_EQ(back.width, 3);
  EXPECT_EQ(back.height, 2);
  EXPECT_DOUBLE_EQ(back.resolution_m, 0.1);
  EXPECT_DOUBLE_EQ(back.origin_x_m, -1.5);
  EXPECT_DOUBLE_EQ(back.origin_y_m, 2.0);
  // Trinary: >= 65 occupied, 0..19 free, the rest unknown.
  EXPECT_EQ(back.cells, (std::vector<int8_t>{100, 0, -1, 100, 0, -1}));
  for (const auto& f : files) std::remove(f.c_str());
  // A name that YAML would cut (' #') or not parse (': ', brackets, quotes) unquoted.
  for (const std::string name : {"lab #2", "run: 1", "[a]", "say \"hi\""}) {
    const std::vector<std::string> named = io::writeGridMap(std::string(dir) + "/" + name, g);
    EXPECT_EQ(io::readGridMap(named[1]).cells, back.cells) << name;
    for (const auto& f : named) std::remove(f.c_str());
  }
  rmdir(dir);
}

/// The message of the error readGridMap throws on the map written as files, with its YAML
/// edited ("" when it loads).
std::string gridMapError(const GridMapData& g, const std::string& from, const std::string& to,
                         const std::string& pgm_header = "") {
  char dir[] = "/tmp/grid_map_badXXXXXX";
  if (mkdtemp(dir) == nullptr) return "mkdtemp failed";
  const std::vector<std::string> files = io::writeGridMap(std::string(dir) + "/m", g);
  std::ifstream in(files[1]);
  std::string yaml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!from.empty()) yaml.replace(yaml.find(from), from.size(), to);
  std::ofstream(files[1]) << yaml;
  if (!pgm_header.empty()) std::ofstream(files[0], std::ios::binary) << pgm_header;
  std::string message;
  try {
    io::readGridMap(files[1]);
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  for (const auto& f : files) std::remove(f.c_str());
  rmdir(dir);
  return message;
}

// readGridMap used to take any resolution and origin, ignore negate and the thresholds, and
// allocate what the PGM header announced before reading the data.
TEST(GridMapFile, BrokenMapFilesAreNamed) {
  const GridMapData g = smallMap({100, 0, -1, 70, 19, 50});
  EXPECT_EQ(gridMapError(g, "", ""), "");
  EXPECT_NE(gridMapError(g, "resolution: 0.1", "resolution: 0").find("resolution must be"),
            std::string::npos);
  EXPECT_NE(gridMapError(g, "resolution: 0.1", "resolution: .nan").find("resolution must be"),
            std::string::npos);
  EXPECT_NE(gridMapError(g, "origin: [0, 0, 0.0]", "origin: [.inf, 0, 0]").find("origin must"),
            std::string::npos);
  EXPECT_NE(gridMapError(g, "origin: [0, 0, 0.0]", "origin: [0, 0, 0.5]").find("origin yaw"),
            std::string::npos);
  EXPECT_NE(gridMapError(g, "origin: [0, 0, 0.0]", "origin: [0, 0, .nan]").find("origin yaw"),
            std::string::npos);
  EXPECT_NE(gridMapError(g, "negate: 0", "negate: 2").find("negate must be 0 or 1"),
            std::string::npos);
  EXPECT_NE(gridMapError(g, "free_thresh: 0.196", "free_thresh: 0.9").find("free_thresh <"),
            std::string::npos);
  const std::string huge = gridMapError(g, "", "", "P5\n100000 100000\n255\n\x01\x02");
  EXPECT_NE(huge.find("truncated (100000 x 100000 pixels announced, 2 bytes of data)"),
            std::string::npos)
      << huge;
}

// map_server's three modes: trinary (thresholds), scale (1..99 between them), raw (the pixel).
TEST(GridMapFile, ScaleAndRawModesFollowMapServer) {
  // Pixels, top row first: 0 (black), 128, 255 (white) / 0, 50, 101.
  const std::string pgm =
      std::string("P5\n3 2\n255\n") + std::string("\x00\x80\xff\x00\x32\x65", 6);
  const GridMapData g = smallMap({-1, -1, -1, -1, -1, -1});
  EXPECT_NE(gridMapError(g, "negate: 0", "negate: 0\nmode: bogus", pgm).find("mode 'bogus'"),
            std::string::npos);
  auto cells = [&](const std::string& mode) {
    char dir[] = "/tmp/grid_map_modeXXXXXX";
    if (mkdtemp(dir) == nullptr) return std::vector<int8_t>{};
    const std::vector<std::string> files = io::writeGridMap(std::string(dir) + "/m", g);
    std::ofstream(files[0], std::ios::binary) << pgm;
    std::ofstream(files[1], std::ios::app) << "mode: " << mode << "\n";
    const std::vector<int8_t> out = io::readGridMap(files[1]).cells;
    for (const auto& f : files) std::remove(f.c_str());
    rmdir(dir);
    return out;
  };
  // Row 0 is the image's bottom row. Occupancy (255 - pixel) / 255: 1, 0.8, 0.6 / 1, 0.5, 0.
  EXPECT_EQ(cells("trinary"), (std::vector<int8_t>{100, 100, -1, 100, -1, 0}));
  // scale: 0.6 -> 1 + 98 (0.6039 - 0.196) / (0.65 - 0.196) = 89; 0.498 -> 66
  EXPECT_EQ(cells("scale"), (std::vector<int8_t>{100, 100, 89, 100, 66, 0}));
  EXPECT_EQ(cells("raw"), (std::vector<int8_t>{0, 50, -1, 0, -1, -1}));
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

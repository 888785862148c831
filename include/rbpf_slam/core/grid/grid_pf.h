#pragma once
// Occupancy-grid particle-filter SLAM for low-cost range sensors (Yatim and Buniyamin 2015):
// differential-drive wheel model (eqs. 11, 12), a log-odds grid per particle (eq. 13), weights
// from matching the local map against the particle's map (eq. 14; or the likelihood field,
// grid.match_model, while localizing on a map), low-variance resampling.

#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/grid/grid_map_data.h"
#include "rbpf_slam/core/grid/grid_options.h"
#include "rbpf_slam/core/grid/inverse_sensor_model.h"
#include "rbpf_slam/core/grid/tiled_grid.h"

namespace rbpf_slam {
namespace core {

/// Eq. 14's match of a local map placed at pose against a grid: the sum over local cells of
/// weight * (+1 occupied, -1 free) * (2 p - 1), p the grid's occupancy (unknown: 0).
double matchLocalMap(const std::vector<LocalMapCell>& local, const Pose2& pose,
                     const TiledLogOddsGrid& grid, const GridOptions& options);
/// How far from the robot a local map reaches (its farthest cell centre plus one cell), m.
double localMapReach(const std::vector<LocalMapCell>& local, double resolution_m);
/// Per cell of grid (y * width + x), the distance to its nearest occupied cell (log odds above
/// 0), m, at most max_dist_m (exact Euclidean, between cell centres).
std::vector<float> distanceToOccupied(const TiledLogOddsGrid& grid, double max_dist_m);
/// grid.match_model likelihood_field over a grid: per cell (y * width + x), the log likelihood
/// of a hit in it, log(z_hit exp(-d^2 / (2 sigma^2)) + 1 - z_hit) with d its distanceToOccupied
/// (capped at grid.field_max_dist_m); off the grid, that of the cap. Computed once per map, so
/// that weighing a hit is one look-up and one addition (no exp or log).
struct LikelihoodField {
  std::vector<float> cell_log_likelihood;
  double off_grid = 0.0;
};
LikelihoodField likelihoodField(const TiledLogOddsGrid& grid, const GridOptions& options);
/// The likelihood field's score of local at pose: the sum over its occupied cells of the field's
/// value where they fall (field built from grid by likelihoodField).
double fieldLogLikelihood(const std::vector<LocalMapCell>& local, const Pose2& pose,
                          const TiledLogOddsGrid& grid, const LikelihoodField& field);
/// The empty grid of the first extent (grid.size_x_m x grid.size_y_m) centred on a pose: every
/// grid of a run (each particle's, render_grid's) starts from it, so all share one tile lattice.
TiledLogOddsGrid firstGrid(const GridOptions& options, const Pose2& centre);
/// A saved occupancy grid (map frame, nav_msgs conventions) as a log-odds grid of
/// options.resolution_m cells over the same extent, cell (0, 0) at the map's: each cell takes
/// the highest occupancy of the map cells it overlaps (a finer cell: the one holding it), as log
/// odds clamped to grid.log_odds_clamp (occupied 100: the clamp, free 0: minus the clamp, unknown
/// -1: 0). Throws std::invalid_argument naming what is wrong with the map (empty, cells missing,
/// non-finite, more than 1e9 cells of options.resolution_m).
TiledLogOddsGrid gridFromMap(const GridMapData& map, const GridOptions& options);
/// How far a grid may grow (TiledLogOddsGrid::grow): grid.max_size_m in tiles per axis (never
/// below the first grid's), and the tiles one table may hold when `tables` of them must fit in
/// the 4 GiB for tile tables.
struct GridGrowthLimits {
  int tiles_x = 0, tiles_y = 0;
  long tiles = 0;
  bool grows = false;  // some axis may grow
};
GridGrowthLimits growthLimits(const GridOptions& options, const TiledLogOddsGrid& first,
                              int tables);
/// Grows the grid to hold a local map reaching `reach` around pose (when limits.grows).
/// Returns false when the grid does not hold all of it (fixed, or at the limits); true for a
/// non-finite pose.
bool growToHold(double reach, const Pose2& pose, const GridGrowthLimits& limits,
                TiledLogOddsGrid* grid);
/// Eq. 13: adds the local map placed at pose to the grid's log odds. Each local cell writes the
/// world cell its placed centre falls in, the cell matchLocalMap reads for it. At headings off
/// the axes some world cells are written twice by one scan and some not at all (~6 % at
/// 0.3 rad). Writing each world cell once was tried and is worse on real laser data: see
/// docs/results.md, "Session 13: one write per world cell (tried, not kept)".
void integrateLocalMap(const std::vector<LocalMapCell>& local, const Pose2& pose,
                       const GridOptions& options, TiledLogOddsGrid* grid);

/// Variant grid_pf: a particle is a pose and a copy-on-write tiled log-odds grid.
class GridParticleFilter : public SlamFilter {
 public:
  explicit GridParticleFilter(const FilterOptions& options);

  std::string variant() const override { return "grid_pf"; }
  void reset(const Pose2& initial_pose = Pose2::Zero()) override;
  void predict(const MotionInput& motion) override;
  /// Uses features.scan and features.cones; landmark features are ignored.
  UpdateStats update(const FeatureSet& features) override;
  PoseEstimate estimate() const override;
  std::vector<LandmarkEstimate> landmarks() const override { return {}; }
  /// With KLD-sampling (grid.kld_min_particles) between that many and `particles` while
  /// localizing; a spread, a start pose, a reset, a map loaded or mapping restores `particles`.
  std::vector<WeightedPose> particles() const override;
  FilterStats stats() const override { return stats_; }
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override;
  /// Every particle starts from this map (gridFromMap, shared tiles), e.g. to localize on a
  /// map saved by an earlier run (with setMapping(false)) or to extend it.
  bool loadGridMap(const GridMapData& map) override;
  double gridResolution() const override { return options_.grid.resolution_m; }
  /// Global localization on the loaded map: every particle starts again on it, at a pose drawn
  /// uniformly over its free cells (log odds below 0 at grid.resolution_m) with any heading.
  /// False when no map is loaded or it has no free cell.
  bool spreadOverMap() override;
  /// A map is loaded and it has a free cell at grid.resolution_m (lists them when first asked).
  bool canSpreadOverMap(std::string* why) const override;
  /// Spread by spreadOverMap, localizing, and not gathered yet (grid.spread_gathered_m).
  bool stillSpread() const override {
    return gathering_ && !mapping_ && !(positionSpread() < options_.grid.spread_gathered_m);
  }
  bool setMapping(bool enabled) override;
  bool occupancyGrid(GridMapData& out) const override;
  bool usesLandmarkFeatures() const override { return false; }

  /// The grid of the particle with the highest weight.
  const TiledLogOddsGrid& bestGrid() const;
  /// Distinct tiles held by all particles (shared tiles counted once) and their bytes.
  long distinctTiles() const;
  size_t gridBytes() const;
  const LocalMapStats& localMapStats() const { return local_stats_; }

 private:
  struct Particle {
    Pose2 pose = Pose2::Zero();
    TiledLogOddsGrid grid;
  };
  int bestIndex() const;
  /// The indices a resampling keeps: as many as there are particles, or while localizing with
  /// KLD-sampling (grid.kld_min_particles), as many as the cloud needs (up to `particles`).
  std::vector<int> drawResampled();
  /// Back to `particles` particles (copies of the first) before a spread, a start pose or a map
  /// load sets them all.
  void restoreFullCount();
  /// Grows each particle's grid (grid.max_size_m > 0) to hold the local map at its pose.
  void growGrids(const std::vector<LocalMapCell>& local);
  /// A pose drawn uniformly over the loaded map's free cells, with any heading.
  Pose2 randomFreePose();
  /// Weighing by the likelihood field (grid.match_model) now: localizing on a loaded map.
  bool fieldInUse() const { return !mapping_ && !field_.cell_log_likelihood.empty(); }
  /// The particles' position spread, sqrt of the trace of their weighted position covariance, m.
  double positionSpread() const;
  /// f of w *= exp(match / f): grid.spread_match_f from a global spread until the particles
  /// gather (grid.spread_gathered_m), else grid.match_f.
  double matchF() const {
    return gathering_ && options_.grid.spread_match_f > 0.0 ? options_.grid.spread_match_f
                                                            : options_.grid.match_f;
  }
  /// The weight's exponent before 1 / f for local at pose: while fieldInUse(), the loaded map's
  /// likelihood field; else eq. 14 against own_grid (the particle's grid, or the loaded map's for
  /// a candidate pose).
  double matchScore(const std::vector<LocalMapCell>& local, const Pose2& pose,
                    const TiledLogOddsGrid& own_grid) const;
  /// The first scan with a hit after a spread: the particles drawn from
  /// grid.spread_candidates times as many uniform poses, by that scan's weight. False when no
  /// candidate had a finite weight (then drawn uniformly).
  bool drawFromCandidates(const std::vector<LocalMapCell>& local);
  /// The loaded map's free cells, listed when first asked for that map.
  const std::vector<int>& freeCells() const;

  const FilterOptions options_;
  const bool field_model_;  // grid.match_model is likelihood_field (parsed once)
  std::unique_ptr<MotionModel> motion_;
  Rng rng_;
  std::vector<Particle> particles_;
  std::vector<double> weights_;  // normalised
  int resampled_best_ = -1;      // after a resampling: the copy of the most probable (bestIndex)
  FilterStats stats_;
  LocalMapStats local_stats_;  // totals since reset
  bool mapping_ = true;
  GridGrowthLimits limits_;
  // The last map loaded (loadGridMap) and its grid, kept to give it again after a reset.
  std::shared_ptr<const GridMapData> loaded_map_;
  TiledLogOddsGrid loaded_grid_;
  // Cells of loaded_grid_ (y * width + x) with log odds < 0, listed by freeCells().
  mutable std::vector<int> free_cells_;
  mutable bool free_cells_listed_ = false;  // free_cells_ is the list for the map loaded last
  // grid.match_model likelihood_field: the field of loaded_grid_ (empty for map_matching).
  LikelihoodField field_;
  bool spread_pending_ = false;  // spread, and no scan weighed since (drawFromCandidates)
  bool gathering_ = false;       // spread, and not yet gathered (grid.spread_match_f in use)
};

}  // namespace core
}  // namespace rbpf_slam

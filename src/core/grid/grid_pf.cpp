#include "rbpf_slam/core/grid/grid_pf.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/filters/pose_moments.h"
#include "rbpf_slam/core/filters/resampling.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kClusterCellRad = 10.0 * M_PI / 180.0;  // estimate()'s heading cells (amcl's)

/// The tile tables of every particle together may take at most this much memory.
constexpr double kMaxTileTablesBytes = 4.0 * (1ull << 30);

/// Refuses (std::invalid_argument) a grid of width x height cells, `what`, whose tile tables
/// would not fit in kMaxTileTablesBytes at the peak: every particle's grid holds a table of
/// tile pointers over the whole grid, allocated when the grid is made (the tiles themselves come
/// as the map fills), and while resampling the copies' tables exist beside them, plus one.
void requireTablesFit(const GridOptions& o, double width, double height, int particles,
                      const std::string& what) {
  const double table_bytes = std::ceil(width / o.tile_cells) * std::ceil(height / o.tile_cells) *
                             static_cast<double>(sizeof(std::shared_ptr<void>));
  const double bytes = table_bytes * (2.0 * particles + 1.0);
  if (bytes <= kMaxTileTablesBytes) return;
  std::ostringstream why;
  why << what << ": the grid's tile tables would take " << std::setprecision(3)
      << bytes / (1ull << 30) << " GiB at the peak (2 x " << particles
      << " particles while resampling + 1, each a table of " << width << " x " << height
      << " cells / grid.tile_cells^2 tiles, " << sizeof(std::shared_ptr<void>)
      << " bytes each), more than " << kMaxTileTablesBytes / (1ull << 30)
      << " GiB: use a smaller map, coarser cells (grid.resolution_m), a larger grid.tile_cells "
         "or fewer particles";
  throw std::invalid_argument(why.str());
}

/// A map's extent in cells of grid.resolution_m; throws std::invalid_argument naming what is
/// wrong with the map (empty, cells missing, non-finite, more cells than 4 GiB of tiles hold).
struct MapExtent {
  int width = 0, height = 0;
};

/// The first extent (grid.size_x_m x grid.size_y_m) in cells: the size of firstGrid(), and
/// what the constructor checks against the memory limit before any table is allocated.
MapExtent firstExtent(const GridOptions& g) {
  return {static_cast<int>(std::ceil(g.size_x_m / g.resolution_m)),
          static_cast<int>(std::ceil(g.size_y_m / g.resolution_m))};
}
MapExtent mapExtent(const GridMapData& map, const GridOptions& g) {
  std::ostringstream size;
  size << map.width << " x " << map.height << " cells of " << map.resolution_m << " m";
  if (map.width <= 0 || map.height <= 0) {
    throw std::invalid_argument("the map is empty (" + size.str() + ")");
  }
  if (map.cells.size() != static_cast<size_t>(map.width) * map.height) {
    throw std::invalid_argument("the map has " + std::to_string(map.cells.size()) +
                                " cell values for " + size.str());
  }
  if (!(std::isfinite(map.resolution_m) && map.resolution_m > 0.0) ||
      !std::isfinite(map.origin_x_m) || !std::isfinite(map.origin_y_m)) {
    throw std::invalid_argument(
        "the map's resolution must be finite and > 0, its origin "
        "finite (" +
        size.str() + ")");
  }
  const double width = std::ceil(map.width * map.resolution_m / g.resolution_m - 1e-9);
  const double height = std::ceil(map.height * map.resolution_m / g.resolution_m - 1e-9);
  // Each known cell takes 4 bytes in its tile: at most 4 GiB of them.
  if (width * height > 1e9) {
    std::ostringstream why;
    why << "the map (" << size.str() << ") is " << width << " x " << height << " cells of "
        << "grid.resolution_m = " << g.resolution_m << " m, more than 1e9 (4 GiB): use coarser "
        << "cells";
    throw std::invalid_argument(why.str());
  }
  return {static_cast<int>(width), static_cast<int>(height)};
}

/// For each of n cells of size `cell` along an axis, the first and last of the map's cells of
/// size `map_cell` (m of them) it overlaps.
std::vector<std::pair<int, int>> coveredCells(int n, double cell, double map_cell, int m) {
  std::vector<std::pair<int, int>> out(n);
  for (int i = 0; i < n; ++i) {
    const int first = std::min(m - 1, static_cast<int>(std::floor(i * cell / map_cell + 1e-9)));
    const int last = static_cast<int>(std::ceil((i + 1) * cell / map_cell - 1e-9)) - 1;
    out[i] = {first, std::min(m - 1, std::max(first, last))};
  }
  return out;
}

}  // namespace

void validate(const GridOptions& o) {
  requireRange("grid.resolution_m", o.resolution_m, 1e-3, 10.0);
  requireRange("grid.size_x_m", o.size_x_m, o.resolution_m, 1e5);
  requireRange("grid.size_y_m", o.size_y_m, o.resolution_m, 1e5);
  requireRange("grid.tile_cells", o.tile_cells, 4, 1024);
  requireRange("grid.max_size_m", o.max_size_m, 0.0, 1e5);
  if (o.size_x_m / o.resolution_m * (o.size_y_m / o.resolution_m) > 4e9) {
    throw std::invalid_argument(
        "grid.size_x_m * grid.size_y_m / grid.resolution_m^2 exceeds "
        "4e9 cells: use coarser cells (a larger grid.resolution_m) or a smaller first extent");
  }
  requireRange("grid.log_odds_occupied", o.log_odds_occupied, 0.0, 100.0);
  requireRange("grid.log_odds_free", o.log_odds_free, -100.0, 0.0);
  requireRange("grid.log_odds_clamp", o.log_odds_clamp, 0.01, 100.0);
  requireRange("grid.cone_arc_thickness_m", o.cone_arc_thickness_m, 0.0, 10.0);
  requireRange("grid.cone_max_range_m", o.cone_max_range_m, 0.0, 1000.0);
  requireRange("grid.max_range_margin_m", o.max_range_margin_m, 0.0, 100.0);
  requireRange("grid.no_echo_free_range_m", o.no_echo_free_range_m, 0.0, 1000.0);
  requireRange("grid.cone_fov_rad", o.cone_fov_rad, 0.0, 3.1);
  requireRange("grid.laser_max_range_m", o.laser_max_range_m, 0.01, 1000.0);
  requireRange("grid.laser_no_return_free_m", o.laser_no_return_free_m, 0.0, 1000.0);
  requireRange("grid.laser_beam_step", o.laser_beam_step, 1, 1000);
  requireRange("grid.match_f", o.match_f, 1e-6, 1e9);
  requireRange("grid.match_occupied_weight", o.match_occupied_weight, 0.0, 1e6);
  requireRange("grid.match_free_weight", o.match_free_weight, 0.0, 1e6);
  if (o.match_model != "map_matching" && o.match_model != "likelihood_field") {
    throw std::invalid_argument(
        "grid.match_model must be map_matching (eq. 14) or "
        "likelihood_field (localization on a map), not \"" +
        o.match_model + "\"");
  }
  requireRange("grid.field_sigma_m", o.field_sigma_m, 1e-3, 100.0);
  requireRange("grid.field_max_dist_m", o.field_max_dist_m, 1e-3, 1000.0);
  requireRange("grid.field_z_hit", o.field_z_hit, 1e-3, 0.999);
  requireRange("grid.spread_candidates", o.spread_candidates, 1, 1000);
  if (o.spread_match_f != 0.0) requireRange("grid.spread_match_f", o.spread_match_f, 1e-6, 1e9);
  requireRange("grid.spread_gathered_m", o.spread_gathered_m, 0.0, 1e6);
  requireRange("grid.kld_min_particles", o.kld_min_particles, 0, 100000);
  requireRange("grid.kld_error", o.kld_error, 1e-4, 1.0);
  requireRange("grid.kld_z", o.kld_z, 0.0, 10.0);
  requireRange("grid.kld_bin_xy_m", o.kld_bin_xy_m, 1e-3, 100.0);
  requireRange("grid.kld_bin_theta_rad", o.kld_bin_theta_rad, 1e-3, 6.3);
}

void requireKldCountFits(const GridOptions& o, int particles) {
  if (o.kld_min_particles > particles) {
    throw std::invalid_argument("grid.kld_min_particles = " + std::to_string(o.kld_min_particles) +
                                " is above particles = " + std::to_string(particles) +
                                " (KLD-sampling keeps between the two)");
  }
}

namespace {

/// Exact squared distances along one line (Felzenszwalb and Huttenlocher's lower envelope of
/// parabolas): f holds squared distances in cells (a large finite value where nothing is) and
/// is replaced by the transform. v, z and out are scratch.
void squaredDistances1d(std::vector<float>& f, std::vector<int>& v, std::vector<double>& z,
                        std::vector<float>& out) {
  const int n = static_cast<int>(f.size());
  if (n == 0) return;
  v.assign(n, 0);
  z.assign(n + 1, 0.0);
  out.assign(n, 0.0f);
  const auto meet = [&f](int q, int p) {  // where the parabolas from q and p cross
    return ((f[q] + static_cast<double>(q) * q) - (f[p] + static_cast<double>(p) * p)) /
           (2.0 * (q - p));
  };
  int k = 0;
  z[0] = -std::numeric_limits<double>::infinity();
  z[1] = std::numeric_limits<double>::infinity();
  for (int q = 1; q < n; ++q) {
    double s = meet(q, v[k]);
    while (s <= z[k]) s = meet(q, v[--k]);  // z[0] = -inf stops it
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = std::numeric_limits<double>::infinity();
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double d = q - v[k];
    out[q] = static_cast<float>(d * d + f[v[k]]);
  }
  f.swap(out);
}

}  // namespace

std::vector<float> distanceToOccupied(const TiledLogOddsGrid& grid, double max_dist_m) {
  const int w = grid.width(), h = grid.height();
  // Capped well above max_dist so that sums of squares cannot overflow a float.
  const float cap_cells = static_cast<float>(max_dist_m / grid.resolution()) + 2.0f;
  const float far = cap_cells * cap_cells;
  std::vector<float> d(static_cast<size_t>(w) * h, far);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (grid.logOdds(x, y) > 0.0f) d[static_cast<size_t>(y) * w + x] = 0.0f;
    }
  }
  std::vector<float> line, out;
  std::vector<double> z;
  std::vector<int> v;
  for (int y = 0; y < h; ++y) {  // along x
    line.assign(d.begin() + static_cast<size_t>(y) * w, d.begin() + static_cast<size_t>(y + 1) * w);
    squaredDistances1d(line, v, z, out);
    std::copy(line.begin(), line.end(), d.begin() + static_cast<size_t>(y) * w);
  }
  for (int x = 0; x < w; ++x) {  // along y
    line.resize(h);
    for (int y = 0; y < h; ++y) line[y] = d[static_cast<size_t>(y) * w + x];
    squaredDistances1d(line, v, z, out);
    for (int y = 0; y < h; ++y) {
      d[static_cast<size_t>(y) * w + x] =
          std::min(static_cast<float>(max_dist_m),
                   std::sqrt(std::min(line[y], far)) * static_cast<float>(grid.resolution()));
    }
  }
  return d;
}

LikelihoodField likelihoodField(const TiledLogOddsGrid& grid, const GridOptions& options) {
  const double inv_two_var = 1.0 / (2.0 * options.field_sigma_m * options.field_sigma_m);
  const auto log_likelihood = [&](double d) {
    return std::log(options.field_z_hit * std::exp(-d * d * inv_two_var) + 1.0 -
                    options.field_z_hit);
  };
  LikelihoodField field;
  field.cell_log_likelihood = distanceToOccupied(grid, options.field_max_dist_m);
  for (float& v : field.cell_log_likelihood) v = static_cast<float>(log_likelihood(v));
  field.off_grid = log_likelihood(options.field_max_dist_m);
  return field;
}

double fieldLogLikelihood(const std::vector<LocalMapCell>& local, const Pose2& pose,
                          const TiledLogOddsGrid& grid, const LikelihoodField& field) {
  double sum = 0.0;
  int cx, cy;
  for (const LocalMapCell& cell : local) {
    if (!cell.occupied) continue;
    sum += grid.cellOf(transformPoint(pose, cell.center), &cx, &cy)
               ? field.cell_log_likelihood[static_cast<size_t>(cy) * grid.width() + cx]
               : field.off_grid;
  }
  return sum;
}

double matchLocalMap(const std::vector<LocalMapCell>& local, const Pose2& pose,
                     const TiledLogOddsGrid& grid, const GridOptions& options) {
  double match = 0.0;
  int cx, cy;
  for (const LocalMapCell& cell : local) {
    if (!grid.cellOf(transformPoint(pose, cell.center), &cx, &cy)) continue;
    const float l = grid.logOdds(cx, cy);
    if (l == 0.0f) continue;
    const double agreement = std::tanh(0.5 * l);  // 2 p - 1
    match += cell.occupied ? options.match_occupied_weight * agreement
                           : -options.match_free_weight * agreement;
  }
  return match;
}

double localMapReach(const std::vector<LocalMapCell>& local, double resolution_m) {
  double reach = 0.0;
  for (const LocalMapCell& cell : local) reach = std::max(reach, cell.center.norm());
  return reach + resolution_m;  // the cell's corners
}

void integrateLocalMap(const std::vector<LocalMapCell>& local, const Pose2& pose,
                       const GridOptions& options, TiledLogOddsGrid* grid) {
  const float occupied = static_cast<float>(options.log_odds_occupied);
  const float free = static_cast<float>(options.log_odds_free);
  const float clamp = static_cast<float>(options.log_odds_clamp);
  int cx, cy;
  for (const LocalMapCell& cell : local) {
    if (grid->cellOf(transformPoint(pose, cell.center), &cx, &cy)) {
      grid->add(cx, cy, cell.occupied ? occupied : free, clamp);
    }
  }
}

GridParticleFilter::GridParticleFilter(const FilterOptions& options)
    : options_(options),
      field_model_(options.grid.match_model == "likelihood_field"),
      motion_(createMotionModel(options.motion)),
      rng_(options.seed) {
  validate(options_.grid);
  if (options_.particles < 1) throw std::invalid_argument("particles must be >= 1");
  requireKldCountFits(options_.grid, options_.particles);
  if (static_cast<double>(options_.particles) * options_.grid.spread_candidates > 1e7) {
    throw std::invalid_argument(
        "particles x grid.spread_candidates exceeds 1e7 poses to weigh at once: lower "
        "grid.spread_candidates");
  }
  const MapExtent first = firstExtent(options_.grid);  // before any table is allocated
  requireTablesFit(options_.grid, first.width, first.height, options_.particles,
                   "grid.size_x_m x grid.size_y_m");
  reset();
}

TiledLogOddsGrid firstGrid(const GridOptions& g, const Pose2& centre) {
  const MapExtent first = firstExtent(g);
  return TiledLogOddsGrid(g.resolution_m, centre.x() - 0.5 * first.width * g.resolution_m,
                          centre.y() - 0.5 * first.height * g.resolution_m, first.width,
                          first.height, g.tile_cells);
}

TiledLogOddsGrid gridFromMap(const GridMapData& map, const GridOptions& g) {
  const MapExtent extent = mapExtent(map, g);
  TiledLogOddsGrid grid(g.resolution_m, map.origin_x_m, map.origin_y_m, extent.width, extent.height,
                        g.tile_cells);
  // Each cell takes the highest occupancy of the map cells it overlaps (occupied over free over
  // unknown): a wall one map cell thick stays a wall in coarser cells.
  const auto xs = coveredCells(extent.width, g.resolution_m, map.resolution_m, map.width);
  const auto ys = coveredCells(extent.height, g.resolution_m, map.resolution_m, map.height);
  const double clamp = g.log_odds_clamp;
  for (int y = 0; y < extent.height; ++y) {
    for (int x = 0; x < extent.width; ++x) {
      int value = -1;
      for (int my = ys[y].first; my <= ys[y].second; ++my) {
        for (int mx = xs[x].first; mx <= xs[x].second; ++mx)
          value = std::max<int>(value, map.at(mx, my));
      }
      if (value < 0) continue;  // unknown: log odds 0, no tile needed
      const double p = std::min(value, 100) / 100.0;
      const double l = std::clamp(std::log(p / (1.0 - p)), -clamp, clamp);  // +-inf at 1 / 0
      if (l != 0.0) grid.add(x, y, static_cast<float>(l), static_cast<float>(clamp));
    }
  }
  return grid;
}

GridGrowthLimits growthLimits(const GridOptions& g, const TiledLogOddsGrid& first, int tables) {
  // An axis whose first extent is already as large does not grow (the grid's own tile count:
  // rounding must not make the limit smaller than the grid).
  const double tile_m = g.resolution_m * g.tile_cells;
  const double max_tiles = std::min(std::ceil(g.max_size_m / tile_m), 1e9);
  GridGrowthLimits limits;
  limits.tiles_x = std::max(static_cast<int>(max_tiles), first.tilesX());
  limits.tiles_y = std::max(static_cast<int>(max_tiles), first.tilesY());
  limits.grows =
      g.max_size_m > 0.0 && (limits.tiles_x > first.tilesX() || limits.tiles_y > first.tilesY());
  limits.tiles =
      static_cast<long>(kMaxTileTablesBytes / std::max(1, tables) / sizeof(std::shared_ptr<void>));
  return limits;
}

bool growToHold(double reach, const Pose2& pose, const GridGrowthLimits& limits,
                TiledLogOddsGrid* grid) {
  const Eigen::Vector2d at = pose.head<2>();
  if (!at.allFinite()) return true;  // nothing of it can be placed on any grid
  const Eigen::Vector2d lo = at.array() - reach, hi = at.array() + reach;
  if (grid->contains(lo, hi)) return true;
  return limits.grows && grid->grow(lo, hi, limits.tiles_x, limits.tiles_y, limits.tiles);
}

void GridParticleFilter::growGrids(const std::vector<LocalMapCell>& local) {
  if (!limits_.grows) return;
  const double reach = localMapReach(local, options_.grid.resolution_m);
  bool refused = false;
  for (Particle& p : particles_) refused |= !growToHold(reach, p.pose, limits_, &p.grid);
  if (refused) ++stats_.grid_growth_refused;
}

void GridParticleFilter::reset(const Pose2& initial_pose) {
  // Centred on the start; every particle starts with the same (empty, tile-less) grid.
  const TiledLogOddsGrid empty = firstGrid(options_.grid, initial_pose);
  // Growth limits: the particles' tables and, while resampling, their copies.
  limits_ = growthLimits(options_.grid, empty, 2 * options_.particles + 1);
  particles_.assign(options_.particles, Particle{initial_pose, empty});
  weights_.assign(options_.particles, 1.0 / options_.particles);
  resampled_best_ = -1;
  spread_pending_ = gathering_ = false;
  stats_ = FilterStats();
  local_stats_ = LocalMapStats();
}

Pose2 GridParticleFilter::randomFreePose() {
  const TiledLogOddsGrid& map = loaded_grid_;
  const int cell = free_cells_[std::min(
      free_cells_.size() - 1, static_cast<size_t>(sampleUniform(rng_) * free_cells_.size()))];
  const double r = map.resolution();
  return Pose2(map.originX() + (cell % map.width() + sampleUniform(rng_)) * r,
               map.originY() + (cell / map.width() + sampleUniform(rng_)) * r,
               wrapAngle(M_PI * (2.0 * sampleUniform(rng_) - 1.0)));
}

const std::vector<int>& GridParticleFilter::freeCells() const {
  if (!free_cells_listed_ && loaded_map_) {
    // Only a run that localizes globally pays for the list (4 bytes per free cell).
    for (int y = 0; y < loaded_grid_.height(); ++y) {
      for (int x = 0; x < loaded_grid_.width(); ++x) {
        if (loaded_grid_.logOdds(x, y) < 0.0f) free_cells_.push_back(y * loaded_grid_.width() + x);
      }
    }
    free_cells_listed_ = true;
  }
  return free_cells_;
}

bool GridParticleFilter::canSpreadOverMap(std::string* why) const {
  std::string problem;
  if (!loaded_map_) {
    problem = "no grid map is loaded";
  } else if (freeCells().empty()) {
    problem = "the map has no free cell (occupancy below 50 %) at the filter's resolution";
  }
  if (why) *why = problem;
  return problem.empty();
}

bool GridParticleFilter::spreadOverMap() {
  if (!canSpreadOverMap(nullptr)) return false;
  restoreFullCount();
  for (Particle& p : particles_) p = Particle{randomFreePose(), loaded_grid_};
  weights_.assign(particles_.size(), 1.0 / particles_.size());
  resampled_best_ = -1;
  spread_pending_ = options_.grid.spread_candidates > 1;
  gathering_ = true;
  return true;
}

double GridParticleFilter::matchScore(const std::vector<LocalMapCell>& local, const Pose2& pose,
                                      const TiledLogOddsGrid& own_grid) const {
  return fieldInUse() ? fieldLogLikelihood(local, pose, loaded_grid_, field_)
                      : matchLocalMap(local, pose, own_grid, options_.grid);
}

double GridParticleFilter::positionSpread() const {
  const PoseEstimate m =
      poseMomentsOf(weights_, [&](size_t i) -> const Pose2& { return particles_[i].pose; });
  return std::sqrt(m.covariance(0, 0) + m.covariance(1, 1));
}

bool GridParticleFilter::drawFromCandidates(const std::vector<LocalMapCell>& local) {
  // The first scan after a spread, weighed at spread_candidates times as many uniform poses as
  // there are particles; the particles are drawn from them by that weight. The same posterior
  // as weighing the spread itself, with more of it near the places the scan fits.
  const size_t count = particles_.size() * static_cast<size_t>(options_.grid.spread_candidates);
  std::vector<Pose2> poses(count);
  std::vector<double> log_weights(count), weights;
  for (size_t j = 0; j < count; ++j) {
    poses[j] = randomFreePose();
    log_weights[j] = matchScore(local, poses[j], loaded_grid_) / matchF();
  }
  const bool finite = normalizeLogWeights(log_weights, &weights);  // else all equal
  const std::vector<int> drawn =
      resampleLowVariance(weights, static_cast<int>(particles_.size()), rng_);
  for (size_t i = 0; i < particles_.size(); ++i) particles_[i].pose = poses[drawn[i]];
  weights_.assign(particles_.size(), 1.0 / particles_.size());
  resampled_best_ = -1;
  return finite;
}

void GridParticleFilter::predict(const MotionInput& motion) {
  for (Particle& p : particles_) p.pose = motion_->sample(p.pose, motion, rng_);
  ++stats_.predictions;
}

UpdateStats GridParticleFilter::update(const FeatureSet& features) {
  UpdateStats result;
  LocalMapStats local_stats;
  const std::vector<LocalMapCell> local = buildLocalMap(features, options_.grid, &local_stats);
  result.features_in = local_stats.readings;
  result.features_rejected = local_stats.rejected;
  local_stats_.readings += local_stats.readings;
  local_stats_.echoes += local_stats.echoes;
  local_stats_.no_echo += local_stats.no_echo;
  local_stats_.rejected += local_stats.rejected;
  local_stats_.beyond_reach += local_stats.beyond_reach;
  stats_.readings_beyond_reach += local_stats.beyond_reach;
  ++stats_.updates;
  if (mapping_) growGrids(local);
  if (gathering_) {
    // The spread has gathered once the particles' position spread is below spread_gathered_m
    // (checked before each scan is weighed): from then on the weights use match_f again.
    gathering_ = !(positionSpread() < options_.grid.spread_gathered_m);
  }
  // The candidates wait for a scan with a hit: one with free cells only scores every pose alike
  // under the likelihood field (an infrared or sonar reading at its maximum range).
  const bool from_candidates =
      spread_pending_ && !mapping_ &&
      std::any_of(local.begin(), local.end(), [](const LocalMapCell& c) { return c.occupied; });
  if (from_candidates) {
    if (!drawFromCandidates(local)) {
      ++result.weight_resets;
      ++stats_.weight_resets;
    }
    spread_pending_ = false;
    result.resampled = true;
    ++stats_.resamples;
    result.neff = effectiveSampleSize(weights_);
    stats_.last_neff = result.neff;
    return result;
  }
  if (!local.empty()) {
    // Eq. 14 in log space: log w += match / f, then normalise (or the likelihood field).
    std::vector<double> log_weights(particles_.size());
    for (size_t i = 0; i < particles_.size(); ++i) {
      const double match = matchScore(local, particles_[i].pose, particles_[i].grid);
      log_weights[i] = std::log(std::max(weights_[i], 1e-300)) + match / matchF();
    }
    if (!normalizeLogWeights(log_weights, &weights_)) {
      ++result.weight_resets;
      ++stats_.weight_resets;
    }
    if (mapping_) {
      for (Particle& p : particles_) integrateLocalMap(local, p.pose, options_.grid, &p.grid);
    }
  }
  {
    // Out of the grid (fixed, at its largest, or not mapping) nothing is mapped nor matched,
    // and the filter falls back to dead reckoning without a word unless this is counted.
    const Particle& best = particles_[bestIndex()];
    int cx, cy;
    if (!best.grid.cellOf(best.pose.head<2>(), &cx, &cy)) ++stats_.outside_grid;
  }
  result.neff = effectiveSampleSize(weights_);
  stats_.last_neff = result.neff;
  if (result.neff < options_.resample_threshold * particles_.size()) {
    const std::vector<int> drawn = drawResampled();
    std::vector<Particle> next;
    next.reserve(drawn.size());
    for (int i : drawn) next.push_back(particles_[i]);  // grids share their tiles
    resampled_best_ = keptMostProbable(drawn, weights_);
    particles_ = std::move(next);
    weights_.assign(particles_.size(), 1.0 / particles_.size());
    result.resampled = true;
    ++stats_.resamples;
  } else {
    resampled_best_ = -1;
  }
  return result;
}

void GridParticleFilter::restoreFullCount() {
  // KLD-sampling may have kept fewer; the caller sets every particle (or its grid) next.
  particles_.resize(options_.particles, particles_.front());
}

std::vector<int> GridParticleFilter::drawResampled() {
  if (mapping_ || options_.grid.kld_min_particles == 0) {
    return resampleLowVariance(weights_, static_cast<int>(particles_.size()), rng_);
  }
  // Localizing with KLD-sampling: as many as the cloud needs, up to `particles` (the count
  // grows again when the cloud spreads out).
  KldSampling kld;
  kld.min_count = options_.grid.kld_min_particles;
  kld.max_count = options_.particles;
  kld.error = options_.grid.kld_error;
  kld.z = options_.grid.kld_z;
  kld.bin_xy_m = options_.grid.kld_bin_xy_m;
  kld.bin_theta_rad = options_.grid.kld_bin_theta_rad;
  std::vector<Pose2> poses;
  poses.reserve(particles_.size());
  for (const Particle& p : particles_) poses.push_back(p.pose);
  return resampleKld(weights_, poses, kld, rng_);
}

int GridParticleFilter::bestIndex() const {
  return std::max(0, mostProbable(weights_, resampled_best_));
}

PoseEstimate GridParticleFilter::estimate() const {
  PoseEstimate e;
  if (mapping_) {
    e = poseMomentsOf(weights_, [&](size_t i) -> const Pose2& { return particles_[i].pose; });
  } else {
    // Localizing, the cloud may hold several places (a spread over the map, look-alike rooms):
    // report the mean of a cluster holding most of the weight (amcl reports its heaviest
    // cluster's), not the point between the places, often in a wall. Cells of ten filter cells and
    // 10 deg; one cluster, or none holding most of the weight, gives the plain moments.
    std::vector<Pose2> poses;
    poses.reserve(particles_.size());
    for (const Particle& p : particles_) poses.push_back(p.pose);
    e = heaviestClusterMoments(poses, weights_, 10.0 * options_.grid.resolution_m, kClusterCellRad);
  }
  e.covariance.diagonal().array() += 1e-9;
  return e;
}

std::vector<WeightedPose> GridParticleFilter::particles() const {
  std::vector<WeightedPose> out;
  out.reserve(particles_.size());
  for (size_t i = 0; i < particles_.size(); ++i) out.push_back({particles_[i].pose, weights_[i]});
  return out;
}

bool GridParticleFilter::resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) {
  if (!pose.allFinite() || !poseCovarianceUsable(covariance)) return false;
  restoreFullCount();
  for (Particle& p : particles_) {
    p.pose = sampleMultivariate<3>(rng_, pose, covariance);
    p.pose.z() = wrapAngle(p.pose.z());
  }
  weights_.assign(particles_.size(), 1.0 / particles_.size());
  resampled_best_ = -1;
  spread_pending_ = gathering_ = false;
  return true;
}

bool GridParticleFilter::loadGridMap(const GridMapData& map) {
  const MapExtent extent = mapExtent(map, options_.grid);  // checked before anything is built
  requireTablesFit(options_.grid, extent.width, extent.height, options_.particles, "the map");
  // The session gives the same map again after every reset, moved by where the filter's
  // coordinates start (AnchoredFilter): the grid built last time is moved, not rebuilt.
  const bool same = loaded_map_ && loaded_map_->resolution_m == map.resolution_m &&
                    loaded_map_->width == map.width && loaded_map_->height == map.height &&
                    loaded_map_->cells == map.cells;
  if (!same) {
    // Built first, then kept: a map that cannot be built leaves the filter as it was.
    TiledLogOddsGrid grid = gridFromMap(map, options_.grid);
    LikelihoodField field;
    if (field_model_) field = likelihoodField(grid, options_.grid);
    loaded_grid_ = std::move(grid);
    field_ = std::move(field);
    free_cells_.clear();  // listed when first needed (spreadOverMap)
    free_cells_listed_ = false;
    GridMapData kept = map;
    loaded_map_ = std::make_shared<const GridMapData>(std::move(kept));
  }
  loaded_grid_.moveTo(map.origin_x_m, map.origin_y_m);
  limits_ = growthLimits(options_.grid, loaded_grid_, 2 * options_.particles + 1);
  restoreFullCount();
  for (Particle& p : particles_) p.grid = loaded_grid_;  // every particle shares its tiles
  weights_.assign(particles_.size(), 1.0 / particles_.size());
  resampled_best_ = -1;
  return true;
}

bool GridParticleFilter::setMapping(bool enabled) {
  mapping_ = enabled;
  if (mapping_ && particles_.size() < static_cast<size_t>(options_.particles)) {
    // KLD-sampling kept fewer while localizing: mapping gets them all again, drawn by weight.
    const std::vector<int> drawn = resampleLowVariance(weights_, options_.particles, rng_);
    std::vector<Particle> all;
    all.reserve(drawn.size());
    for (int i : drawn) all.push_back(particles_[i]);
    resampled_best_ = keptMostProbable(drawn, weights_);
    particles_ = std::move(all);
    weights_.assign(particles_.size(), 1.0 / particles_.size());
  }
  if (mapping_) spread_pending_ = gathering_ = false;  // a spread is for localization only
  return true;
}

bool GridParticleFilter::occupancyGrid(GridMapData& out) const {
  out = bestGrid().toGridMap();
  return true;
}

const TiledLogOddsGrid& GridParticleFilter::bestGrid() const {
  return particles_[bestIndex()].grid;
}

long GridParticleFilter::distinctTiles() const {
  std::vector<const TiledLogOddsGrid*> grids;
  for (const Particle& p : particles_) grids.push_back(&p.grid);
  return TiledLogOddsGrid::distinctTiles(grids);
}

size_t GridParticleFilter::gridBytes() const {
  return static_cast<size_t>(distinctTiles()) * particles_.front().grid.tileBytes();
}

}  // namespace core
}  // namespace rbpf_slam

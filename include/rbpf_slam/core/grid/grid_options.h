#pragma once
// Options of the occupancy-grid particle filter (variant grid_pf, Yatim and Buniyamin 2015).

#include <string>

namespace rbpf_slam {
namespace core {

/// Grid, inverse sensor models (eq. 13) and map matching (eq. 14) of variant grid_pf.
struct GridOptions {
  // The map: an extent centred on the first pose, stored in square tiles that particles share
  // copy-on-write. While mapping, each particle's grid grows by whole tiles to hold what it
  // observes, up to max_size_m along each axis (0: the grid stays size_x_m x size_y_m).
  double resolution_m = 0.05;
  double size_x_m = 100.0;     // first extent along x, centred on the start; also the farthest
  double size_y_m = 100.0;     // a reading is traced (the diagonal)
  double max_size_m = 1000.0;  // largest extent along x or y when growing (0, or below
                               // size_x_m / size_y_m: that axis never grows)
  int tile_cells = 64;      // tile side in cells (a tile is the unit of sharing)
  // Log-odds added per observation (eq. 13 with l(m_i) = 0 as the prior) and their clamp.
  double log_odds_occupied = 0.85;
  double log_odds_free = -0.4;
  double log_odds_clamp = 6.0;
  // Cone sensors (sonar, infrared): an arc of this thickness at the range is occupied, the
  // cone up to it free; a reading within max_range_margin_m of max_range is "no echo" and only
  // frees the cone up to min(max_range, no_echo_free_range_m). A reading beyond the grid's
  // diagonal is refused.
  double cone_arc_thickness_m = 0.0;  // 0: one cell
  double cone_max_range_m = 0.0;      // an echo beyond this counts as none (0: the sensor's
                                      // max)
  double max_range_margin_m = 0.005;
  double no_echo_free_range_m = 0.0;  // 0: up to max_range
  double cone_fov_rad = 0.0;          // 0: each reading's field_of_view
  // Laser beams: cells along the beam free, the end cell occupied; a beam with no return
  // frees up to laser_no_return_free_m (0: nothing).
  double laser_max_range_m = 20.0;    // shorten longer beams (their end is not a hit)
  double laser_no_return_free_m = 0.0;
  int laser_beam_step = 1;            // use every n-th beam
  // Map matching weight (eq. 14): w *= exp(match / f), match = sum over local-map cells of
  // weight * (+1 occupied, -1 free) * (2 p_global - 1).
  double match_f = 100.0;
  double match_occupied_weight = 1.0;
  double match_free_weight = 1.0;
  // While localizing on a loaded map (mapping off), "likelihood_field" (after amcl's model, not
  // the paper's) weighs instead by w *= exp(match / f) with match = sum over the occupied local
  // cells of log(z_hit exp(-d^2 / (2 field_sigma_m^2)) + 1 - z_hit), d the distance to the loaded
  // map's nearest occupied cell (at most field_max_dist_m; off the map the most); free cells
  // unused. Unlike amcl the miss term is the constant 1 - z_hit and the sum is divided by f, so
  // amcl's parameter values do not carry over. "map_matching" (eq. 14) always while mapping or
  // without a loaded map. The field holds 4 bytes per cell of the loaded map.
  std::string match_model = "map_matching";
  double field_sigma_m = 0.2;
  double field_max_dist_m = 2.0;
  double field_z_hit = 0.95;
  // Global localization (spreadOverMap): the first scan with a hit (an occupied local cell)
  // after the spread, while mapping is off, is weighed at this many uniform poses per particle
  // and the particles drawn from them (1: the spread as is); particles x this at most 1e7.
  int spread_candidates = 1;
  // From a global spread until the particles gather (their position spread, the root of the
  // covariance's trace, below spread_gathered_m before a scan is weighed), f is spread_match_f
  // (0: match_f): softer weights while many places fit, the usual precision once found. The
  // threshold is absolute: a place smaller than it (an e-puck arena) counts as gathered at once;
  // 0 never gathers. Mapping turned on ends it.
  double spread_match_f = 0.0;
  double spread_gathered_m = 1.0;
  // KLD-sampling (Fox 2003, with amcl's min_particles / kld_err / kld_z; off when
  // kld_min_particles is 0): while localizing on a loaded map (mapping off), each resampling
  // keeps only as many particles as the cloud needs: enough for the KL divergence to the
  // posterior to stay under kld_error with the probability whose standard normal upper quantile
  // is kld_z, counted over bins of kld_bin_xy_m x kld_bin_xy_m x kld_bin_theta_rad; at least
  // kld_min_particles, at most `particles`. A spread over the map, a start pose, a map loaded, a
  // reset or mapping restores `particles`. The defaults are amcl's, which puts its kld_z 0.99
  // into the formula as the quantile itself (a 99 % bound would be 2.33).
  int kld_min_particles = 0;
  double kld_error = 0.01;
  double kld_z = 0.99;
  double kld_bin_xy_m = 0.5;
  double kld_bin_theta_rad = 0.1745;
};

/// What to change when the grid cannot hold the robot or its readings (warnings, summaries).
constexpr const char* kGridLimitAdvice =
    "while mapping, the grid grows up to grid.max_size_m along each axis (0: fixed at "
    "grid.size_x_m x grid.size_y_m, centred on the start) and while its particles' tile tables "
    "fit in memory: raise grid.max_size_m, coarsen grid.resolution_m or enlarge "
    "grid.tile_cells (with mapping off, nothing grows)";

/// What to check when the robot is outside a map it was given (map_file, ~load_map).
constexpr const char* kGridOffTheMapAdvice =
    "on a loaded map the robot is off it: most likely its start was not given on the map "
    "(rviz's 2D Pose Estimate / initialpose, offline_slam --initial-pose; without one the first "
    "odometry pose is taken as the pose in the map), or the map does not cover where it went";

/// The same when a start pose was given.
constexpr const char* kGridOffTheMapGivenStartAdvice =
    "on a loaded map the robot is off it: the start given (initialpose, offline_slam "
    "--initial-pose) may be wrong, off the map or too uncertain (its spread reaching beyond the "
    "map: give sigmas that fit the place, e.g. 0.02 m for an e-puck), or the map does not cover "
    "where it went";

/// Said of readings whose echo lies beyond grid.size_x_m x grid.size_y_m's diagonal.
constexpr const char* kGridReachAdvice =
    "with an echo beyond the diagonal of the first extent (grid.size_x_m x grid.size_y_m), the "
    "farthest one reading is traced, were not mapped (cones: left out; laser beams: free up to "
    "it): enlarge grid.size_x_m / grid.size_y_m to the sensor's range at least";

/// Throws std::invalid_argument naming the first out-of-range field ("grid.NAME").
void validate(const GridOptions& options);
/// Throws std::invalid_argument naming both when grid.kld_min_particles exceeds particles.
void requireKldCountFits(const GridOptions& options, int particles);

}  // namespace core
}  // namespace rbpf_slam

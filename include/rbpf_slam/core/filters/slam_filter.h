#pragma once
// The one interface every SLAM variant implements (FastSLAM 2.0, robust, H-infinity,
// multi-filter SMC, EKF, grid, distributed); the node and the offline runner use only this.

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/motion/motion_model.h"

namespace rbpf_slam {
namespace core {

struct GridMapData;  // grid/grid_map_data.h

enum class LandmarkType { kPoint, kLine };

/// A landmark of the best particle's map, in the map frame.
struct LandmarkEstimate {
  int id = -1;  // stable over the run
  LandmarkType type = LandmarkType::kPoint;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();  // point: (x, y); line: (rho, theta)
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // line extent seen so far (map frame)
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  int observations = 0;
};

struct PoseEstimate {
  Pose2 mean = Pose2::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

struct WeightedPose {
  Pose2 pose = Pose2::Zero();
  double weight = 0.0;  // normalised
};

/// What one update did (returned, never logged by the core).
struct UpdateStats {
  double neff = 0.0;             // effective sample size after weighting, before resampling
  bool resampled = false;
  int features_in = 0;           // features offered
  int features_rejected = 0;     // non-finite or degenerate features skipped
  int associated = 0;            // best particle: features matched to existing landmarks
  int new_landmarks = 0;         // best particle: landmarks created
  int weight_resets = 0;         // all-zero or NaN weights reset to uniform
  int fallbacks = 0;             // variant-specific numeric fallbacks (e.g. H-inf -> EKF)
  int relocalized = 0;           // particles whose proposal started from a searched correction
  // log p(z_t | z_1:t-1) as the filter estimates it (FastSLAM 2.0 and H-infinity FastSLAM: the
  // log of the weights' mass after this update over their mass before; 0 without observations;
  // -inf when every weight vanished; particles with a NaN weight are left out of both masses).
  // robust_fastslam2 reports it on its FastSLAM 2.0 steps only; the other variants leave it 0.
  double log_evidence = 0.0;
};

/// Running totals since construction or reset.
struct FilterStats {
  long updates = 0;
  long predictions = 0;
  long resamples = 0;
  long weight_resets = 0;
  long fallbacks = 0;
  long relocalizations = 0;  // particle proposals started from a searched pose correction
  long heading_measurements = 0;  // particle proposals conditioned on the heading prior
  long robust_steps = 0;          // robust_fastslam2: steps sampled from several ancestor sets
  double last_neff = 0.0;
  int landmarks = 0;  // in the best particle
  double attenuation = 0.0;  // hinf_fastslam: the theta in use (hinf.mode relative / adaptive)
  long leader_changes = 0;   // ensemble: updates after which another member was reported
  long outside_grid = 0;     // grid_pf: updates whose best pose lay outside the grid (fixed,
                             // or at grid.max_size_m): nothing is mapped or matched there
  long readings_beyond_reach = 0;  // grid_pf: readings with an echo beyond the first extent's
                                   // diagonal (grid.size_x_m x grid.size_y_m): not mapped
  long grid_growth_refused = 0;  // grid_pf: updates where a particle's grid could not grow to
                                 // hold the readings (grid.max_size_m or the memory limit)
  long missed_answers = 0;   // dpf_master_node: local filters' answers not received within
                             // dpf.step_timeout_s (the step was fused without them)
  // Per-part state for /diagnostics, as (name, text) pairs (dpf: one per local filter).
  std::vector<std::pair<std::string, std::string>> details;
};

/// A SLAM filter. Not thread-safe; time is always an argument (the core reads no clock).
class SlamFilter {
 public:
  virtual ~SlamFilter() = default;
  virtual std::string variant() const = 0;
  /// Forgets everything and restarts at pose (the map frame's origin by default).
  virtual void reset(const Pose2& initial_pose = Pose2::Zero()) = 0;
  /// Moves every hypothesis by the odometry increment.
  virtual void predict(const MotionInput& motion) = 0;
  /// Incorporates the observations taken at the current pose.
  virtual UpdateStats update(const FeatureSet& features) = 0;
  virtual PoseEstimate estimate() const = 0;
  /// Landmarks of the best hypothesis.
  virtual std::vector<LandmarkEstimate> landmarks() const = 0;
  virtual std::vector<WeightedPose> particles() const = 0;
  virtual FilterStats stats() const = 0;

  // Map reuse and localization (rviz's 2D Pose Estimate, ~load_map, localization mode).
  // Variants that cannot do one of these keep the default, which declines (returns false).

  /// Redraws every hypothesis' pose from N(pose, covariance), keeping its map.
  virtual bool resetPose(const Pose2& /*pose*/, const Eigen::Matrix3d& /*covariance*/) {
    return false;
  }
  /// Gives every hypothesis this map (map frame), replacing what it had.
  virtual bool loadMap(const std::vector<LandmarkEstimate>& /*landmarks*/) { return false; }
  /// Gives every hypothesis this occupancy grid (map frame) as its map, for variants that map
  /// cells (grid_pf); throws std::invalid_argument for a grid the variant cannot hold.
  virtual bool loadGridMap(const GridMapData& /*map*/) { return false; }
  /// Global localization (amcl's global_localization): spreads every hypothesis over the free
  /// space of the loaded map with any heading, for variants that localize on a grid map.
  virtual bool spreadOverMap() { return false; }
  /// Whether spreadOverMap() would spread now (a grid map with a free cell is loaded), without
  /// doing it; when not, why (if given) says why: the variant never spreads, no map is loaded,
  /// or the map has no free cell (left empty when it would).
  virtual bool canSpreadOverMap(std::string* why) const {
    if (why) *why = "variant " + variant() + " cannot spread its particles over a map";
    return false;
  }
  /// Whether the hypotheses spread by spreadOverMap() have yet to gather on one place: the
  /// filter does not know where on the map the robot is (its estimate is no place to start from).
  virtual bool stillSpread() const { return false; }
  /// The cell size of the grids it keeps, m (0: it keeps none).
  virtual double gridResolution() const { return 0.0; }
  /// Mapping off = localization only: landmarks are neither added nor changed.
  virtual bool setMapping(bool enabled) { return enabled; }

  /// The best hypothesis' occupancy grid, for variants that keep one (grid_pf); the default
  /// declines and callers rasterise landmarks() instead (rasterizeLandmarks).
  virtual bool occupancyGrid(GridMapData& /*out*/) const { return false; }
  /// For variants that estimate whole paths (FastSLAM): the best hypothesis' pose at every
  /// update() since the last reset, oldest first, which after a loop closure is the path
  /// consistent with its map, unlike the sequence of estimate()s. Default: empty (none).
  virtual std::vector<Pose2> bestPath() const { return {}; }
  /// At most max_poses (>= 1) poses of bestPath(), evenly spaced from the first to the latest
  /// (core::evenlySpacedPoses), and in *length (when given) bestPath()'s length. The default
  /// builds the whole path; the FastSLAM variants pick the poses without it.
  virtual std::vector<Pose2> bestPathSample(std::size_t max_poses, std::size_t* length) const;
  /// Ensembles of independent filters (ensemble.members > 1): how many there are, member k
  /// (0 <= k < members()), and the one whose estimate, map and path this filter reports. A
  /// single filter is an ensemble of one, itself.
  virtual int members() const { return 1; }
  virtual const SlamFilter& member(int /*k*/) const { return *this; }
  virtual int leader() const { return 0; }
  /// False for variants that map raw readings only (grid_pf): drivers then leave the
  /// `features` topic alone instead of feeding it frames that only move the robot.
  virtual bool usesLandmarkFeatures() const { return true; }
};

/// Builds the variant named by options.variant; throws std::invalid_argument if unknown or
/// if the options do not validate.
std::unique_ptr<SlamFilter> createFilter(const FilterOptions& options);

/// The variant names createFilter accepts.
std::vector<std::string> availableVariants();

}  // namespace core
}  // namespace rbpf_slam

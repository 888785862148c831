#pragma once
// Runs the SLAM pipeline over a bag file without a roscore: reads tf, scans, sonar and features
// straight from the bag, feeds the same SlamPipeline as rbpf_slam_node, writes the results.

#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/slam/slam_pipeline.h"
#include "rbpf_slam/io/slam_config.h"

namespace rbpf_slam {
namespace rosbridge {

struct OfflineOptions {
  std::string bag_path;
  std::string output_dir;
  std::string reference_path;  // optional TUM reference for the summary's ATE
  bool progress = true;        // a progress bar on stderr when it is a terminal
  bool verbose = false;        // one line per update on stderr
  std::string output_bag;      // optional: a bag of the results (tf, pose, markers) for rviz
  // Optional: where the robot starts in the map frame (e.g. on a prior map) and how uncertain
  // that is, as an initialpose before the first frame. The bag's own initialpose messages
  // (rviz's 2D Pose Estimate, recorded) are used either way, at their place in the bag.
  bool has_initial_pose = false;
  core::Pose2 initial_pose = core::Pose2::Zero();
  Eigen::Matrix3d initial_covariance = core::defaultStartCovariance();
  // Optional: the start is unknown; the particles start spread over map_file's free cells
  // (grid_pf on a map_server map, SlamSession::localizeGlobally).
  bool global_localization = false;
};

/// Counts and timings of one offline run.
struct OfflineSummary {
  double wall_s = 0.0;
  double cpu_s = 0.0;  // this process's CPU time over the same span (wall_s less other jobs' share)
  double bag_duration_s = 0.0;
  long frames = 0;
  long updates = 0;
  long skipped = 0;     // no motion since the last update (linear_update, angular_update)
  long buffered = 0;    // sonar readings that joined the echo window (used at a later update)
  long same_stamp = 0;  // at the stamp of the frame before (another input of that instant)
  long rejected = 0;    // older stamps, non-finite odometry
  std::string first_rejected;  // the first of them: topic, stamp, why
  long resets = 0;
  long discarded_poses = 0;  // poses of the runs before the last reset (not in the outputs)
  long gaps = 0;  // steps across a time gap or odometry jump (max_time_gap, max_odometry_jump)
  long dropped_no_tf = 0;
  long dropped_bad_message = 0;
  bool prior_map = false;          // the run started from a map (map_file)
  bool global_localization = false;  // --global-localization or the config's
                                     // global_localization (a recorded initialpose after it
                                     // replaces it)
  long initial_poses = 0;  // start poses taken: --initial-pose and the bag's initialpose messages
  long ignored_initial_poses = 0;  // ... and those that could not (frame, non-finite, variant)
  std::string first_ignored_initial_pose;  // why the first of them was
  long skipped_transforms = 0;  // repeated or malformed tf in the bag
  long malformed_transforms = 0;  // of them, those tf2 refuses (transformProblem)
  std::string first_malformed_transform;  // the first of them, with why
  long dropped_features = 0;    // non-finite features inside otherwise good messages
  long tilted_frames = 0;       // sensor frames tilted over kMaxLevelTiltRad (used as if level)
  long features_rejected = 0;   // features the filter skipped (degenerate, or a kind it ignores)
  std::string first_tf_error;   // the first failed lookup behind dropped_no_tf
  std::string first_bad_message;  // the first reason behind dropped_bad_message
  long tf_segments = 0;         // tf runs: 1 + the times the odometry stamps went back
  long dropped_cloud_points = 0;  // sonar_cloud points on no transducer's axis
  int landmarks = 0;
  int particles = 0;  // as configured (grid_pf with KLD-sampling: the most)
  // The filter's particles() after each update, mean over the updates and the last: grid_pf's
  // vary with KLD-sampling; dpf gives every local filter's, ekf_slam 1.
  double particles_mean = 0.0;
  int particles_final = 0;
  long fallbacks = 0;  // H-infinity steps that fell back to the EKF (since the last reset)
  double hinf_theta = 0.0;   // the H-infinity attenuation at the end (adaptive: learnt)
  long relocalizations = 0;  // particle proposals started from a searched pose correction
  long heading_measurements = 0;  // particle proposals conditioned on the heading prior
  long robust_steps = 0;          // robust_fastslam2: steps sampled from several ancestor sets
  int ensemble_members = 1;       // ensemble.members
  int ensemble_leader = 0;        // the member reported at the end (by ensemble.rank_by)
  long ensemble_leader_changes = 0;  // updates after which another member was reported
  long updates_outside_grid = 0;     // grid_pf: updates with the best pose outside the grid
  long grid_growth_refused = 0;      // grid_pf: updates the grid could not grow for
  long readings_beyond_reach = 0;    // grid_pf: echoes beyond the first extent's diagonal
  long dpf_missed_answers = 0;       // dpf_master_node: local answers not received in time
  double update_ms_mean = 0.0;
  double update_ms_p99 = 0.0;
  double update_ms_max = 0.0;
  bool has_reference = false;  // at least two poses matched the reference
  long ate_matched_poses = 0;  // poses of trajectory.tum matched to a reference pose
  double ate_rmse_m = 0.0;
  double final_position_error_m = 0.0;
  double ate_online_rmse_m = 0.0;  // of trajectory_online.tum (the per-update estimates)
  // With a prior map: the ATE against the reference without alignment (the map's frame is the
  // reference's when the map was made from it; the aligned ATE hides a wrong start).
  bool has_map_frame_ate = false;
  double ate_map_frame_rmse_m = 0.0;
  std::string trajectory_source;   // [smoothed_]best_particle_path | [smoothed_]online_estimate
  bool smoothed = false;           // smoothing.enabled and the smoother succeeded
  std::string smoothing;           // the smoother's account (or why it did not smooth)
  double smoothing_s = 0.0;        // wall time of the smoothing (not in wall_s)
};

/// What a finished run should tell its user, one line each: the first failed tf lookup,
/// malformed message, malformed transform and rejected frame behind those counts, the features
/// dropped or skipped, the map restarts and what they discarded, and why the run
/// did not do its work (no frame used; a reference given but not evaluated), which also sets
/// *failed. Empty for a clean run.
std::vector<std::string> describeOutcome(const OfflineSummary& summary,
                                         const OfflineOptions& options, const std::string& variant,
                                         bool* failed);

class OfflineRunner {
 public:
  OfflineRunner(const io::SlamConfig& config, const OfflineOptions& options);
  /// With a filter built elsewhere (dpf_master_node: the local filters in other processes).
  OfflineRunner(const io::SlamConfig& config, const OfflineOptions& options,
                std::unique_ptr<core::SlamFilter> filter);
  /// Processes the whole bag and writes trajectory.tum, trajectory_online.tum, landmarks.yaml,
  /// summary.json and map.png/.pgm/.yaml (with smoothing also trajectory_filter.tum and
  /// landmarks_filter.yaml) into the output directory. Throws std::runtime_error with a clear
  /// message; before the bag is read when one of those paths (or the output bag's) is a
  /// directory, a pipe or a device.
  OfflineSummary run();
  const core::SlamPipeline& pipeline() const { return pipeline_; }

 private:
  OfflineSummary writeOutputs(const OfflineSummary& summary) const;
  /// --global-localization (the config's global_localization was asked by applyMapConfig):
  /// asks the session before anything is read; throws std::runtime_error with the reason when
  /// it cannot (no grid map, mapping on, ...), or when either comes with --initial-pose.
  void startGlobally();
  bool startsGlobally() const {
    return options_.global_localization || pipeline_.session().configuredGlobally();
  }
  const io::SlamConfig config_;
  const OfflineOptions options_;
  core::SlamPipeline pipeline_;
  std::string loaded_map_;  // what map_file gave (applyMapConfig), "" without one
};

}  // namespace rosbridge
}  // namespace rbpf_slam

#pragma once
// Options shared by the filter variants; each variant reads the fields it needs.

#include <string>

#include "rbpf_slam/core/filters/dpf_options.h"
#include "rbpf_slam/core/filters/estimator_rule.h"
#include "rbpf_slam/core/filters/heading_prior.h"
#include "rbpf_slam/core/filters/line_slam_options.h"
#include "rbpf_slam/core/filters/relocalization.h"
#include "rbpf_slam/core/grid/grid_options.h"
#include "rbpf_slam/core/motion/motion_model.h"
#include "rbpf_slam/core/tracking/landmark_tracker_options.h"

namespace rbpf_slam {
namespace core {

/// Per-particle data association of features to landmarks.
struct AssociationOptions {
  double gate_chi2 = 9.21;          // Mahalanobis^2 gate (99% for 2 dof)
  double new_landmark_chi2 = 13.8;  // beyond every gate by this much: a new landmark
  double line_overlap_margin_m = 1.0;  // a line matches only if the segments come this close
  // Each particle draws its match among the landmarks inside the gate with probability
  // proportional to their likelihoods, and is weighted by their sum (data association sampling,
  // Nieto et al. 2003), instead of taking the most likely one (false: FastSLAM 2.0's maximum
  // likelihood).
  bool sample = false;
  // The weight of a sampled match: "sum" of the gated landmarks' likelihoods (the draw's
  // importance weight) or "max", the most likely one's as without sampling (no gain for copies).
  std::string sample_weight = "sum";
  // The weight of a feature between the gate and the new-landmark threshold (neither matched
  // nor mapped): "none" leaves it out (a factor of 1); "soft" counts the sum of its nearest
  // landmark's match likelihood and the new-landmark likelihood (close to, not equal to, a
  // match's weight at the gate and a new landmark's at the threshold). fastslam2 and
  // hinf_fastslam (with pointwise weights the marginal likelihood at the proposal, not at the
  // drawn pose; untested there); robust_fastslam2's robust steps count the new-landmark
  // likelihood.
  std::string ambiguous_weight = "none";
  // One-to-one within a frame: a point landmark matched by one feature of the frame is not a
  // candidate for the frame's other point features without a known id, which take their
  // landmarks in order of their best match's Mahalanobis distance at the prior pose. Applies to
  // fastslam2 and hinf_fastslam, and to robust_fastslam2's plain steps (not its robust steps).
  bool exclusive = false;
};

/// Measurement noise assumed by the filter when a feature carries no covariance of its own.
struct MeasurementOptions {
  bool use_feature_covariance = true;
  double sigma_range_m = 0.2;
  double sigma_bearing_rad = 0.035;
  double sigma_rho_m = 0.05;
  double sigma_theta_rad = 0.03;
  double covariance_inflation = 1.0;  // multiplies every feature covariance
  // Point landmark updates of the FastSLAM variants (fastslam2, hinf_fastslam, and
  // robust_fastslam2's updates and replays; not ekf_slam or the dpf): 1 is the EKF (or
  // H-infinity) step linearised at the landmark's prior mean; n > 1 relinearises n - 1 times at
  // the updated mean (iterated EKF: Gauss-Newton on prior plus sighting with the EKF rule), which
  // is less biased when the range is weak against the bearing. No convergence test or damping.
  int landmark_iterations = 1;
};

/// Robust RBPF-SLAM (Lee, Kim and Chung 2010): sampling from K ancestor sets on a new landmark.
struct RobustOptions {
  int ancestor_sets = 5;           // K: sets sampled from on a new landmark, the latest included
  int ancestor_spacing_steps = 5;  // minimum steps between two stored sets (and robust steps)
  int window_steps = 25;           // oldest usable set, in steps; bounds the stored history
  bool intermediate_path = true;   // estimate the skipped path and replay its observations
  int path_iterations = 10;        // iterated EKF steps of the intermediate path estimate
  // A robust step needs at least this many observations associated with landmarks older than
  // the oldest ancestor set (counted for the most probable particle of each candidate set,
  // moved over the skipped steps, and the largest count taken); with fewer, the event
  // takes a plain FastSLAM 2.0 step (sparse sensors). 0 = never fall back.
  int min_old_observations = 3;
};

/// Landmark existence management (landmark_existence.h), shared by the FastSLAM variants:
/// a tentative landmark that is not confirmed soon is dropped, and a point landmark that the
/// sensor should see but does not is counted down and dropped at zero.
struct ExistenceOptions {
  int min_observations = 1;     // a landmark seen fewer times than this ...
  int tentative_updates = 20;   // ... this many updates after its creation is removed
  double visible_range_m = 0.0;      // negative evidence for points within [min, max] range;
  double visible_min_range_m = 0.0;  // visible_range_m = 0 switches it off
  double visible_fov_rad = M_PI;     // full width of the field of view, centred ahead
  int max_count = 5;  // existence counter: +sighting_count per sighting up to this, -1 per
                      // unexplained miss; a new landmark starts at 1 (its first sighting)
  // What each later sighting adds to the counter (capped at max_count). A miss always takes one
  // away, so with 1 a landmark the sensor detects in fewer than half of the frames that have it
  // in view (a barcode camera: about 0.3-0.5 per frame at 1-6 m on MRCLAM) is eventually
  // dropped; k > 1 weighs a sighting as k misses (a landmark then gains on average when it is
  // detected in more than 1 / (k + 1) of those frames).
  int sighting_count = 1;
  // Duplicates: a point landmark seen in this update and another point landmark, both seen at
  // least merge_min_observations times, whose means differ by less than merge_chi2 (chi-square,
  // in the Mahalanobis metric of their summed covariances) and by less than
  // merge_max_distance_m are one landmark mapped twice (e.g. once while the pose was off): the
  // less observed one is removed (not fused: its estimate is dropped), the other keeps the
  // larger existence counter. A copy next to its original is in view with it, so negative
  // evidence cannot remove it, and with sampled association both keep being matched. Landmarks
  // of features with a known id are never removed as duplicates. Checked after each update that
  // runs the existence bookkeeping (not on robust_fastslam2's ancestor steps). 0: off; the
  // other two defaults were chosen on MRCLAM dataset 6 (barcodes 0.18-0.25 m apart).
  double merge_chi2 = 0.0;
  int merge_min_observations = 10;
  double merge_max_distance_m = 0.5;
};

/// Independent filters run side by side on the same input (ensemble_filter.h), each with its
/// own seed; one of them is reported. 1 = one filter.
struct EnsembleOptions {
  int members = 1;
  // Which member is reported: "evidence", the largest estimated marginal likelihood (summed
  // UpdateStats::log_evidence; with association.sample_weight sum a map holding copies of a
  // landmark is not penalised for them); "new_landmarks", the fewest landmarks created so far,
  // summed over the updates' UpdateStats::new_landmarks (the most probable particle of each
  // update; sightings its map could not explain; ties: the larger evidence); "consensus",
  // every consensus_period updates the member whose best path is closest to the other
  // members' (the median RMS distance after rigid alignment, as the smoother's
  // member_consensus_margin; members that found the same path agree, each one that lost its
  // way is lost differently; needs three members, else evidence decides).
  std::string rank_by = "evidence";
  // consensus: updates between two choices (the paths grow with the run: each choice aligns
  // every pair of members' paths once) ...
  int consensus_period = 10;
  // ... and how much shorter (m) another member's median distance must be before it is
  // reported instead of the leader (members that found the same path differ by rounding, and
  // each change moves the node's pose, map -> odom, ~trajectory and markers).
  double consensus_margin_m = 0.05;
  // ... and how many poses of each path it compares at most: evenly spaced, from the first to the
  // latest (core::evenlySpacedPoses). Bounds each choice's cost on long runs: the poses are
  // picked through the paths' jump pointers (SlamFilter::bestPathSample), O(max_poses log T)
  // per member instead of a walk over the T updates (8 members at 120000 updates: 33.5 ms
  // against 151 ms per choice, docs/results.md Timing). One pose per update: the paths of a
  // 15-minute MRCLAM run, 1000-2300 updates, are compared whole.
  int consensus_max_poses = 4000;
  // The reported member changes only when another leads it by more than this much summed
  // log-evidence (nats; with new_landmarks, when it created fewer landmarks, or as many and
  // leads by this much). Without it members of about equal evidence take turns, and the
  // node's map -> odom, ~pose, ~trajectory and markers jump with each turn. 0: the best
  // member at every update (on an exact tie the leader stays). With new_landmarks the margin
  // only matters between members that created as many landmarks. With consensus only its
  // fallback (fewer than three members, or paths that cannot be compared) uses it.
  double switch_margin = 0.0;
};

struct FilterOptions {
  std::string variant = "fastslam2";
  int particles = 100;
  unsigned long seed = 42;
  double resample_threshold = 0.5;  // resample when Neff < threshold * particles
  // fastslam2 family: each particle's pose is drawn from its proposal N(mean, scale x cov)
  // when observations refined it. 1 is FastSLAM 2.0; below 1 the particles follow the map
  // more closely (less heading noise injected per update, at the cost of diversity).
  double proposal_sample_scale = 1.0;
  MotionOptions motion;
  AssociationOptions association;
  RelocalizationOptions relocalization;  // fastslam2 and the variants built on it
  HeadingPriorOptions heading_prior;     // fastslam2 and hinf_fastslam (line landmarks)
  MeasurementOptions measurement;
  ExistenceOptions existence;
  HinfOptions hinf;  // variant hinf_fastslam only
  bool use_points = true;
  bool use_lines = true;
  RobustOptions robust;            // variant robust_fastslam2 (particles = M per set)
  LandmarkTrackerOptions tracker;  // variant robust_fastslam2
  WadAssociationOptions line_association;  // variants multifilter_smc and ekf_slam
  MultiFilterOptions multifilter;          // variant multifilter_smc
  EkfSlamOptions ekf;                      // variant ekf_slam
  GridOptions grid;                // variant grid_pf
  DpfOptions dpf;                  // variant dpf (and the fault injector of any variant)
  EnsembleOptions ensemble;        // variants fastslam2 and hinf_fastslam
};

/// Throws std::invalid_argument naming the first out-of-range field and its allowed range.
void validate(const FilterOptions& options);
void validate(const RobustOptions& options);

}  // namespace core
}  // namespace rbpf_slam

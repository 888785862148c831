#pragma once
// Re-association after drift (loop closure) for the landmark filters: when most of a scan's
// features fall outside every gate, a particle's pose may have drifted (or the odometry / scan
// match of this step failed) by more than its proposal covers. searchPoseCorrection() looks for
// a rigid correction (dx, dy, dtheta) of the pose, within a bounded window, under which many
// features line up with the particle's own map: the rotation from votes of observed / mapped
// line pairs (directions modulo pi), then the translation from pairs of non-parallel line
// constraints, point pairs, or one line's normal shift (a corridor leaves the shift along
// it at zero), each candidate scored by how many distinct features it explains.
// The filter then re-runs its ordinary association and proposal from the corrected pose and
// keeps the correction only if that associates clearly more features (FastSlam2).

#include <vector>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

class LandmarkMap;
struct Observation;

/// Options of the search (config block `relocalization`); off by default.
struct RelocalizationOptions {
  bool enabled = false;
  double search_xy_m = 2.0;        // largest position correction searched, m
  double search_theta_rad = 0.2;   // largest heading correction searched, rad
  int min_unmatched = 3;           // trigger: at least this many features left unmatched ...
  double min_unmatched_ratio = 0.5;  // ... and at least this fraction of the scan's features
  int min_matches = 4;             // accept: at least this many features associated after ...
  int min_gain = 2;                // ... and this many more than at the uncorrected pose ...
  double min_matched_ratio = 0.0;  // ... and at least this fraction of the scan's features
  double min_information = 0.0;    // ... and the features it explains fix it this well in every
                                   // direction (a wall across it counts 1, a point 1 each way;
                                   // 2: along a corridor, two points; 0: no condition)
  int min_landmark_age = 0;        // search only landmarks not seen for this many updates
                                   // (loop closure; 0: every landmark, also odometry glitches)
  double line_tolerance_m = 0.15;  // a line constraint counts as explained within this, m
  double angle_tolerance_rad = 0.03;  // ... and this in direction, rad
  double point_tolerance_m = 0.3;  // a point pair counts as explained within this, m
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const RelocalizationOptions& options);

struct PoseCorrection {
  bool found = false;
  Pose2 pose = Pose2::Zero();  // the corrected pose
  int support = 0;             // distinct observations the correction explains
};

/// The best rigid correction of `pose` within the options' window under which observations
/// (robot frame) line up with map landmarks, or found = false when none explains at least
/// options.min_matches observations. Deterministic; uses no random numbers.
/// `line_overlap_margin_m`: how far an observed segment may lie from a map line's extent.
/// Only landmarks last seen before step `seen_before` take part (INT_MAX: all).
PoseCorrection searchPoseCorrection(const LandmarkMap& map, const Pose2& pose,
                                    const std::vector<Observation>& observations,
                                    const RelocalizationOptions& options,
                                    double line_overlap_margin_m,
                                    int seen_before = 2147483647);

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Options of the landmark tracker (no other dependency, so that filter_options.h can hold them).

namespace rbpf_slam {
namespace core {

struct LandmarkTrackerOptions {
  double gate_chi2 = 9.21;          // Mahalanobis^2 within which an observation is a tracked one
  double new_landmark_chi2 = 20.0;  // beyond this from every tracked landmark: a new landmark
  int forget_after_steps = 25;      // a landmark unseen for this many steps is dropped
  double forget_distance_m = 25.0;  // a landmark farther than this from the robot is dropped
  int max_landmarks = 40;           // hard bound of the state: when full, the landmark unseen
                                    // longest makes room if unseen for forget_after_steps / 5
                                    // steps; otherwise new sightings are left out
  // A line matches a tracked one only when the observed segment comes this close to the extent
  // seen so far (as FastSLAM's association.line_overlap_margin_m), and is forgotten by its
  // distance to that extent: a collinear wall 35 m on is another landmark, not the same
  // infinite line. A negative value: infinite lines (before session 39).
  double line_overlap_margin_m = 1.0;
};

/// Throws std::invalid_argument naming the first out-of-range field (prefix "tracker.").
void validate(const LandmarkTrackerOptions& options);

}  // namespace core
}  // namespace rbpf_slam

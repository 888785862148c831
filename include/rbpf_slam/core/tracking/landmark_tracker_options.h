#pragma once
// Options of the landmark tracker (no other dependency, so that filter_options.h can hold them).

namespace rbpf_slam {
namespace core {

struct LandmarkTrackerOptions {
  double gate_chi2 = 9.21;          // Mahalanobis^2 within which an observation is a tracked one
  double new_landmark_chi2 = 20.0;  // beyond this from every tracked landmark: a new landmark
  int forget_after_steps = 25;      // a landmark unseen for this many steps is dropped
  double forget_distance_m = 25.0;  // a landmark farther than this from the robot is dropped
  int max_landmarks = 40;           // hard bound of the state (oldest-seen dropped first)
};

/// Throws std::invalid_argument naming the first out-of-range field (prefix "tracker.").
void validate(const LandmarkTrackerOptions& options);

}  // namespace core
}  // namespace rbpf_slam

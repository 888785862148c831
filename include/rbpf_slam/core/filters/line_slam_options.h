#pragma once
// Options of the line-based multi-filter SMC SLAM (Yuen and MacDonald) and of the EKF-SLAM
// baseline it was compared with; both share the WAD association and its thresholds.

#include <string>

namespace rbpf_slam {
namespace core {

/// Feature association and new-obstacle detection by the weighted absolute difference
/// (Yuen and MacDonald eqs. 13 to 15). Points, which the paper does not use, are compared by
/// their Euclidean distance in metres against the same threshold.
struct WadAssociationOptions {
  double h_similar_feature = 1.0;  // two features are similar when their WAD is below this
  double c_w1 = 1.0;               // WAD weight of |delta rho| [1/m]
  double c_w2 = 1.5;               // WAD weight of |delta theta| [1/rad]
  // Where |delta rho| is measured: "origin" (the paper: the map frame's (rho, theta)) or
  // "robot" (both lines' rho measured from the robot's position, i.e. the difference the
  // sensor would see; a heading error then does not grow with the distance from the origin).
  std::string compare_at = "origin";
};

/// Multi-filter SMC: one SIR filter for the robot pose (FilterOptions::particles, the paper's
/// 2000) and one small SIR filter per landmark.
struct MultiFilterOptions {
  int line_particles = 200;  // particles of each landmark filter
  double c_m1 = 0.2;         // Laplace scale of the robot filter's likelihood of the mean WAD
  double c_m2 = 0.2;         // Laplace scale of a landmark filter's likelihood of its WAD
  // Landmark filters start as N(detection, sigma^2) around the first sighting.
  double init_sigma_m = 0.1;     // rho (lines) or x, y (points), m
  double init_sigma_rad = 0.03;  // theta (lines), rad
  // Jitter added after a landmark filter resamples (regularised SIR): without it the
  // time-invariant parameter's particles collapse onto a few values and can no longer move,
  // which is the paper's plain SIR (config/laser_multifilter.yaml sets 0: with jitter the
  // lines follow the robot's drift).
  double roughening_m = 0.005;
  double roughening_rad = 0.002;
};

/// EKF-SLAM baseline: one joint Gaussian over the pose and every landmark.
struct EkfSlamOptions {
  // A matched feature whose Mahalanobis^2 innovation exceeds this is not used (0: use every
  // match the WAD association gives, as the paper's EKF did).
  double innovation_gate_chi2 = 0.0;
};

/// Each throws std::invalid_argument naming the first out-of-range field.
void validate(const WadAssociationOptions& options);
void validate(const MultiFilterOptions& options);
void validate(const EkfSlamOptions& options);

}  // namespace core
}  // namespace rbpf_slam

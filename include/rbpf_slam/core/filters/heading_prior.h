#pragma once
// Heading prior of rectilinear buildings ("Manhattan world"): most walls run along two
// perpendicular directions, so every line landmark seen along one of them measures the robot's
// absolute heading modulo 90 deg. FastSLAM with lines otherwise holds the heading only
// relative to the particle's own (drifting) map; this bounds the drift between loop closures.
//
// The dominant direction is learned from the first updates' lines (the start pose is exact)
// or given. A line whose normal lies within `tolerance_rad` of an axis counts, others (diagonal
// walls, clutter) are ignored, so a building that is not rectilinear only loses the benefit.

#include <Eigen/Core>
#include <cmath>
#include <utility>
#include <vector>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

struct Observation;

struct HeadingPriorOptions {
  bool enabled = false;
  // The dominant wall direction in the map frame, modulo pi/2: learned from the lines of the
  // first `learn_updates` updates that have lines (each at the best particle's heading), or
  // given as direction_rad (the map frame starts at the first pose, so 0 when the robot
  // starts parallel to a wall).
  bool learn_direction = true;
  int learn_updates = 5;
  double direction_rad = 0.0;
  double tolerance_rad = 0.1;  // a line whose normal is within this of an axis counts
  double sigma_rad = 0.02;     // noise of the heading measured from one update's lines
  int min_lines = 2;           // fewer axis-aligned lines in an update: no measurement
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const HeadingPriorOptions& options);

/// The angle wrapped into [-pi/4, pi/4): its offset from the nearest of four axes at 0 rad.
double axisOffset(double angle_rad);

class HeadingPrior {
 public:
  explicit HeadingPrior(const HeadingPriorOptions& options);

  /// Forgets a learned direction (a new map).
  void reset();
  bool enabled() const { return options_.enabled; }
  /// True once the direction is known (given, or learned).
  bool ready() const { return std::isfinite(direction_); }
  double direction() const { return direction_; }
  /// While learning: adds the lines of one update seen at this heading; after `learn_updates`
  /// updates with lines fixes the direction at the strongest family: the axis offset that
  /// most line length lies within tolerance_rad of (so walls of a second, oblique family do
  /// not pull it), refined by the length-weighted mean of that family.
  void learn(const std::vector<Observation>& observations, double heading_rad);
  /// The mean offset from the nearest axis of the lines seen at `heading_rad` that lie within
  /// the tolerance, length-weighted; false when fewer than min_lines do (or not ready).
  bool residual(const std::vector<Observation>& observations, double heading_rad,
                double* offset_rad) const;
  /// Conditions the Gaussian (mean, cov) on the heading measurement "heading = mean.z() -
  /// offset" with noise sigma_rad; returns its log-likelihood (the weight factor).
  double condition(double offset_rad, Pose2* mean, Eigen::Matrix3d* cov) const;

 private:
  HeadingPriorOptions options_;
  double direction_;
  std::vector<std::pair<double, double>> learned_;  // (axis offset, length) of the lines seen
  int learned_updates_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

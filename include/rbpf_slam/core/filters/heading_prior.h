#pragma once
// Heading prior of rectilinear buildings ("Manhattan world"): most walls run along two
// directions, usually perpendicular, so every line seen along one of them measures the robot's
// absolute heading (modulo the half turn), with no data association. FastSLAM with lines
// otherwise holds the heading only relative to the particle's own (drifting) map; this bounds
// the drift between loop closures.
//
// The two wall families are learned from the lines of the first scans (directions modulo pi,
// in the map frame): the strongest family, and the strongest one within max_skew_rad of its
// perpendicular if it holds enough line length and lies more than 0.05 rad off the exact
// perpendicular (else the exact perpendicular is taken).
// A line within tolerance_rad of a family measures the heading; others (walls of a third
// direction, clutter) are ignored, so where the assumption fails the filter loses the benefit.
// Used by FastSlam2::update: fastslam2, hinf_fastslam, and the plain steps of robust_fastslam2.
//
// Each particle's motion prediction is conditioned on the measurement (a 1-D Kalman step with
// that step's motion noise) and the particle weighed by its likelihood. That corrects drift only
// as far as the motion noise spreads the particles' headings: enough with laser increments, not
// with sonar's few lines and low motion noise. With drift_tracking, one Kalman filter also
// follows the error of the filter's mean heading, its variance growing with the angle turned and
// the distance driven (drift_per_rad, drift_per_m); each measurement first turns every particle
// by the same correction, then weighs them as above. The lines are then used twice (for the
// common drift and for the particles' spread), an approximation that sigma_rad absorbs.

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

struct Observation;

struct HeadingPriorOptions {
  bool enabled = false;
  // Learn the families from the lines of the first `learn_updates` updates that have lines
  // (each at the filter's estimated heading), or take direction_rad (the first family; the
  // second is its perpendicular) in the map frame.
  bool learn_direction = true;
  int learn_updates = 5;
  // Learning keeps the families only if they hold at least this fraction of the learned line
  // length; otherwise it starts again over the next learn_updates scans.
  double min_family_fraction = 0.4;
  // The second family within this of the first's perpendicular; 0: exactly perpendicular,
  // both families learned together (directions modulo a quarter turn).
  double max_skew_rad = 0.35;
  double direction_rad = 0.0;
  double tolerance_rad = 0.1;  // a line within this of a family measures the heading
  double sigma_rad = 0.01;     // noise of the heading measured from one update's lines
  int min_lines = 2;           // fewer such lines in an update: no measurement
  // Probability that an update's measurement is wrong (clutter, a badly fitted wall), spread
  // evenly over the tolerance: the update is then weighted by the probability that it is right,
  // so one wrong line moves the heading little. 0: every measurement trusted.
  double outlier_ratio = 0.0;
  bool drift_tracking = false;  // follow the mean heading's drift (above)
  double drift_per_rad = 0.02;  // ... which grows by this (1 sigma) per sqrt(rad) turned, rad
  double drift_per_m = 0.005;   // ... and by this per sqrt(m) driven, rad
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const HeadingPriorOptions& options);

/// The angle wrapped into [-pi/2, pi/2): a line direction (a normal and its opposite are the
/// same wall).
double halfTurnOffset(double angle_rad);

class HeadingPrior {
 public:
  explicit HeadingPrior(const HeadingPriorOptions& options);

  /// Forgets learned families and any learning in progress (a new map).
  void reset();
  bool enabled() const { return options_.enabled; }
  bool tracksDrift() const { return options_.enabled && options_.drift_tracking; }
  /// True once the families are known (given, or learned).
  bool ready() const { return ready_; }
  /// The two families' normal directions in the map frame, modulo pi.
  const std::array<double, 2>& families() const { return families_; }
  /// While learning: adds the lines of one update seen at this heading; after `learn_updates`
  /// updates with lines (at once with `conclude`, e.g. for a loaded map) fixes the families.
  void learn(const std::vector<Observation>& observations, double heading_rad,
             bool conclude = false);
  /// The length-weighted mean offset from their family, at `heading_rad`, of the lines that lie
  /// within tolerance of a family at `reference_rad`. Every particle passes the same reference
  /// (the filter's heading), so all are scored on the same lines; false when fewer than
  /// min_lines qualify (or not ready).
  bool residual(const std::vector<Observation>& observations, double reference_rad,
                double heading_rad, double* offset_rad) const;
  /// The lines residual() uses, picked once at `reference_rad`: each line's observed direction,
  /// its family's direction and its weight. Empty when not enabled or not ready.
  struct LineSelection {
    struct Line {
      double observed_rad, family_rad, weight;
    };
    std::vector<Line> lines;
  };
  LineSelection select(const std::vector<Observation>& observations, double reference_rad) const;
  /// residual() on lines already selected: one selection per update serves every particle.
  bool residual(const LineSelection& selection, double heading_rad, double* offset_rad) const;
  /// Conditions the Gaussian (mean, cov) on the heading measurement "heading = mean.z() -
  /// offset" with noise sigma_rad (and outlier_ratio); returns its log-likelihood (the weight
  /// factor).
  double condition(double offset_rad, Pose2* mean, Eigen::Matrix3d* cov) const;
  /// drift_tracking: the mean heading's error variance grows with a motion of this rotation and
  /// translation (rad, m).
  void predictDrift(double rotation_rad, double translation_m);
  /// drift_tracking: the turn (rad) that corrects the filter's mean heading `reference_rad` from
  /// this update's lines (a Kalman step on the error variance); 0 without a measurement (or not
  /// ready).
  double correctDrift(const std::vector<Observation>& observations, double reference_rad);
  /// drift_tracking: the variance of the mean heading's error, rad^2.
  double driftVariance() const { return drift_variance_; }
  /// drift_tracking: the mean heading was set anew (e.g. an initial pose) with this variance.
  void setDriftVariance(double variance_rad2) {
    if (std::isfinite(variance_rad2) && variance_rad2 >= 0.0) drift_variance_ = variance_rad2;
  }

 private:
  /// The family of a map-frame line direction (index), or -1 beyond tolerance of both.
  int familyOf(double direction_rad) const;
  /// The probability that a measurement `offset_rad` with innovation variance s is right, and
  /// the log-likelihood of the measurement (inlier Gaussian mixed with the outlier density).
  double inlierProbability(double offset_rad, double s, double* log_likelihood) const;
  /// The offset with the most length within tolerance among `samples` (optionally only those
  /// within max_skew_rad of `around`), refined by their weighted mean; returns that support.
  /// Directions are taken modulo `period` (pi: one family; pi/2: two perpendicular ones).
  double strongest(const std::vector<std::pair<double, double>>& samples, const double* around,
                   double period, double* direction) const;

  HeadingPriorOptions options_;
  bool ready_ = false;
  std::array<double, 2> families_{{0.0, 0.0}};
  std::vector<std::pair<double, double>> learned_;  // (direction mod pi, length) of lines seen
  int learned_updates_ = 0;
  double drift_variance_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

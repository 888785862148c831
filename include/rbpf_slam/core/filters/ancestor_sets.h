#pragma once
// Bounded memory of the robust RBPF-SLAM (Lee, Kim and Chung 2010, Fig. 4): the particle sets
// stored at the last step before each of the latest new landmarks (the ancestor sets
// S_{t - dt_k}), and the odometry and observations of the latest steps, for sampling from an
// ancestor (eq. 8) and for the intermediate path (sec. IV). Nothing grows with run length.

#include <deque>
#include <vector>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/motion/motion_model.h"

namespace rbpf_slam {
namespace core {

/// One stored particle set S_s. Particles share their maps copy-on-write, so a set costs one
/// pose and one pointer per particle.
struct AncestorSet {
  int step = 0;
  std::vector<Particle> particles;
  std::vector<double> weights;  // normalised
};

/// What the filter received at one step.
struct StepRecord {
  int step = 0;
  MotionInput motion;  // increment from the previous step to this one
  double drift_turn_rad = 0.0;  // the heading prior's drift correction of the step (added to
                                // every particle's predicted heading after the motion)
  std::vector<Observation> observations;
};

/// Eq. 8's Gaussian: moves mean and cov over the records by the odometry mean, the record's
/// drift turn and the motion model's covariance (propagated by the composition's Jacobian).
void propagateOverRecords(const MotionModel& model, const std::vector<const StepRecord*>& records,
                          Pose2* mean, Eigen::Matrix3d* cov);

class AncestorMemory {
 public:
  /// max_sets stored sets (K - 1: the current set is the K-th), at least spacing_steps apart,
  /// none and no record older than window_steps.
  AncestorMemory(int max_sets, int spacing_steps, int window_steps);

  void clear();
  /// Appends the record of a step (steps increase); drops records beyond the window.
  void record(StepRecord record);
  /// Sets the latest record's drift turn (the correction every particle of that step got), so
  /// that candidates propagated over the record later get it too. Nothing without records.
  void setLatestDriftTurn(double turn_rad);
  /// Whether a set of `step` would be far enough from the latest stored one.
  bool canStore(int step) const;
  /// Stores a set (when canStore), dropping the oldest beyond max_sets.
  void store(AncestorSet set);
  /// The stored sets usable at `step` (within the window, all their records held), newest first.
  std::vector<const AncestorSet*> usable(int step) const;
  /// The records of steps from + 1 .. to, in order; empty when one is missing.
  std::vector<const StepRecord*> records(int from, int to) const;

  int storedSets() const { return static_cast<int>(sets_.size()); }
  int storedRecords() const { return static_cast<int>(records_.size()); }
  int latestStoredStep() const { return sets_.empty() ? -1 : sets_.back().step; }

 private:
  void dropOld(int step);

  const int max_sets_;
  const int spacing_steps_;
  const int window_steps_;
  std::deque<AncestorSet> sets_;  // oldest first
  std::deque<StepRecord> records_;
};

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Robust RBPF-SLAM of Lee, Kim and Chung (ICRA 2010): FastSLAM 2.0 that, when the landmark
// tracker reports a new landmark, draws M particles from each of K ancestor sets (eq. 8),
// weights all M x K by the current observations, keeps M (Fig. 3, 4), and fills the path a
// particle skipped by the intermediate path estimate, replaying the stored observations into
// its map (sec. IV). Between such steps it is exactly FastSLAM 2.0, and so is a step whose
// observations include fewer than robust.min_old_observations of landmarks every set knows
// (sparse sensors: z_t could not weigh the sets' candidates against each other).

#include <vector>

#include "rbpf_slam/core/filters/ancestor_sets.h"
#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/intermediate_path.h"
#include "rbpf_slam/core/tracking/landmark_tracker.h"

namespace rbpf_slam {
namespace core {

/// Running totals of the robust steps (their count is FilterStats::robust_steps).
struct RobustStats {
  long tracker_events = 0;   // steps at which the tracker started a landmark
  long from_older_sets = 0;  // particles kept at robust steps that came from an older set
  long replayed_steps = 0;   // intermediate steps replayed into particles' maps
  long fallbacks = 0;        // events with older sets that took a plain FastSLAM 2.0 step, having
                             // fewer than robust.min_old_observations old-landmark observations
};

class RobustFastSlam2 : public FastSlam2 {
 public:
  explicit RobustFastSlam2(const FilterOptions& options);

  std::string variant() const override { return "robust_fastslam2"; }
  void reset(const Pose2& initial_pose) override;
  UpdateStats update(const FeatureSet& features) override;
  /// A new pose or map invalidates the stored sets and the tracker: both start again.
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override;
  bool loadMap(const std::vector<LandmarkEstimate>& landmarks) override;

  const RobustStats& robustStats() const { return robust_stats_; }
  /// For each particle, the step of the set it was drawn from at the latest robust step
  /// (that step - 1 for the latest set); empty before the first robust step.
  const std::vector<int>& origins() const { return origins_; }
  const AncestorMemory& memory() const { return memory_; }
  const LandmarkTracker& tracker() const { return tracker_; }

 private:
  /// Odometry increment covariance in the frame of the previous pose.
  Eigen::Matrix3d incrementCovariance(const MotionInput& motion) const;
  UpdateStats robustUpdate(const std::vector<Observation>& observations,
                           const std::vector<const AncestorSet*>& ancestors,
                           const MotionInput& motion);
  /// The FastSLAM 2.0 step of one candidate from its propagated pose Gaussian; returns its
  /// weight, counting only landmarks mapped by oldest_set_step (those every ancestor can know),
  /// so that candidates from older sets are not penalised for lacking newer landmarks.
  double updateCandidate(Particle* particle, const Pose2& mean, const Eigen::Matrix3d& cov,
                         const std::vector<Observation>& observations,
                         const HeadingPrior::LineSelection& heading_lines, int oldest_set_step,
                         ParticleUpdate* counts);
  /// The most observations at `step` that the most probable particle of one ancestor set, moved
  /// over the skipped steps, associates with landmarks older than the oldest set (known to every
  /// set): the evidence z_t holds to weigh the candidates of the sets against each other.
  int oldLandmarkObservations(const std::vector<Observation>& observations,
                              const std::vector<const AncestorSet*>& ancestors, int step) const;
  void forgetHistory();
  /// The intermediate path (sec. IV) between `start`, a pose of the set of step `from`, and
  /// `end`, the pose of the current step; empty when fewer than two records join them.
  IntermediatePath intermediatePath(const Pose2& start, const Pose2& end, int from) const;
  /// Its means, one per skipped step (from + 1 .. current - 1).
  std::vector<Pose2> intermediateMeans(const Pose2& start, const Pose2& end, int from) const;
  /// Samples the skipped poses of a particle drawn from the set of step `from` and replays the
  /// stored observations into its map, from the latest step back (sec. IV). Returns the skipped
  /// poses in step order (sampled where a step had observations, else the estimated mean).
  std::vector<Pose2> replayIntermediatePath(Particle* particle, const Pose2& start, int from);

  LandmarkTracker tracker_;
  AncestorMemory memory_;
  std::vector<int> origins_;
  int last_robust_step_ = -1000000;
  RobustStats robust_stats_;
};

}  // namespace core
}  // namespace rbpf_slam

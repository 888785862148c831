#pragma once
// One local filter of the distributed particle filter (Pei et al. 2014): a Rao-Blackwellised
// particle filter over the robot pose and its own block of point landmarks (ids i mod N), with
// the FastSLAM 2.0 proposal and the adaptive importance function of eqs. 12-13.

#include <map>
#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/dpf_exchange.h"
#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/motion/motion_model.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {

/// eq. 13 (our reading): the covariance used in the likelihood of one observation is the
/// measurement noise plus the weighted spread of the particles' innovations under the basic
/// weights of the first pass: R + sum_j w_j (v_j - v_bar)(v_j - v_bar)^T, v_bar = sum_j w_j v_j.
/// `weights` are normalised; entries with weight 0 do not contribute.
Eigen::Matrix2d adaptiveLikelihoodCovariance(const std::vector<Eigen::Vector2d>& innovations,
                                             const std::vector<double>& weights,
                                             const Eigen::Matrix2d& measurement_noise);

/// Seed of local filter `index` derived from the filter's seed (splitmix64 of both).
unsigned long localFilterSeed(unsigned long seed, int index);

class DpfLocalFilter {
 public:
  /// A point landmark's EKF in the map frame.
  struct Landmark {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
    int observations = 0;
  };
  using Map = std::map<int, Landmark>;  // keyed by landmark id
  struct Particle {
    Pose2 pose = Pose2::Zero();
    std::shared_ptr<const Map> map = std::make_shared<const Map>();
  };

  DpfLocalFilter(const FilterOptions& options, int index);

  int index() const { return index_; }
  /// Every particle at initial_pose, or drawn from N(initial_pose, covariance) when one is
  /// given (poseCovarianceUsable); maps emptied.
  void reset(const Pose2& initial_pose, const Eigen::Matrix3d* covariance = nullptr);
  /// Runs steps 2 of the protocol (dpf_exchange.h) for one input; `injected` is the
  /// disturbance added to this filter's odometry increment (zero when not faulted).
  DpfLocalEstimate step(const DpfStepInput& input, const Pose2& injected = Pose2::Zero());
  /// True when this filter takes features with this landmark id.
  bool owns(int id) const;

  const std::vector<Particle>& particles() const { return particles_; }
  const std::vector<double>& weights() const { return weights_; }
  int bestParticle() const;
  long reinitialisations() const { return reinitialisations_; }

 private:
  struct Observation {
    int id = -1;
    Eigen::Vector2d z = Eigen::Vector2d::Zero();
    Eigen::Matrix2d noise = Eigen::Matrix2d::Identity();
  };
  std::vector<Observation> prepare(const FeatureSet& features, int* rejected) const;
  void applyFeedback(const DpfFeedback& feedback);
  void reinitialise(const DpfFeedback& feedback);
  /// feedback_mode moment: moves and scales the cloud onto the master's mean and covariance.
  void momentMatch(const DpfFeedback& feedback);
  /// feedback_mode reweight: weights times N(x; master) / N(x; own last posterior), then
  /// resampling when Neff drops under the threshold.
  void reweight(const DpfFeedback& feedback);
  /// Low-variance resampling (weights then uniform) when neff < resample_threshold x N.
  void resampleIfBelow(double neff);
  /// Weights (eq. 12, adaptive covariance of eq. 13 when enabled), NIS, resampling.
  DpfLocalEstimate finishStep(long step,
                              const std::vector<std::vector<Eigen::Vector2d>>& innovations,
                              const std::vector<std::vector<Eigen::Matrix2d>>& model_cov,
                              const std::vector<bool>& known, DpfLocalEstimate* estimate);

  const FilterOptions options_;
  const int index_;
  std::unique_ptr<MotionModel> motion_model_;
  Rng rng_;
  std::vector<Particle> particles_;
  std::vector<double> weights_;
  std::vector<double> log_weights_;  // since the last resampling
  int resampled_best_ = -1;  // after a resampling: the copy of the most probable (bestParticle)
  // This step's per-particle Gaussians: predicted (motion only) and proposal (after the
  // observations), for the prior and posterior moments the master fuses.
  std::vector<Pose2> prior_means_, proposal_means_;
  std::vector<Eigen::Matrix3d> prior_covs_, proposal_covs_;
  long reinitialisations_ = 0;
  // The posterior this filter reported last (the denominator of the reweighting feedback).
  bool has_posterior_ = false;
  double feedback_neff_ = 0.0;  // Neff of the last reweighting feedback (particles: none)
  Pose2 posterior_mean_ = Pose2::Zero();
  Eigen::Matrix3d posterior_cov_ = Eigen::Matrix3d::Identity();
};

/// A local filter fed by the master's stream of steps as a separate process sees it
/// (dpf_local_node): a step may arrive after lost ones, or first in the middle of a run (a
/// restarted process, or a new run whose step 1 was lost), or again (a message delivered
/// twice).
class DpfLocalStream {
 public:
  enum class Outcome {
    kStepped,         // the expected step
    kResynchronised,  // after a gap: the particles were redrawn from the master's estimate
                      // (the step's feedback) before the step, keeping the best map of the
                      // run if any (a new run starts with none)
    kRepeated,        // a step of this run already taken: ignored
    kNoFeedback,      // a gap, but the step carries no master estimate to start from: ignored
  };
  DpfLocalStream(const FilterOptions& options, int index) : filter_(options, index) {}

  /// Step 1, or a step of another run (DpfStepInput::run), resets the filter at initial_pose
  /// (a new run). *estimate is set unless the outcome is kRepeated or kNoFeedback.
  Outcome step(const DpfStepInput& input, const Pose2& initial_pose, const Pose2& injected,
               DpfLocalEstimate* estimate);
  const DpfLocalFilter& filter() const { return filter_; }
  /// The step it expects next (1 before its first).
  long expected() const { return expected_; }

 private:
  DpfLocalFilter filter_;
  long expected_ = 1;
  bool started_ = false;  // has seen a run
  std::uint32_t run_ = 0;
};

/// The log of the ratio N(x; target_mean, target_cov) / N(x; own_mean, own_cov) at each pose,
/// up to a constant, keeping only the directions in which the target is the sharper (where
/// the ratio is a Gaussian; elsewhere reweighting cannot add information and the direction is
/// left out). Headings are wrapped relative to the target mean.
std::vector<double> feedbackLogRatio(const std::vector<Pose2>& poses, const Pose2& target_mean,
                                     const Eigen::Matrix3d& target_cov, const Pose2& own_mean,
                                     const Eigen::Matrix3d& own_cov);

}  // namespace core
}  // namespace rbpf_slam

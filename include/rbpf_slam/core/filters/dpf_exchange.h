#pragma once
// The data the local filters and the master filter of the distributed filter exchange, as
// plain structs: the same step protocol runs between threads or between ROS nodes.
//
// Step protocol (step k = 1, 2, ...), identical in both deployments:
//   1. the master sends DpfStepInput{k, motion_k, features_k, feedback_{k-1}} to every local;
//   2. local i applies feedback_{k-1} (re-initialise if listed, else reweight or moment-match
//      onto the master's estimate when feedback is on), predicts with motion_k, updates with
//      its block of features_k, and answers DpfLocalEstimate{i, k, ...};
//   3. the master fuses the N estimates of step k (in index order) into DpfMasterOutput_k,
//      whose feedback goes out with step k + 1. A local whose prior (its prediction) is not
//      the master's prediction is flagged and not fused that step (dpf.fault_prior_chi2).
// Each local filter owns its generator, seeded from (seed, index), so the result does not
// depend on which thread or process runs which local filter.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/motion/motion_model.h"

namespace rbpf_slam {
namespace core {

/// What the master tells the local filters after fusing a step.
struct DpfFeedback {
  long step = 0;  // the step this feedback was fused from (0: none yet)
  Pose2 mean = Pose2::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  std::vector<int> reinitialise;  // indices of isolated local filters to redraw from the master
};

/// One step of input, the same for every local filter.
struct DpfStepInput {
  long step = 0;
  // The master's run (remote deployment): a new value at every master start and reset. A local
  // filter that sees another run starts over, even when it missed that run's step 1.
  std::uint32_t run = 0;
  MotionInput motion;
  FeatureSet features;  // all features: each local filter takes its own block
  DpfFeedback feedback;
};

/// A local filter's answer for one step.
struct DpfLocalEstimate {
  int index = 0;
  long step = 0;
  Pose2 mean = Pose2::Zero();  // posterior (after this step's observations)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  Pose2 prior_mean = Pose2::Zero();  // predicted, before this step's observations
  Eigen::Matrix3d prior_covariance = Eigen::Matrix3d::Identity();
  double neff = 0.0;          // before resampling
  int particles = 1;
  double nis_sum = 0.0;       // sum over this step's observations of the normalised innovation^2
  int innovations = 0;        // observations of known landmarks this step
  int new_landmarks = 0;
  int rejected = 0;           // features of this block that were unusable
  int landmarks = 0;          // in the best particle
  // false: no answer came (a dpf_local_node that stalled or died); a placeholder that the master
  // does not fuse, counted in DpfLocalHealth::missed. Only the remote deployment makes them.
  bool answered = true;
};

/// The placeholder for a local filter that did not answer step `step`.
inline DpfLocalEstimate missedEstimate(int index, long step) {
  DpfLocalEstimate e;
  e.index = index;
  e.step = step;
  e.answered = false;
  return e;
}

/// Per-local bookkeeping of the master (fault detection state).
struct DpfLocalHealth {
  double smoothed_nis = 2.0;  // exponential average of the mean NIS (2 dof: expectation 2)
  int suspect_steps = 0;      // consecutive steps flagged
  bool suspect = false;
  double prior_nis = 0.0;     // this step's Mahalanobis^2 of its prior against the master's
  bool inconsistent = false;  // prior_nis > fault_prior_chi2: not fused this step (false
                              // when it did not answer: not judged)
  bool answered = true;       // it answered the last step fused
  long isolations = 0;
  double process_nis = 0.0;   // ... of its prior against its process (see DpfMaster::fuse)
  bool has_last_mean = false;  // last_mean is the local's posterior of the previous step
  long non_finite = 0;  // estimates with a non-finite value: not fused, counted as inconsistent
  long missed = 0;      // steps it did not answer (missedEstimate): not fused, not judged
  Pose2 last_mean = Pose2::Zero();
  bool streak_process_fault = false;  // a process fault among the current flagged steps
  int probation_steps = 0;    // after an isolation: unflagged steps needed before it is fused
};

/// What the master produced for one step.
struct DpfMasterOutput {
  long step = 0;
  Pose2 mean = Pose2::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  std::vector<double> weights;  // fused weight of each local filter (sum 1)
  DpfFeedback feedback;
};

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Options of the distributed particle filter (Pei et al. 2014) and of the fault injector
// used to test it; FilterOptions holds one DpfOptions (variant dpf).

#include <string>

namespace rbpf_slam {
namespace core {

/// Disturbance noise added to the odometry increment of one filter's process from a given
/// step on (the paper's robustness experiment). Off by default. For variant dpf it disturbs
/// local filter `local_index` only; for any other variant the whole (centralised) filter.
struct FaultInjectorOptions {
  bool enabled = false;
  int start_step = 1000;           // first filter step (1-based count of updates) disturbed
  int local_index = 0;             // dpf: the local filter whose process is disturbed
  double sigma_xy_m = 2.0;         // per-step N(0, sigma^2) added to dx and dy of the increment
  double sigma_theta_rad = 0.2;    // ... and to dtheta
};

/// The distributed filter: local particle filters over blocks of landmarks and a master
/// filter that fuses their pose estimates.
struct DpfOptions {
  int local_filters = 3;     // landmark blocks: a feature with id i goes to local i mod this
  int threads = 0;           // worker threads for the local filters (0: one per local filter)
  std::string weighting = "mixed";  // master weights: innovation | neff | mixed (section 3.2)
  double mix_innovation = 0.5;      // mixed: share of the innovation weight, the rest Neff
  std::string fusion = "information";  // information: weighted information fusion of what each
                                       // local learned; average: sum_i w_i x_i (the paper's)
  bool adaptive_covariance = true;  // eqs. 12-13: likelihood covariance from the particle spread
  bool feedback = true;  // give each local filter's particle cloud the master's mean and covariance
  double feedback_inflation = 1.0;  // the locals' clouds get this times the master covariance
  // How the feedback reaches a local filter's particles. reweight: each particle's weight is
  // multiplied by N(x; master) / N(x; the local's own posterior), i.e. by the information the
  // other local filters added, so that pose and map stay paired (the particles whose map agrees
  // with the fused pose survive resampling). moment: the cloud is moved and scaled onto the
  // master's mean and covariance (maps untouched; breaks the pose-map correlation). The default
  // is the shipped config's (reweight): fault-free on the simulator 0.52 m ATE against
  // moment's 4.06 m (10 seeds, docs/results.md).
  std::string feedback_mode = "reweight";
  double innovation_smoothing = 0.3;  // exponential smoothing of each local's mean NIS
  double fault_nis = 8.0;          // smoothed mean NIS (2 dof, expected 2) above this: suspect
  double fault_neff_ratio = 0.02;  // Neff / particles below this: suspect
  // Prior consistency (the precondition of the information fusion: every local predicts from
  // the master's last estimate with the same odometry): a local whose predicted pose differs
  // from the master's prediction by more than this Mahalanobis^2 (3 dof; 16.27: 99.9%) under
  // its prior covariance plus the master's last covariance has a faulty process. It is
  // suspect, and its information gain (relative to a prior the master does not share) is not
  // fused this step. 0: off.
  double fault_prior_chi2 = 16.27;
  double suspect_weight = 0.05;    // a suspect local's weight is multiplied by this
  int isolate_after_steps = 3;     // consecutive suspect steps before isolation + re-init
  // Readmission after an isolation for a process fault (a flagged step whose prior is neither
  // the master's prediction nor its own last posterior moved by the odometry, under
  // fault_prior_chi2): the re-initialised local is not fused (weight 0) until it has gone this
  // many consecutive steps unflagged; a flagged step restarts the count. A persistent fault
  // passes the checks now and then (e.g. the prior check when a gap in the data inflates every
  // covariance), and one clean step used to let it back in. 0: off (fused again on its first
  // unflagged step, the behaviour before dpf4).
  int readmit_after_steps = 10;
  double step_timeout_s = 10.0;    // dpf_master_node: wait this long for every local's answer
                                   // (then the step goes on without the silent ones)
  FaultInjectorOptions fault;
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const DpfOptions& options);

}  // namespace core
}  // namespace rbpf_slam

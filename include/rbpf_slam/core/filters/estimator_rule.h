#pragma once
// How a particle filter's Gaussians (the pose proposal and each landmark) are
// corrected by one linearised measurement: the EKF rule of FastSLAM 2.0, or the
// H-infinity rule of Havangi et al. ("The H-infinity FastSLAM framework"),
// which differ only in the gain and the covariance.

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace rbpf_slam {
namespace core {

/// Options of the H-infinity rule (Havangi et al., section IV; config section
/// `hinf`).
struct HinfOptions {
  /// How Gamma is set. "relative": scale-free, Gamma = P / theta with P the
  /// covariance before the step (the motion prediction for the pose, the landmark's previous
  /// covariance for a landmark), i.e. Gamma^-1 = theta P^-1: the step removes the fraction
  /// theta of the prior information, P+ = ((1 - theta) P^-1 + H^T R^-1 H)^-1. The condition
  /// holds for every theta < 1 whatever the units and scale of the problem, and the posterior
  /// gain is then the EKF gain with R scaled by (1 - theta): it undoes an overstated R by up
  /// to the factor 1 / (1 - theta). "absolute": Gamma = diag(gamma_*) below (the paper's form,
  /// fits one problem's scale only). "adaptive" (default, as config/landmarks_hinf.yaml; our
  /// addition, not in the paper): the relative form with theta learnt from the innovations.
  std::string mode = "adaptive";
  /// "adaptive": theta = 1 - s, s the scale of R at which the mean normalised innovation
  /// squared v^T S^-1 v of the matched observations (S with R scaled by s) would be 2, i.e. the
  /// innovations consistent, averaged over about adapt_steps steps and kept within
  /// [1 - theta_pose, 1]. An overstated R is undone, a right or understated one left nearly
  /// alone (theta near 0, FastSLAM 2.0's step at 0). theta_pose is then the cap.
  int adapt_steps = 20;
  /// theta of the pose proposal (relative mode; the cap in adaptive mode) and of the landmark
  /// filters (relative and adaptive modes, fixed), in [0, 1) (0: the EKF). Adaptive theta_pose
  /// 0.99 and adapt_steps 20: worlds/havangi_car.yaml and MRCLAM (docs/results.md, session 14);
  /// the landmark attenuation is off.
  double theta_pose = 0.99;
  double theta_landmark = 0.0;
  /// Attenuation gamma of the pose proposal (eqs. 22, 23) and of the landmark
  /// filters (eqs. 33, 34). The H-infinity covariance is P+ = (P^-1 + H^T R^-1
  /// H - Gamma^-1)^-1: 1 / gamma is taken off the information of each state
  /// direction. The paper's Gamma is gamma I; the pose's (x, y, heading) mixes
  /// metres and radians, so its Gamma is diag(gamma_position, gamma_position,
  /// gamma_heading) (Simon's weighting S = Gamma^-1). Units of a variance (m^2,
  /// rad^2); infinity gives the EKF back. Defaults: benchmarks/run_experiments
  /// on worlds/havangi_car.yaml (docs/results.md); the landmark attenuation did
  /// not help there and is off.
  double gamma_position = 0.003;
  double gamma_heading = 3e-4;
  double gamma_landmark = std::numeric_limits<double>::infinity();
  /// Gain: "posterior" K = P+ H^T R^-1 (Simon, Optimal State Estimation, ch.
  /// 11: the H-infinity gain, larger than the EKF's), or "prior" K = P H^T (H P
  /// H^T + R)^-1 (eqs. 20, 31 as printed: the Kalman form, on the H-infinity
  /// covariance of the previous step).
  std::string gain = "posterior";
  /// Covariance the pose is drawn from (eq. 24): "hinf", the H-infinity P+ as in the paper; or
  /// "ekf", the EKF's posterior of the same step, around the H-infinity mean. P+ bounds the
  /// worst-case error rather than being the spread of the posterior; with an overstated R it is
  /// up to 1 / (1 - theta) times the prediction and, the weights being flat then, drawing from
  /// it is a random walk that wide. Or "scaled" (modes relative and adaptive, posterior gain):
  /// the EKF's posterior with R scaled by 1 - theta, (1 - theta) P+, the Gaussian whose mean the
  /// step gives (shipped in config/landmarks_hinf.yaml since session 18). Default "ekf", valid
  /// with every mode (the paper: "hinf").
  std::string proposal_covariance = "ekf";
  /// Importance weight: "marginal", N(z; z_hat, H P H^T + R) accumulated over
  /// the sequential proposal updates as in FastSLAM 2.0; or "pointwise", eq. 36
  /// evaluated at the drawn pose: p(z | s) p(s | s_prev, u) / q(s); or "attenuated" (relative
  /// mode), the marginal likelihood of the model whose gain the H-infinity step applies:
  /// N(z; z_hat, H P H^T + (1 - theta_pose) R), R with the landmark's part.
  std::string weight = "marginal";
  /// Guard of the H-infinity condition ("absolute" mode; in "relative" mode the inflation is
  /// at most 1 / (1 - theta) by construction): a step whose covariance P+ would exceed this many
  /// times the EKF's in some direction (gamma too close to its bound, corrections amplified as
  /// much) falls back to the EKF like a failed condition, and is counted.
  double max_inflation = 4.0;
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const HinfOptions& options);

/// The corrected Gaussian of an N-dimensional state after one 2D measurement.
template <int N>
struct Correction {
  Eigen::Matrix<double, N, 2> gain = Eigen::Matrix<double, N, 2>::Zero();
  Eigen::Matrix<double, N, N> covariance = Eigen::Matrix<double, N, N>::Zero();
  bool ok = false;        // false: nothing finite could be computed; leave the state alone
  bool fallback = false;  // the H-infinity condition failed and the EKF was used instead
};

/// The EKF update: K = P H^T S^-1, P+ = (I - K H) P, S = H P H^T + R.
template <int N>
Correction<N> ekfCorrection(const Eigen::Matrix<double, N, N>& p,
                            const Eigen::Matrix<double, 2, N>& h, const Eigen::Matrix2d& r);

/// The H-infinity step from the EKF result of the same measurements (one or
/// several stacked): by the matrix inversion lemma eqs. 22, 23 (33, 34), P+ = P
/// - P [H^T I] R_e^-1 [H; I] P with R_e = [R 0; 0 -Gamma] + [H; I] P [H^T I],
/// are P+^-1 = P^-1 + H^T R^-1 H - Gamma^-1 = P_ekf^-1 - Gamma^-1, i.e. P+ =
/// P_ekf (I - Gamma^-1 P_ekf)^-1 (no indefinite (N + 2)-square R_e to invert).
/// With the posterior gain K = P+ H^T R^-1 the EKF's correction of the mean is
/// scaled by P+ P_ekf^-1 = (I - P_ekf Gamma^-1)^-1; with the prior gain (eqs.
/// 20, 31 as printed) it is kept. When P+ is not positive definite (the
/// H-infinity condition fails), or would exceed max_inflation x P_ekf in some
/// direction, the EKF result stands and fallback is set.
template <int N>
struct Attenuation {
  Eigen::Matrix<double, N, N> covariance = Eigen::Matrix<double, N, N>::Zero();
  Eigen::Matrix<double, N, N> correction_scale = Eigen::Matrix<double, N, N>::Identity();
  bool fallback = false;
};
template <int N>
Attenuation<N> hinfAttenuation(const Eigen::Matrix<double, N, N>& ekf_covariance,
                               const Eigen::Matrix<double, N, 1>& gamma, bool posterior_gain,
                               double max_inflation = std::numeric_limits<double>::infinity());
/// The same with a full Gamma^-1 (symmetric, positive semidefinite; zero: the EKF).
template <int N>
Attenuation<N> hinfAttenuationInformation(
    const Eigen::Matrix<double, N, N>& ekf_covariance,
    const Eigen::Matrix<double, N, N>& gamma_inverse, bool posterior_gain,
    double max_inflation = std::numeric_limits<double>::infinity());
/// Scale-free Gamma^-1 = theta P^-1 of a prior covariance P (zero when theta is 0 or P is
/// not positive definite).
template <int N>
Eigen::Matrix<double, N, N> relativeGammaInverse(const Eigen::Matrix<double, N, N>& prior,
                                                 double theta);

/// The H-infinity update of one measurement with attenuation Gamma =
/// diag(gamma): the EKF update followed by hinfAttenuation (gain =
/// correction_scale * K_ekf).
template <int N>
Correction<N> hinfCorrection(const Eigen::Matrix<double, N, N>& p,
                             const Eigen::Matrix<double, 2, N>& h, const Eigen::Matrix2d& r,
                             const Eigen::Matrix<double, N, 1>& gamma, bool posterior_gain,
                             double max_inflation = std::numeric_limits<double>::infinity());

/// The rule a FastSLAM-style filter applies to its pose proposal and landmark
/// updates.
class EstimatorRule {
 public:
  virtual ~EstimatorRule() = default;
  /// Pose proposal, after the EKF updates of every landmark matched in this
  /// step (FastSLAM 2.0's sequential proposal): the rule's change to that
  /// Gaussian, or nullopt-like `applies == false` for none. The H-infinity
  /// attenuation enters once per time step with all of the step's measurements,
  /// as in eq. 14, so it does not depend on how many landmarks were seen nor on
  /// their order.
  virtual bool attenuatesPose() const { return false; }
  /// prior_covariance: the motion prediction's, before any landmark measurement of the step
  /// (conditioned on the heading prior's measurement when that is on: heading_prior.h).
  virtual Attenuation<3> attenuatePose(const Eigen::Matrix3d& prior_covariance,
                                       const Eigen::Matrix3d& ekf_covariance) const;
  /// Landmark filter: landmark covariance p, d h / d landmark, measurement
  /// noise r.
  virtual Correction<2> correctLandmark(const Eigen::Matrix2d& p, const Eigen::Matrix2d& h,
                                        const Eigen::Matrix2d& r) const = 0;
  /// True: weigh particles by eq. 36 at the drawn pose instead of the marginal
  /// likelihood.
  virtual bool pointwiseWeights() const { return false; }
  /// Marginal weight N(v; H P H^T + k R): the factor k on the measurement's (and landmark's)
  /// part of the innovation covariance; 1 for FastSLAM 2.0.
  virtual double weightNoiseScale() const { return 1.0; }
  /// True: the filter collects the normalised innovations squared for observeInnovations.
  virtual bool learnsFromInnovations() const { return false; }
  /// After each filter step: v^T S^-1 v of every matched observation of every particle, S =
  /// H P H^T + (1 - theta()) L of the sequential proposal (L: the landmark's part, with R).
  virtual void observeInnovations(std::vector<double> /*nis*/) {}
  /// The attenuation theta in use (relative and adaptive modes), 0 otherwise.
  virtual double theta() const { return 0.0; }
  /// With the filter's reset: forgets what observeInnovations learnt.
  virtual void reset() {}
};

/// FastSLAM 2.0 (Montemerlo et al. 2003): EKF everywhere.
class EkfRule : public EstimatorRule {
 public:
  Correction<2> correctLandmark(const Eigen::Matrix2d& p, const Eigen::Matrix2d& h,
                                const Eigen::Matrix2d& r) const override;
};

/// H-infinity FastSLAM (Havangi et al.): H-infinity filters in the proposal and
/// the landmarks.
class HinfRule : public EstimatorRule {
 public:
  explicit HinfRule(const HinfOptions& options);
  bool attenuatesPose() const override { return true; }
  Attenuation<3> attenuatePose(const Eigen::Matrix3d& prior_covariance,
                               const Eigen::Matrix3d& ekf_covariance) const override;
  Correction<2> correctLandmark(const Eigen::Matrix2d& p, const Eigen::Matrix2d& h,
                                const Eigen::Matrix2d& r) const override;
  bool pointwiseWeights() const override { return options_.weight == "pointwise"; }
  double weightNoiseScale() const override;
  bool learnsFromInnovations() const override { return options_.mode == "adaptive"; }
  void observeInnovations(std::vector<double> nis) override;
  double theta() const override;
  void reset() override;

 private:
  const HinfOptions options_;
  // Adaptive mode: 1 - theta, the scale of R that the recent innovations were consistent with,
  // and the steps it covers.
  double noise_scale_ = 1.0;
  double mean_wanted_scale_ = 1.0;  // the running mean before clamping
  int nis_steps_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

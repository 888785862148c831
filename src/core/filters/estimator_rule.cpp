#include "rbpf_slam/core/filters/estimator_rule.h"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {
namespace {

template <int N>
Eigen::Matrix<double, N, N> symmetrize(const Eigen::Matrix<double, N, N>& m) {
  return 0.5 * (m + m.transpose());
}

template <int N>
bool positiveDefinite(const Eigen::Matrix<double, N, N>& m) {
  if (!m.allFinite()) return false;
  Eigen::LLT<Eigen::Matrix<double, N, N>> llt(m);
  return llt.info() == Eigen::Success;
}

}  // namespace

void validate(const HinfOptions& o) {
  // gamma may be +inf (the EKF), never zero, negative or NaN.
  const double inf = std::numeric_limits<double>::infinity();
  requireRange("hinf.gamma_position", o.gamma_position, 0.0, inf, true);
  requireRange("hinf.gamma_heading", o.gamma_heading, 0.0, inf, true);
  requireRange("hinf.gamma_landmark", o.gamma_landmark, 0.0, inf, true);
  requireRange("hinf.max_inflation", o.max_inflation, 1.0, inf);
  requireOneOf("hinf.mode", o.mode, {"relative", "absolute", "adaptive"});
  if (o.adapt_steps < 1 || o.adapt_steps > 100000) {
    throw std::invalid_argument("hinf.adapt_steps must be in [1, 100000], got " +
                                std::to_string(o.adapt_steps));
  }
  requireRange("hinf.theta_pose", o.theta_pose, 0.0, 1.0, false, true);
  requireRange("hinf.theta_landmark", o.theta_landmark, 0.0, 1.0, false, true);
  requireOneOf("hinf.proposal_covariance", o.proposal_covariance, {"hinf", "ekf", "scaled"});
  requireOneOf("hinf.gain", o.gain, {"posterior", "prior"});
  requireOneOf("hinf.weight", o.weight, {"pointwise", "marginal", "attenuated"});
  // 'scaled' is the EKF posterior at the noise scale 1 - theta, around the mean the posterior
  // gain gives: it needs a theta (not the absolute gammas) and that gain.
  if (o.proposal_covariance == "scaled" && (o.mode == "absolute" || o.gain != "posterior")) {
    throw std::invalid_argument(
        "hinf.proposal_covariance 'scaled' needs hinf.mode relative or adaptive and hinf.gain "
        "posterior, got mode '" + o.mode + "', gain '" + o.gain +
        "' (set hinf.proposal_covariance to ekf or hinf for those)");
  }
  // 'attenuated' weighs at the noise scale 1 - theta; the absolute gammas have no theta, and
  // the weight would silently be the plain marginal one.
  if (o.weight == "attenuated" && o.mode == "absolute") {
    throw std::invalid_argument(
        "hinf.weight 'attenuated' needs hinf.mode relative or adaptive (absolute has no theta; "
        "use weight marginal or pointwise with it)");
  }
}

template <int N>
Correction<N> ekfCorrection(const Eigen::Matrix<double, N, N>& p,
                            const Eigen::Matrix<double, 2, N>& h, const Eigen::Matrix2d& r) {
  Correction<N> c;
  const Eigen::Matrix2d s = h * p * h.transpose() + r;
  const double det = s.determinant();
  if (!(det > 0.0) || !std::isfinite(det)) return c;
  c.gain = p * h.transpose() * s.inverse();
  c.covariance = symmetrize<N>((Eigen::Matrix<double, N, N>::Identity() - c.gain * h) * p);
  c.ok = c.gain.allFinite() && c.covariance.allFinite();
  return c;
}

template <int N>
Attenuation<N> hinfAttenuationInformation(const Eigen::Matrix<double, N, N>& ekf_covariance,
                                          const Eigen::Matrix<double, N, N>& gamma_inverse,
                                          bool posterior_gain, double max_inflation) {
  Attenuation<N> a;
  a.covariance = ekf_covariance;
  if (gamma_inverse.isZero(0.0)) return a;
  const Eigen::Matrix<double, N, N> identity = Eigen::Matrix<double, N, N>::Identity();
  // P+ = (P_ekf^-1 - Gamma^-1)^-1 = P_ekf (I - Gamma^-1 P_ekf)^-1. With P_ekf = L L^T,
  // I - Gamma^-1 P_ekf is similar to the symmetric I - L^T Gamma^-1 L, whose smallest
  // eigenvalue is 1 / (the largest inflation of P+ over P_ekf): <= 0 means the H-infinity
  // condition fails, below 1 / max_inflation that Gamma is too close to its bound (the
  // corrections would be amplified without limit).
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(symmetrize<N>(ekf_covariance));
  if (llt.info() == Eigen::Success && gamma_inverse.allFinite()) {
    const Eigen::Matrix<double, N, N> l = llt.matrixL();
    const Eigen::Matrix<double, N, N> similar = identity - l.transpose() * gamma_inverse * l;
    const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>>(
                                symmetrize<N>(similar), Eigen::EigenvaluesOnly)
                                .eigenvalues()
                                .minCoeff();
    const Eigen::FullPivLU<Eigen::Matrix<double, N, N>> lu(identity -
                                                           gamma_inverse * ekf_covariance);
    if (smallest * max_inflation >= 1.0 && smallest > 0.0 && lu.isInvertible()) {
      const Eigen::Matrix<double, N, N> covariance =
          symmetrize<N>(ekf_covariance * lu.inverse());
      // The H-infinity condition: the new covariance must be positive definite.
      if (positiveDefinite<N>(covariance)) {
        a.covariance = covariance;
        if (posterior_gain) a.correction_scale = (identity - ekf_covariance * gamma_inverse).inverse();
        if (a.correction_scale.allFinite()) return a;
      }
    }
  }
  a.covariance = ekf_covariance;
  a.correction_scale.setIdentity();
  a.fallback = true;
  return a;
}

template <int N>
Attenuation<N> hinfAttenuation(const Eigen::Matrix<double, N, N>& ekf_covariance,
                               const Eigen::Matrix<double, N, 1>& gamma, bool posterior_gain,
                               double max_inflation) {
  if (gamma.array().isInf().all()) {
    Attenuation<N> a;
    a.covariance = ekf_covariance;
    return a;
  }
  const Eigen::Matrix<double, N, N> gamma_inv(gamma.cwiseInverse().asDiagonal());
  return hinfAttenuationInformation<N>(ekf_covariance, gamma_inv, posterior_gain, max_inflation);
}

template <int N>
Eigen::Matrix<double, N, N> relativeGammaInverse(const Eigen::Matrix<double, N, N>& prior,
                                                 double theta) {
  Eigen::Matrix<double, N, N> zero = Eigen::Matrix<double, N, N>::Zero();
  if (!(theta > 0.0)) return zero;
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(symmetrize<N>(prior));
  if (llt.info() != Eigen::Success) return zero;
  const Eigen::Matrix<double, N, N> information =
      llt.solve(Eigen::Matrix<double, N, N>::Identity());
  if (!information.allFinite()) return zero;
  return symmetrize<N>(theta * information);
}

template <int N>
Correction<N> hinfCorrection(const Eigen::Matrix<double, N, N>& p,
                             const Eigen::Matrix<double, 2, N>& h, const Eigen::Matrix2d& r,
                             const Eigen::Matrix<double, N, 1>& gamma, bool posterior_gain,
                             double max_inflation) {
  Correction<N> c = ekfCorrection<N>(p, h, r);
  if (!c.ok) return c;
  const Attenuation<N> a = hinfAttenuation<N>(c.covariance, gamma, posterior_gain, max_inflation);
  c.gain = a.correction_scale * c.gain;
  c.covariance = a.covariance;
  c.fallback = a.fallback;
  return c;
}

template Correction<2> ekfCorrection<2>(const Eigen::Matrix2d&, const Eigen::Matrix2d&,
                                        const Eigen::Matrix2d&);
template Correction<3> ekfCorrection<3>(const Eigen::Matrix3d&, const Eigen::Matrix<double, 2, 3>&,
                                        const Eigen::Matrix2d&);
template Attenuation<3> hinfAttenuation<3>(const Eigen::Matrix3d&, const Eigen::Vector3d&, bool,
                                           double);
template Attenuation<2> hinfAttenuationInformation<2>(const Eigen::Matrix2d&,
                                                      const Eigen::Matrix2d&, bool, double);
template Attenuation<3> hinfAttenuationInformation<3>(const Eigen::Matrix3d&,
                                                      const Eigen::Matrix3d&, bool, double);
template Eigen::Matrix2d relativeGammaInverse<2>(const Eigen::Matrix2d&, double);
template Eigen::Matrix3d relativeGammaInverse<3>(const Eigen::Matrix3d&, double);
template Correction<2> hinfCorrection<2>(const Eigen::Matrix2d&, const Eigen::Matrix2d&,
                                         const Eigen::Matrix2d&, const Eigen::Vector2d&, bool,
                                         double);
template Correction<3> hinfCorrection<3>(const Eigen::Matrix3d&, const Eigen::Matrix<double, 2, 3>&,
                                         const Eigen::Matrix2d&, const Eigen::Vector3d&, bool,
                                         double);

Attenuation<3> EstimatorRule::attenuatePose(const Eigen::Matrix3d& /*prior_covariance*/,
                                            const Eigen::Matrix3d& ekf_covariance) const {
  Attenuation<3> a;
  a.covariance = ekf_covariance;
  return a;
}

Correction<2> EkfRule::correctLandmark(const Eigen::Matrix2d& p, const Eigen::Matrix2d& h,
                                       const Eigen::Matrix2d& r) const {
  return ekfCorrection<2>(p, h, r);
}

// In relative mode P+^-1 = P_ekf^-1 - theta P^-1 >= (1 - theta) P_ekf^-1 (P_ekf <= P): the
// inflation is bounded by 1 / (1 - theta) by construction, so max_inflation does not apply.
constexpr double kNoInflationGuard = std::numeric_limits<double>::infinity();

HinfRule::HinfRule(const HinfOptions& options) : options_(options) { validate(options_); }

Attenuation<3> HinfRule::attenuatePose(const Eigen::Matrix3d& prior_covariance,
                                       const Eigen::Matrix3d& ekf_covariance) const {
  Attenuation<3> a;
  bool attenuated = false;  // a relative step applied (theta > 0, prior invertible, no fallback)
  if (options_.mode == "relative" || options_.mode == "adaptive") {
    const Eigen::Matrix3d gamma_inverse = relativeGammaInverse<3>(prior_covariance, theta());
    a = hinfAttenuationInformation<3>(ekf_covariance, gamma_inverse,
                                      options_.gain == "posterior", kNoInflationGuard);
    attenuated = !gamma_inverse.isZero() && !a.fallback;
  } else {
    const Eigen::Vector3d gamma(options_.gamma_position, options_.gamma_position,
                                options_.gamma_heading);
    a = hinfAttenuation<3>(ekf_covariance, gamma, options_.gain == "posterior",
                           options_.max_inflation);
  }
  if (options_.proposal_covariance == "ekf") a.covariance = ekf_covariance;
  // The EKF posterior with R scaled by 1 - theta, whose mean the H-infinity step gives:
  // P+^-1 = (1 - theta) P^-1 + H^T R^-1 H = (1 - theta) (P^-1 + H^T ((1 - theta) R)^-1 H),
  // R with the landmark's part, H stacked over the step's matches (up to the linearisation
  // points of the sequential updates). Without an attenuated step (theta 0, a singular prior,
  // a fallback) the mean is the EKF's and so is the draw.
  if (options_.proposal_covariance == "scaled") {
    a.covariance = attenuated ? Eigen::Matrix3d((1.0 - theta()) * a.covariance) : ekf_covariance;
  }
  return a;
}

double HinfRule::weightNoiseScale() const {
  if (options_.weight == "attenuated" && options_.mode != "absolute") return 1.0 - theta();
  return 1.0;
}

double HinfRule::theta() const {
  if (options_.mode == "relative") return options_.theta_pose;
  if (options_.mode != "adaptive") return 0.0;
  return 1.0 - noise_scale_;
}

void HinfRule::reset() {
  noise_scale_ = mean_wanted_scale_ = 1.0;
  nis_steps_ = 0;
}

void HinfRule::observeInnovations(std::vector<double> nis) {
  nis.erase(std::remove_if(nis.begin(), nis.end(), [](double v) { return !std::isfinite(v); }),
            nis.end());
  if (options_.mode != "adaptive" || nis.empty()) return;
  // The step's mean NIS against its expectation 2 (chi2 with 2 dof): the scale of R (times the
  // one in use) at which the innovations would be consistent. (The median was tried: heavy
  // tails across particles then read as an overstated R, and a right R got attenuated; a loop
  // closing on a drifted map does lower the mean's theta for a while, e.g. 0.97 -> 0.87 on the
  // car, docs/results.md.)
  double sum = 0.0;
  for (double v : nis) sum += v;
  const double wanted = noise_scale_ * 0.5 * sum / static_cast<double>(nis.size());
  // A running mean over the first adapt_steps steps, then an exponential one of that length,
  // taken before clamping (clamping each step's value would bias it).
  nis_steps_ = std::min(nis_steps_ + 1, options_.adapt_steps);
  mean_wanted_scale_ += (wanted - mean_wanted_scale_) / nis_steps_;
  noise_scale_ = std::clamp(mean_wanted_scale_, 1.0 - options_.theta_pose, 1.0);
}

Correction<2> HinfRule::correctLandmark(const Eigen::Matrix2d& p, const Eigen::Matrix2d& h,
                                        const Eigen::Matrix2d& r) const {
  if (options_.mode == "relative" || options_.mode == "adaptive") {
    Correction<2> c = ekfCorrection<2>(p, h, r);
    if (!c.ok) return c;
    const Attenuation<2> a = hinfAttenuationInformation<2>(
        c.covariance, relativeGammaInverse<2>(p, options_.theta_landmark),
        options_.gain == "posterior", kNoInflationGuard);
    c.gain = a.correction_scale * c.gain;
    c.covariance = a.covariance;
    c.fallback = a.fallback;
    return c;
  }
  return hinfCorrection<2>(p, h, r, Eigen::Vector2d::Constant(options_.gamma_landmark),
                           options_.gain == "posterior", options_.max_inflation);
}

}  // namespace core
}  // namespace rbpf_slam

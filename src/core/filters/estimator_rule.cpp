#include "rbpf_slam/core/filters/estimator_rule.h"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>
#include <string>

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
  if (!(o.gamma_position > 0.0)) {
    throw std::invalid_argument("hinf.gamma_position = " + std::to_string(o.gamma_position) +
                                " must be > 0 (infinity: the EKF)");
  }
  if (!(o.gamma_heading > 0.0)) {
    throw std::invalid_argument("hinf.gamma_heading = " + std::to_string(o.gamma_heading) +
                                " must be > 0 (infinity: the EKF)");
  }
  if (!(o.gamma_landmark > 0.0)) {
    throw std::invalid_argument("hinf.gamma_landmark = " + std::to_string(o.gamma_landmark) +
                                " must be > 0 (infinity: the EKF)");
  }
  if (!(o.max_inflation >= 1.0)) {
    throw std::invalid_argument("hinf.max_inflation = " + std::to_string(o.max_inflation) +
                                " must be >= 1");
  }
  if (o.gain != "posterior" && o.gain != "prior") {
    throw std::invalid_argument("hinf.gain = '" + o.gain + "' must be posterior or prior");
  }
  if (o.weight != "pointwise" && o.weight != "marginal") {
    throw std::invalid_argument("hinf.weight = '" + o.weight + "' must be pointwise or marginal");
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
Attenuation<N> hinfAttenuation(const Eigen::Matrix<double, N, N>& ekf_covariance,
                               const Eigen::Matrix<double, N, 1>& gamma, bool posterior_gain,
                               double max_inflation) {
  Attenuation<N> a;
  a.covariance = ekf_covariance;
  if (gamma.array().isInf().all()) return a;
  const Eigen::Matrix<double, N, N> gamma_inv(gamma.cwiseInverse().asDiagonal());
  const Eigen::Matrix<double, N, N> identity = Eigen::Matrix<double, N, N>::Identity();
  // I - Gamma^-1 P_ekf is similar to the symmetric I - Gamma^-1/2 P_ekf Gamma^-1/2, whose
  // smallest eigenvalue is 1 / (the largest inflation of P+ over P_ekf): <= 0 means the
  // H-infinity condition fails, below 1 / max_inflation that gamma is too close to its bound
  // (the corrections would be amplified without limit).
  const Eigen::Matrix<double, N, N> root_inv(gamma.cwiseInverse().cwiseSqrt().asDiagonal());
  const Eigen::Matrix<double, N, N> similar = identity - root_inv * ekf_covariance * root_inv;
  const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>>(
                              symmetrize<N>(similar), Eigen::EigenvaluesOnly)
                              .eigenvalues()
                              .minCoeff();
  const Eigen::FullPivLU<Eigen::Matrix<double, N, N>> lu(identity - gamma_inv * ekf_covariance);
  if (smallest * max_inflation >= 1.0 && lu.isInvertible()) {
    const Eigen::Matrix<double, N, N> covariance = symmetrize<N>(ekf_covariance * lu.inverse());
    // The H-infinity condition: the new covariance must be positive definite.
    if (positiveDefinite<N>(covariance)) {
      a.covariance = covariance;
      if (posterior_gain) a.correction_scale = (identity - ekf_covariance * gamma_inv).inverse();
      if (a.correction_scale.allFinite()) return a;
    }
  }
  a.covariance = ekf_covariance;
  a.correction_scale.setIdentity();
  a.fallback = true;
  return a;
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
template Correction<2> hinfCorrection<2>(const Eigen::Matrix2d&, const Eigen::Matrix2d&,
                                         const Eigen::Matrix2d&, const Eigen::Vector2d&, bool,
                                         double);
template Correction<3> hinfCorrection<3>(const Eigen::Matrix3d&, const Eigen::Matrix<double, 2, 3>&,
                                         const Eigen::Matrix2d&, const Eigen::Vector3d&, bool,
                                         double);

Attenuation<3> EstimatorRule::attenuatePose(const Eigen::Matrix3d& ekf_covariance) const {
  Attenuation<3> a;
  a.covariance = ekf_covariance;
  return a;
}

Correction<2> EkfRule::correctLandmark(const Eigen::Matrix2d& p, const Eigen::Matrix2d& h,
                                       const Eigen::Matrix2d& r) const {
  return ekfCorrection<2>(p, h, r);
}

HinfRule::HinfRule(const HinfOptions& options) : options_(options) { validate(options_); }

Attenuation<3> HinfRule::attenuatePose(const Eigen::Matrix3d& ekf_covariance) const {
  const Eigen::Vector3d gamma(options_.gamma_position, options_.gamma_position,
                              options_.gamma_heading);
  return hinfAttenuation<3>(ekf_covariance, gamma, options_.gain == "posterior",
                            options_.max_inflation);
}

Correction<2> HinfRule::correctLandmark(const Eigen::Matrix2d& p, const Eigen::Matrix2d& h,
                                        const Eigen::Matrix2d& r) const {
  return hinfCorrection<2>(p, h, r, Eigen::Vector2d::Constant(options_.gamma_landmark),
                           options_.gain == "posterior", options_.max_inflation);
}

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Seeded randomness owned by each filter; no global generator anywhere in the package.

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>

namespace rbpf_slam {
namespace core {

using Rng = std::mt19937_64;

/// One N(0, sigma^2) draw.
inline double sampleGaussian(Rng& rng, double sigma) {
  if (sigma <= 0.0) return 0.0;
  return std::normal_distribution<double>(0.0, sigma)(rng);
}

/// One U[0, 1) draw.
inline double sampleUniform(Rng& rng) {
  return std::uniform_real_distribution<double>(0.0, 1.0)(rng);
}

/// A pose covariance (x, y, yaw) to draw particles from: finite, symmetric and positive
/// semi-definite (zero: an exact pose). A positive diagonal is not enough: xx = yy = 0.25 with
/// xy = 1 has a negative eigenvalue, and sampleMultivariate would then add jitter up to ~1 to
/// every variance without a word. Every filter's resetPose checks this.
bool poseCovarianceUsable(const Eigen::Matrix3d& covariance);
/// Why poseCovarianceUsable refuses covariance ("is not symmetric (xy ... / yx ...)", ...), or
/// "" when it is usable.
std::string poseCovarianceProblem(const Eigen::Matrix3d& covariance);
/// The spread rviz's 2D Pose Estimate sends (0.25 m^2, 0.25 m^2, 0.0685 rad^2): the default
/// uncertainty of a start pose given without one.
inline Eigen::Matrix3d defaultStartCovariance() {
  return Eigen::Vector3d(0.25, 0.25, 0.0685).asDiagonal();
}

/// One draw from N(mean, cov) for a 2x2 or 3x3 covariance (Cholesky; jitter when semidefinite).
template <int N>
Eigen::Matrix<double, N, 1> sampleMultivariate(Rng& rng, const Eigen::Matrix<double, N, 1>& mean,
                                               const Eigen::Matrix<double, N, N>& cov);

}  // namespace core
}  // namespace rbpf_slam

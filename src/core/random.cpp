#include "rbpf_slam/core/random.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace rbpf_slam {
namespace core {

bool poseCovarianceUsable(const Eigen::Matrix3d& covariance) {
  if (!covariance.allFinite()) return false;
  const double scale = covariance.cwiseAbs().maxCoeff();
  if (scale == 0.0) return true;  // an exact pose
  if ((covariance - covariance.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance, Eigen::EigenvaluesOnly);
  return solver.info() == Eigen::Success && solver.eigenvalues().minCoeff() >= -1e-12 * scale;
}

template <int N>
Eigen::Matrix<double, N, 1> sampleMultivariate(Rng& rng, const Eigen::Matrix<double, N, 1>& mean,
                                               const Eigen::Matrix<double, N, N>& cov) {
  using Matrix = Eigen::Matrix<double, N, N>;
  const Matrix symmetric = 0.5 * (cov + cov.transpose());
  Eigen::LLT<Matrix> llt(symmetric);
  Matrix jitter = Matrix::Identity() * 1e-12;
  while (llt.info() != Eigen::Success && jitter(0, 0) < 1.0) {
    llt.compute(symmetric + jitter);
    jitter *= 10.0;
  }
  Eigen::Matrix<double, N, 1> standard;
  for (int i = 0; i < N; ++i) standard(i) = sampleGaussian(rng, 1.0);
  if (llt.info() != Eigen::Success) return mean;
  return mean + llt.matrixL() * standard;
}

template Eigen::Matrix<double, 2, 1> sampleMultivariate<2>(Rng&, const Eigen::Matrix<double, 2, 1>&,
                                                           const Eigen::Matrix<double, 2, 2>&);
template Eigen::Matrix<double, 3, 1> sampleMultivariate<3>(Rng&, const Eigen::Matrix<double, 3, 1>&,
                                                           const Eigen::Matrix<double, 3, 3>&);

}  // namespace core
}  // namespace rbpf_slam

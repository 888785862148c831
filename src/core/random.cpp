#include "rbpf_slam/core/random.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <sstream>

namespace rbpf_slam {
namespace core {

std::string poseCovarianceProblem(const Eigen::Matrix3d& covariance) {
  if (!covariance.allFinite()) return "is not finite";
  const double scale = covariance.cwiseAbs().maxCoeff();
  if (scale == 0.0) return "";  // an exact pose
  // 1e-6 of the largest entry: a covariance filled in float32 (xy and yx computed apart) differs
  // by ~1e-7 and is accepted; every resetPose uses the symmetric part.
  const Eigen::Matrix3d asymmetry = covariance - covariance.transpose();
  if (asymmetry.cwiseAbs().maxCoeff() > 1e-6 * scale) {
    std::ostringstream out;
    out << "is not symmetric (xy " << covariance(0, 1) << " / yx " << covariance(1, 0) << ", x-yaw "
        << covariance(0, 2) << " / yaw-x " << covariance(2, 0) << ", y-yaw " << covariance(1, 2)
        << " / yaw-y " << covariance(2, 1) << ")";
    return out.str();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance, Eigen::EigenvaluesOnly);
  const double smallest = solver.eigenvalues().minCoeff();
  if (solver.info() != Eigen::Success || smallest < -1e-12 * scale) {
    std::ostringstream out;
    out << "is not positive semi-definite (smallest eigenvalue " << smallest << ")";
    return out.str();
  }
  return "";
}

bool poseCovarianceUsable(const Eigen::Matrix3d& covariance) {
  return poseCovarianceProblem(covariance).empty();
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

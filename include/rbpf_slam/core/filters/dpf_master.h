#pragma once
// The master filter of the distributed particle filter (Pei et al. 2014, section 3.2): fuses
// the local filters' pose estimates with weights from their innovations, their Neff, or a mix
// of both, and isolates a local filter whose innovation or Neff shows a fault.

#include <vector>

#include "rbpf_slam/core/filters/dpf_exchange.h"
#include "rbpf_slam/core/filters/dpf_options.h"

namespace rbpf_slam {
namespace core {

/// Mahalanobis^2 under `covariance` of r from the nearest point of the segment from 0 to v
/// (the master's process check: 0 is its prediction, v a local's own last posterior moved by
/// the odometry, r the local's prior).
double segmentMahalanobis(const Eigen::Vector3d& r, const Eigen::Vector3d& v,
                          const Eigen::Matrix3d& covariance);

/// Innovation method (Won et al., the paper's eq. 4 reference): w_i proportional to
/// 1 / (mean NIS of local i); a larger innovation means a worse local filter.
std::vector<double> innovationWeights(const std::vector<double>& mean_nis);
/// Neff method (eqs. 15-16): w_i proportional to Neff_i / particles_i.
std::vector<double> neffWeights(const std::vector<double>& neff_ratio);
/// Mixed (the paper's proposal): alpha * innovation weights + (1 - alpha) * Neff weights.
std::vector<double> mixedWeights(const std::vector<double>& innovation,
                                 const std::vector<double>& neff, double alpha);

/// The information a local filter gained in one step, (posterior_info - prior_info), and its
/// information vector, both restricted to the eigendirections of the difference with a
/// positive eigenvalue (the vector's components elsewhere are dropped, not divided by ~0);
/// `not_gained` is the projector onto the other directions.
void gainedInformation(const Eigen::Matrix3d& posterior_info, const Eigen::Matrix3d& prior_info,
                       const Eigen::Vector3d& vector, Eigen::Matrix3d* information,
                       Eigen::Vector3d* projected, Eigen::Matrix3d* not_gained);

class DpfMaster {
 public:
  explicit DpfMaster(const DpfOptions& options);
  /// Starts at initial_pose with this covariance (zero: exactly there).
  void reset(const Pose2& initial_pose,
             const Eigen::Matrix3d& covariance = Eigen::Matrix3d::Zero());
  /// Fuses one step's estimates (one per local filter, any order); `motion` is the step's
  /// odometry increment (the master's prior is its last mean moved by it). Throws
  /// std::invalid_argument when an estimate is missing, duplicated or from another step.
  DpfMasterOutput fuse(long step, const MotionInput& motion,
                       const std::vector<DpfLocalEstimate>& estimates);
  const std::vector<DpfLocalHealth>& health() const { return health_; }
  const DpfMasterOutput& last() const { return last_; }

 private:
  /// Information fusion: the master's prior plus, for each local filter, its trust
  /// (min(1, N w_i); 0 for all when every weight is 0) times the information it gained this
  /// step (posterior minus prior, in information form, gainedInformation), plus, along the
  /// directions where a local gained no information, w_i times the move of its posterior
  /// mean from its prior mean. Returns false when the result is not positive definite.
  bool fuseInformation(const Pose2& prior_mean, const std::vector<const DpfLocalEstimate*>& locals,
                       const std::vector<double>& weights, const std::vector<double>& trusts,
                       DpfMasterOutput* out) const;

  const DpfOptions options_;
  std::vector<DpfLocalHealth> health_;
  DpfMasterOutput last_;
};

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// EKF-SLAM over line and point landmarks: one Gaussian over (x, y, phi, landmark 1, ...,
// landmark L), the baseline of Yuen and MacDonald, with their WAD association and new-obstacle
// detection. Each matched feature is an O(n^2) covariance update (n = 3 + 2L); a new landmark
// augments the state (O(n^2) with the copy).

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/line_association.h"
#include "rbpf_slam/core/filters/observation.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/motion/motion_model.h"

namespace rbpf_slam {
namespace core {

class EkfSlam : public SlamFilter {
 public:
  explicit EkfSlam(const FilterOptions& options);

  std::string variant() const override { return "ekf_slam"; }
  void reset(const Pose2& initial_pose) override;
  void predict(const MotionInput& motion) override;
  UpdateStats update(const FeatureSet& features) override;
  PoseEstimate estimate() const override;
  std::vector<LandmarkEstimate> landmarks() const override;
  std::vector<WeightedPose> particles() const override;
  FilterStats stats() const override;
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override;
  bool loadMap(const std::vector<LandmarkEstimate>& landmarks) override;

  const Eigen::VectorXd& state() const { return state_; }
  const Eigen::MatrixXd& covariance() const { return covariance_; }

 private:
  struct LandmarkInfo {
    int id = -1;
    LandmarkType type = LandmarkType::kLine;
    double extent_min = 0.0, extent_max = 0.0;
    int observations = 1;
  };
  GlobalFeature inMap(const Observation& o, const Pose2& pose, int source) const;
  void applyMotion();
  /// One EKF correction of landmark i by an observation; false when gated out or singular.
  bool correct(int i, const Observation& o);
  /// Appends a landmark initialised from an observation at the current pose.
  void augment(const Observation& o, const GlobalFeature& g);
  void appendLandmark(const Eigen::Vector2d& mean, const Eigen::Matrix2d& cov,
                      const Eigen::Matrix<double, 2, 3>& cross_pose_jacobian, bool correlated);
  void extendLine(int i, const GlobalFeature& g);
  Pose2 pose() const { return state_.head<3>(); }
  int landmarkCount() const { return info_.size(); }

  const FilterOptions options_;
  std::unique_ptr<MotionModel> motion_model_;
  Eigen::VectorXd state_;
  Eigen::MatrixXd covariance_;
  std::vector<LandmarkInfo> info_;
  PendingMotion pending_motion_;
  int next_landmark_id_ = 0;
  FilterStats stats_;
};

}  // namespace core
}  // namespace rbpf_slam

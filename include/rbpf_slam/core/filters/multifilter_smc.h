#pragma once
// Line-based multi-filter SMC SLAM (Yuen and MacDonald): one SIR filter for the robot pose
// (Psi_0) and one small SIR filter per landmark (Psi_1..L). The map is shared by every robot
// particle, so an update costs O(robot particles x features + features x landmarks +
// matched landmarks x landmark particles): linear in the number of landmarks.

#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/line_association.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/motion/motion_model.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {

/// A SIR filter over one time-invariant landmark: a line (rho, theta) or a point (x, y) in
/// the map frame. Its system model is the identity (plus roughening after resampling), its
/// likelihood the Laplace density of the dissimilarity to the observation.
class LandmarkParticleFilter {
 public:
  /// Particles drawn from N(detection, diag(sigma^2)); uniform weights. A line's spread is
  /// drawn as seen from `seen_from` (its rho measured from there, lineSeenFrom), so that the
  /// theta spread turns the line about the point nearest seen_from, not the map origin.
  LandmarkParticleFilter(int id, LandmarkType type, const Eigen::Vector2d& detection,
                         const Eigen::Vector2d& sigma, int particles, Rng& rng,
                         const Eigen::Vector2d& seen_from = Eigen::Vector2d::Zero());

  /// Particles drawn again from N(mean, covariance), re-centred on mean (a loaded map). The
  /// covariance is symmetrised and made positive semi-definite; no spread when not finite.
  void redraw(const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance, Rng& rng);

  /// One SIR step with an observation in the map frame: weight by exp(-d / c_m2), resample
  /// (low variance), roughen. Returns false (and leaves the filter as it was) when every
  /// weight underflows. seen_from: where lines' rho is measured (wadCentre).
  bool update(const Eigen::Vector2d& observed, const Eigen::Vector2d& seen_from,
              const WadAssociationOptions& association, const MultiFilterOptions& options,
              Rng& rng);

  int id() const { return id_; }
  LandmarkType type() const { return type_; }
  /// The particles' centroid (circular mean for theta): the filter's estimate phi_bar.
  const Eigen::Vector2d& centroid() const { return centroid_; }
  Eigen::Matrix2d covariance() const;
  const std::vector<Eigen::Vector2d>& particles() const { return particles_; }
  int observations() const { return observations_; }

  /// Grows a line's observed extent by a segment (map frame); a point has none.
  void extendBy(const Eigen::Vector2d& start, const Eigen::Vector2d& end);
  LandmarkEstimate toEstimate() const;

 private:
  void computeCentroid();

  int id_;
  LandmarkType type_;
  std::vector<Eigen::Vector2d> particles_;
  Eigen::Vector2d centroid_ = Eigen::Vector2d::Zero();
  double extent_min_ = 0.0, extent_max_ = 0.0;
  bool has_extent_ = false;
  int observations_ = 1;
};

class MultiFilterSmc : public SlamFilter {
 public:
  explicit MultiFilterSmc(const FilterOptions& options);

  std::string variant() const override { return "multifilter_smc"; }
  void reset(const Pose2& initial_pose) override;
  void predict(const MotionInput& motion) override;
  UpdateStats update(const FeatureSet& features) override;
  PoseEstimate estimate() const override;
  std::vector<LandmarkEstimate> landmarks() const override;
  std::vector<WeightedPose> particles() const override;
  FilterStats stats() const override;
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override;
  bool loadMap(const std::vector<LandmarkEstimate>& landmarks) override;
  bool setMapping(bool enabled) override;

  const std::vector<LandmarkParticleFilter>& landmarkFilters() const { return filters_; }

 private:
  /// A finite feature of the current scan, in the robot frame.
  struct LocalFeature {
    LandmarkType type = LandmarkType::kLine;
    LineFeature line;
    Eigen::Vector2d range_bearing = Eigen::Vector2d::Zero();
  };
  std::vector<LocalFeature> prepare(const FeatureSet& features, int* rejected) const;
  GlobalFeature inMap(const LocalFeature& feature, const Pose2& pose, int source) const;
  /// Localisation: sample the motion model, weight each particle by the Laplace likelihood
  /// of its mean dissimilarity to the map, resample when Neff is low.
  void updateRobot(const std::vector<LocalFeature>& features, UpdateStats* stats);
  /// Map building at the mean pose: association, new filters, landmark filter updates.
  void updateMap(const std::vector<LocalFeature>& features, UpdateStats* stats);
  void addFilter(const GlobalFeature& feature, const Eigen::Vector2d& centre);

  const FilterOptions options_;
  std::unique_ptr<MotionModel> motion_model_;
  Rng rng_;
  std::vector<Pose2> robot_;
  std::vector<double> weights_;  // normalised, same order as robot_
  std::vector<LandmarkParticleFilter> filters_;
  PendingMotion pending_motion_;
  bool mapping_ = true;
  int next_landmark_id_ = 0;
  FilterStats stats_;
};

/// Weighted mean (circular for the heading) and covariance of a set of poses.
PoseEstimate weightedPoseMean(const std::vector<Pose2>& poses, const std::vector<double>& weights);

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Runs a filter in coordinates centred on where the run started, and reports in the map frame.
//
// Every line-landmark variant keeps and associates lines by their map-frame (rho, theta), and a
// heading error of d rad moves a line's rho by about d times the robot's distance from the map
// origin. With the map frame equal to the odometry frame, the same walls seen by the same robot
// then associate differently depending on where the odometry happens to start (a CARMEN log's
// odometry starts 100 m from its origin): the results depended on an arbitrary offset. This
// wrapper moves the filter's origin to the position of the pose it is reset at (the first
// frame's), so the filter sees every run as starting at (0, 0) with the start heading kept
// (absolute headings stay meaningful: heading priors, compasses). Every pose, landmark, path
// and grid the wrapper reports, and every pose and map it is given, is in the map frame: the
// shift is invisible outside. A shift only (no rotation) keeps covariances of poses and
// points unchanged; a line's (rho, theta) covariance is carried through the shift's Jacobian.

#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace core {

/// A landmark moved by shift (map frame = filter frame + shift): a point's mean and a line's
/// extent move by it; a line's rho changes by shift . n(theta) (normal form kept: rho >= 0),
/// and its covariance is carried through that map's Jacobian.
LandmarkEstimate shiftLandmark(const LandmarkEstimate& landmark, const Eigen::Vector2d& shift);

class AnchoredFilter : public SlamFilter {
 public:
  /// Wraps inner (not null). The origin is set by reset().
  explicit AnchoredFilter(std::unique_ptr<SlamFilter> inner);

  /// The wrapped filter, whose outputs are in its own (shifted) frame.
  const SlamFilter& inner() const { return *inner_; }
  /// Where the filter's origin lies in the map frame (the last reset()'s position).
  const Eigen::Vector2d& origin() const { return *origin_; }

  std::string variant() const override { return inner_->variant(); }
  /// Puts the filter's origin at initial_pose's position, the inner filter at (0, 0, heading).
  void reset(const Pose2& initial_pose = Pose2::Zero()) override;
  void predict(const MotionInput& motion) override;
  UpdateStats update(const FeatureSet& features) override;
  PoseEstimate estimate() const override;
  std::vector<LandmarkEstimate> landmarks() const override;
  std::vector<WeightedPose> particles() const override;
  FilterStats stats() const override { return inner_->stats(); }
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override;
  bool loadMap(const std::vector<LandmarkEstimate>& landmarks) override;
  bool loadGridMap(const GridMapData& map) override;
  bool spreadOverMap() override { return mutableInner().spreadOverMap(); }
  bool canSpreadOverMap(std::string* why) const override { return inner_->canSpreadOverMap(why); }
  bool stillSpread() const override { return inner_->stillSpread(); }
  double gridResolution() const override { return inner_->gridResolution(); }
  bool setMapping(bool enabled) override;
  bool occupancyGrid(GridMapData& out) const override;
  std::vector<Pose2> bestPath() const override;
  std::vector<Pose2> bestPathSample(std::size_t max_poses, std::size_t* length) const override;
  /// The members of a wrapped ensemble, each reported in the map frame too (read-only views,
  /// built on first use; like every SlamFilter, not to be called from two threads at once).
  int members() const override { return inner_->members(); }
  const SlamFilter& member(int k) const override;
  int leader() const override { return inner_->leader(); }
  bool usesLandmarkFeatures() const override { return inner_->usesLandmarkFeatures(); }

 private:
  /// A read-only view of a member of the wrapped ensemble, sharing the owner's origin.
  AnchoredFilter(const SlamFilter* member, std::shared_ptr<Eigen::Vector2d> origin);
  Pose2 toMap(const Pose2& pose) const;
  Pose2 toFilter(const Pose2& pose) const;
  std::vector<Pose2> toMap(std::vector<Pose2> path) const;
  SlamFilter& mutableInner();

  std::unique_ptr<SlamFilter> owned_;  // null for a member view, which cannot be changed
  const SlamFilter* inner_;
  std::shared_ptr<Eigen::Vector2d> origin_;
  mutable std::vector<std::unique_ptr<AnchoredFilter>> member_views_;
};

}  // namespace core
}  // namespace rbpf_slam

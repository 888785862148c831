#include "rbpf_slam/core/filters/anchored_filter.h"

#include <cmath>
#include <stdexcept>
#include <utility>

#include "rbpf_slam/core/filters/line_association.h"
#include "rbpf_slam/core/grid/grid_map_data.h"

namespace rbpf_slam {
namespace core {

LandmarkEstimate shiftLandmark(const LandmarkEstimate& landmark, const Eigen::Vector2d& shift) {
  LandmarkEstimate out = landmark;
  out.start += shift;
  out.end += shift;
  if (landmark.type == LandmarkType::kPoint) {
    out.mean += shift;
    return out;
  }
  const double theta = landmark.mean.y();
  const double c = std::cos(theta), s = std::sin(theta);
  double rho = lineSeenFrom(landmark.mean, -shift).x();  // rho + shift . n(theta)
  double new_theta = theta;
  Eigen::Matrix2d jacobian;  // d(rho', theta') / d(rho, theta)
  jacobian << 1.0, -shift.x() * s + shift.y() * c, 0.0, 1.0;
  if (rho < 0.0) jacobian.row(0) *= -1.0;  // normal form flips rho's sign
  normalizeLine(rho, new_theta);
  out.mean = Eigen::Vector2d(rho, new_theta);
  out.covariance = (jacobian * landmark.covariance * jacobian.transpose()).eval();
  return out;
}

AnchoredFilter::AnchoredFilter(std::unique_ptr<SlamFilter> inner)
    : owned_(std::move(inner)),
      inner_(owned_.get()),
      origin_(std::make_shared<Eigen::Vector2d>(Eigen::Vector2d::Zero())) {
  if (!inner_) throw std::invalid_argument("AnchoredFilter needs a filter to wrap");
}

AnchoredFilter::AnchoredFilter(const SlamFilter* member, std::shared_ptr<Eigen::Vector2d> origin)
    : inner_(member), origin_(std::move(origin)) {}

SlamFilter& AnchoredFilter::mutableInner() {
  if (!owned_) throw std::logic_error("an ensemble member's view cannot be changed");
  return *owned_;
}

Pose2 AnchoredFilter::toMap(const Pose2& pose) const {
  return Pose2(pose.x() + origin_->x(), pose.y() + origin_->y(), pose.z());
}

Pose2 AnchoredFilter::toFilter(const Pose2& pose) const {
  return Pose2(pose.x() - origin_->x(), pose.y() - origin_->y(), pose.z());
}

std::vector<Pose2> AnchoredFilter::toMap(std::vector<Pose2> path) const {
  for (Pose2& pose : path) pose = toMap(pose);
  return path;
}

void AnchoredFilter::reset(const Pose2& initial_pose) {
  SlamFilter& inner = mutableInner();
  // A non-finite start is the inner filter's to refuse or carry; the origin stays finite.
  *origin_ = initial_pose.head<2>().allFinite() ? Eigen::Vector2d(initial_pose.head<2>())
                                                : Eigen::Vector2d::Zero();
  inner.reset(toFilter(initial_pose));
}

void AnchoredFilter::predict(const MotionInput& motion) { mutableInner().predict(motion); }

UpdateStats AnchoredFilter::update(const FeatureSet& features) {
  return mutableInner().update(features);
}

PoseEstimate AnchoredFilter::estimate() const {
  PoseEstimate estimate = inner_->estimate();
  estimate.mean = toMap(estimate.mean);
  return estimate;
}

std::vector<LandmarkEstimate> AnchoredFilter::landmarks() const {
  std::vector<LandmarkEstimate> out = inner_->landmarks();
  for (LandmarkEstimate& landmark : out) landmark = shiftLandmark(landmark, *origin_);
  return out;
}

std::vector<WeightedPose> AnchoredFilter::particles() const {
  std::vector<WeightedPose> out = inner_->particles();
  for (WeightedPose& particle : out) particle.pose = toMap(particle.pose);
  return out;
}

bool AnchoredFilter::resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) {
  return mutableInner().resetPose(toFilter(pose), covariance);
}

bool AnchoredFilter::loadMap(const std::vector<LandmarkEstimate>& landmarks) {
  std::vector<LandmarkEstimate> shifted;
  shifted.reserve(landmarks.size());
  for (const LandmarkEstimate& landmark : landmarks) {
    shifted.push_back(shiftLandmark(landmark, -*origin_));
  }
  return mutableInner().loadMap(shifted);
}

bool AnchoredFilter::loadGridMap(const GridMapData& map) {
  GridMapData shifted = map;
  shifted.origin_x_m -= origin_->x();
  shifted.origin_y_m -= origin_->y();
  return mutableInner().loadGridMap(shifted);
}

bool AnchoredFilter::setMapping(bool enabled) { return mutableInner().setMapping(enabled); }

bool AnchoredFilter::occupancyGrid(GridMapData& out) const {
  if (!inner_->occupancyGrid(out)) return false;
  out.origin_x_m += origin_->x();
  out.origin_y_m += origin_->y();
  return true;
}

std::vector<Pose2> AnchoredFilter::bestPath() const { return toMap(inner_->bestPath()); }

std::vector<Pose2> AnchoredFilter::bestPathSample(std::size_t max_poses,
                                                  std::size_t* length) const {
  return toMap(inner_->bestPathSample(max_poses, length));
}

const SlamFilter& AnchoredFilter::member(int k) const {
  if (inner_->members() <= 1) return *this;
  const SlamFilter& member = inner_->member(k);
  if (static_cast<int>(member_views_.size()) != inner_->members()) {
    member_views_.clear();
    member_views_.resize(inner_->members());
  }
  std::unique_ptr<AnchoredFilter>& view = member_views_.at(k);
  if (!view || view->inner_ != &member) {
    view.reset(new AnchoredFilter(&member, origin_));
  }
  return *view;
}

}  // namespace core
}  // namespace rbpf_slam

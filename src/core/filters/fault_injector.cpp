#include "rbpf_slam/core/filters/fault_injector.h"

#include <utility>

namespace rbpf_slam {
namespace core {
namespace {

/// Wraps a filter: predict() adds the disturbance of the step the next update() completes.
class FaultInjectedFilter : public SlamFilter {
 public:
  FaultInjectedFilter(std::unique_ptr<SlamFilter> inner, const FilterOptions& options)
      : inner_(std::move(inner)), injector_(options.dpf.fault, options.seed) {}

  std::string variant() const override { return inner_->variant(); }
  void reset(const Pose2& initial_pose) override {
    inner_->reset(initial_pose);
    injector_.reset();
    step_ = 0;
  }
  void predict(const MotionInput& motion) override {
    MotionInput disturbed = motion;
    disturbed.delta += injector_.disturbance(step_ + 1);
    disturbed.delta.z() = wrapAngle(disturbed.delta.z());
    inner_->predict(disturbed);
  }
  UpdateStats update(const FeatureSet& features) override {
    ++step_;
    return inner_->update(features);
  }
  PoseEstimate estimate() const override { return inner_->estimate(); }
  std::vector<LandmarkEstimate> landmarks() const override { return inner_->landmarks(); }
  std::vector<WeightedPose> particles() const override { return inner_->particles(); }
  FilterStats stats() const override { return inner_->stats(); }
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override {
    return inner_->resetPose(pose, covariance);
  }
  bool loadMap(const std::vector<LandmarkEstimate>& landmarks) override {
    return inner_->loadMap(landmarks);
  }
  bool loadGridMap(const GridMapData& map) override { return inner_->loadGridMap(map); }
  bool spreadOverMap() override { return inner_->spreadOverMap(); }
  bool canSpreadOverMap(std::string* why) const override { return inner_->canSpreadOverMap(why); }
  bool stillSpread() const override { return inner_->stillSpread(); }
  double gridResolution() const override { return inner_->gridResolution(); }
  bool setMapping(bool enabled) override { return inner_->setMapping(enabled); }
  bool occupancyGrid(GridMapData& out) const override { return inner_->occupancyGrid(out); }
  std::vector<Pose2> bestPath() const override { return inner_->bestPath(); }
  std::vector<Pose2> bestPathSample(size_t max_poses, size_t* length) const override {
    return inner_->bestPathSample(max_poses, length);
  }
  bool usesLandmarkFeatures() const override { return inner_->usesLandmarkFeatures(); }

 private:
  std::unique_ptr<SlamFilter> inner_;
  FaultInjector injector_;
  long step_ = 0;
};

}  // namespace

FaultInjector::FaultInjector(const FaultInjectorOptions& options, unsigned long seed)
    : options_(options), seed_(seed) {
  reset();
}

void FaultInjector::reset() { rng_.seed(seed_ ^ 0x6661756c74ULL); }

Pose2 FaultInjector::disturbance(long step) {
  if (!options_.enabled || step < options_.start_step) return Pose2::Zero();
  const double dx = sampleGaussian(rng_, options_.sigma_xy_m);
  const double dy = sampleGaussian(rng_, options_.sigma_xy_m);
  const double dtheta = sampleGaussian(rng_, options_.sigma_theta_rad);
  return Pose2(dx, dy, dtheta);
}

std::unique_ptr<SlamFilter> createFaultInjectedFilter(const FilterOptions& options) {
  FilterOptions inner = options;
  inner.dpf.fault.enabled = false;
  return std::make_unique<FaultInjectedFilter>(createFilter(inner), options);
}

}  // namespace core
}  // namespace rbpf_slam

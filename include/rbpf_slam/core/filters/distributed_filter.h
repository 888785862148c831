#pragma once
// Distributed particle-filter SLAM (Pei et al. 2014), variant "dpf": N local filters over
// blocks of landmarks run in threads, a master filter fuses their estimates every step and
// isolates a faulty one (dpf_exchange.h gives the step protocol; the ROS nodes
// dpf_local_node / dpf_master_node run the same protocol across processes).

#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/dpf_local_filter.h"
#include "rbpf_slam/core/filters/dpf_master.h"
#include "rbpf_slam/core/filters/fault_injector.h"
#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace core {

/// Accumulates the motion between filter steps (several predict() calls compose).
struct PendingMotion {
  bool has_motion = false;
  MotionInput motion;
  void add(const MotionInput& m);
  MotionInput take();
};

class DistributedFilter : public SlamFilter {
 public:
  explicit DistributedFilter(const FilterOptions& options);

  std::string variant() const override { return "dpf"; }
  void reset(const Pose2& initial_pose) override;
  void predict(const MotionInput& motion) override;
  UpdateStats update(const FeatureSet& features) override;
  PoseEstimate estimate() const override;
  std::vector<LandmarkEstimate> landmarks() const override;
  std::vector<WeightedPose> particles() const override;
  FilterStats stats() const override;

  const DpfMaster& master() const { return master_; }
  const DpfLocalFilter& local(int i) const { return *locals_[i]; }
  const std::vector<DpfLocalEstimate>& lastEstimates() const { return estimates_; }

 private:
  /// Steps every local filter, in worker threads when configured; results in index order.
  void stepLocals(const DpfStepInput& input, const std::vector<Pose2>& injected);

  const FilterOptions options_;
  std::vector<std::unique_ptr<DpfLocalFilter>> locals_;
  DpfMaster master_;
  FaultInjector injector_;
  PendingMotion pending_;
  DpfFeedback feedback_;
  std::vector<DpfLocalEstimate> estimates_;
  long step_ = 0;
  FilterStats stats_;
};

/// Converts a local filter's best map into landmark estimates.
std::vector<LandmarkEstimate> localLandmarks(const DpfLocalFilter& local);

}  // namespace core
}  // namespace rbpf_slam

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

/// The master's side of the step protocol, shared by the threaded filter and the master node:
/// collects the motion, builds each step's input (with the fault injector's disturbance for
/// the faulted local filter), fuses the answers and keeps the statistics.
class DpfCoordinator {
 public:
  explicit DpfCoordinator(const FilterOptions& options);
  void reset(const Pose2& initial_pose,
             const Eigen::Matrix3d& covariance = Eigen::Matrix3d::Zero());
  void predict(const MotionInput& motion);
  /// The next step's input; *injected gets the disturbance of each local filter.
  DpfStepInput beginStep(const FeatureSet& features, std::vector<Pose2>* injected);
  /// Fuses the answers to the step begun last (throws std::invalid_argument naming a missing
  /// or unexpected local filter) and returns the step's statistics.
  UpdateStats finishStep(const DpfStepInput& input, std::vector<DpfLocalEstimate> estimates);
  PoseEstimate estimate() const;
  /// The statistics, with one `details` entry per local filter (its state at the last step).
  FilterStats stats() const;
  const DpfMaster& master() const { return master_; }
  const std::vector<DpfLocalEstimate>& lastEstimates() const { return estimates_; }
  long step() const { return step_; }

 private:
  const FilterOptions options_;
  DpfMaster master_;
  FaultInjector injector_;
  PendingMotion pending_;
  DpfFeedback feedback_;
  std::vector<DpfLocalEstimate> estimates_;
  long step_ = 0;
  FilterStats stats_;
};

class DistributedFilter : public SlamFilter {
 public:
  explicit DistributedFilter(const FilterOptions& options);

  std::string variant() const override { return "dpf"; }
  void reset(const Pose2& initial_pose) override;
  /// Only before the first update() since reset (the session's start pose, an initialpose
  /// before the first frame): later the local filters' feedback and maps would carry the old
  /// pose, so it declines.
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override;
  void predict(const MotionInput& motion) override;
  UpdateStats update(const FeatureSet& features) override;
  PoseEstimate estimate() const override;
  std::vector<LandmarkEstimate> landmarks() const override;
  std::vector<WeightedPose> particles() const override;
  FilterStats stats() const override;

  const DpfMaster& master() const { return coordinator_.master(); }
  const DpfLocalFilter& local(int i) const { return *locals_[i]; }
  const std::vector<DpfLocalEstimate>& lastEstimates() const {
    return coordinator_.lastEstimates();
  }

 private:
  /// Steps every local filter, in worker threads when configured; results in index order.
  std::vector<DpfLocalEstimate> stepLocals(const DpfStepInput& input,
                                           const std::vector<Pose2>& injected);

  const FilterOptions options_;
  std::vector<std::unique_ptr<DpfLocalFilter>> locals_;
  DpfCoordinator coordinator_;
};

/// Converts a local filter's best map into landmark estimates.
std::vector<LandmarkEstimate> localLandmarks(const DpfLocalFilter& local);

}  // namespace core
}  // namespace rbpf_slam

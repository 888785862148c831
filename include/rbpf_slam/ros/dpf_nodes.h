#pragma once
// The distributed filter across processes: dpf_local_node runs one local filter, dpf_master_node
// runs the master through RemoteDpfFilter. Both speak the step protocol of
// include/rbpf_slam/core/filters/dpf_exchange.h over `dpf/step` (rbpf_slam/DpfStep, master ->
// locals) and `dpf/estimate` (rbpf_slam/DpfLocalEstimate, locals -> master), in lockstep: the
// master publishes step k and waits for the N answers to step k before step k + 1.

#include <rbpf_slam/DpfLocalEstimate.h>
#include <rbpf_slam/DpfStep.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <map>
#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/distributed_filter.h"
#include "rbpf_slam/core/filters/dpf_local_filter.h"
#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace rosbridge {

// Conversions; doubles are copied as they are, so both deployments compute the same numbers.
DpfStep toMsg(const core::DpfStepInput& input, const core::Pose2& initial_pose,
              int injected_index, const core::Pose2& injected);
core::DpfStepInput fromMsg(const DpfStep& msg);
DpfLocalEstimate toMsg(const core::DpfLocalEstimate& estimate,
                       const std::vector<core::LandmarkEstimate>& landmarks);
core::DpfLocalEstimate fromMsg(const DpfLocalEstimate& msg);
std::vector<core::LandmarkEstimate> landmarksOf(const DpfLocalEstimate& msg);

/// The distributed filter whose local filters are dpf_local_node processes: the master's
/// coordinator here, the local filters behind topics. update() blocks until every local filter
/// answered the step, and throws std::runtime_error naming the missing local filter(s) after
/// dpf.step_timeout_s.
class RemoteDpfFilter : public core::SlamFilter {
 public:
  RemoteDpfFilter(ros::NodeHandle nh, const core::FilterOptions& options);

  std::string variant() const override { return "dpf"; }
  void reset(const core::Pose2& initial_pose) override;
  void predict(const core::MotionInput& motion) override { coordinator_.predict(motion); }
  core::UpdateStats update(const core::FeatureSet& features) override;
  core::PoseEstimate estimate() const override { return coordinator_.estimate(); }
  std::vector<core::LandmarkEstimate> landmarks() const override;
  /// The master holds no particles: the fused pose with weight 1.
  std::vector<core::WeightedPose> particles() const override;
  core::FilterStats stats() const override { return coordinator_.stats(); }

  /// Waits until every local filter said it is up; throws naming the silent ones.
  void waitForLocals(double timeout_s);

 private:
  void estimateCallback(const DpfLocalEstimate::ConstPtr& msg);
  /// Spins the estimate queue until `done` or the timeout; false on timeout.
  template <typename Done>
  bool spinUntil(Done done, double timeout_s);
  std::string missing(const std::vector<bool>& present) const;

  const core::FilterOptions options_;
  ros::NodeHandle nh_;
  ros::CallbackQueue queue_;
  ros::Publisher step_publisher_;
  ros::Subscriber estimate_subscriber_;
  core::DpfCoordinator coordinator_;
  core::Pose2 initial_pose_ = core::Pose2::Zero();
  std::vector<bool> alive_;
  bool locals_ready_ = false;
  long waiting_step_ = -1;
  std::map<int, DpfLocalEstimate::ConstPtr> answers_;
  std::string duplicate_error_;
  std::vector<std::vector<core::LandmarkEstimate>> landmarks_;
};

/// dpf_local_node: one local filter answering the master's steps.
class DpfLocalNode {
 public:
  /// Private parameters: the config (as rbpf_slam_node) plus `index` (0..N-1).
  DpfLocalNode(ros::NodeHandle nh, ros::NodeHandle private_nh);

 private:
  void stepCallback(const DpfStep::ConstPtr& msg);

  ros::Publisher estimate_publisher_;
  ros::Subscriber step_subscriber_;
  std::unique_ptr<core::DpfLocalFilter> local_;
  int index_ = 0;
  long expected_step_ = 1;
};

}  // namespace rosbridge
}  // namespace rbpf_slam

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

#include <cstdint>
#include <map>
#include <memory>
#include <string>
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
/// it expects answered the step, at most dpf.step_timeout_s. A local that did not answer in
/// time is named in a warning, left out of the step (core::missedEstimate: not fused, counted
/// in FilterStats::missed_answers) and no longer waited for, until it is heard from again (a
/// restarted dpf_local_node's hello, or a late answer); it then resynchronises itself from the
/// master's estimate (DpfLocalNode). With no local left the master predicts only.
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

  /// Waits until every local filter said it is up and subscribes to the steps. False (with
  /// *problem naming the silent ones) after timeout_s; those are then not waited for.
  bool waitForLocals(double timeout_s, std::string* problem);
  /// A bag run: update() throws when ROS shuts down during a step (live, the step goes on
  /// with the answers that came).
  void stopOnShutdown() { stop_on_shutdown_ = true; }
  /// Answers to a step from a second process with the same ~index (a configuration error;
  /// the first answer is used).
  long conflictingAnswers() const { return conflicting_answers_; }

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
  std::uint32_t run_;  // DpfStep::run: drawn at start, + 1 at every reset
  bool stop_on_shutdown_ = false;
  long conflicting_answers_ = 0;
  core::Pose2 initial_pose_ = core::Pose2::Zero();
  std::vector<bool> alive_;   // heard from since the start
  std::vector<bool> absent_;  // missed a step and not heard from since: not waited for
  bool locals_ready_ = false;
  long waiting_step_ = -1;
  std::map<int, DpfLocalEstimate::ConstPtr> answers_;
  std::vector<std::vector<core::LandmarkEstimate>> landmarks_;
};

/// dpf_local_node: one local filter answering the master's steps. After lost steps, or when
/// started in the middle of a run, it resynchronises from the master's estimate that comes
/// with the step (core::DpfLocalStream).
class DpfLocalNode {
 public:
  /// Private parameters: the config (as rbpf_slam_node) plus `index` (0..N-1), and for fault
  /// tests `crash_at_step` (> 0: the process exits without answering when that step arrives,
  /// as a crash would; 0, the default: never).
  DpfLocalNode(ros::NodeHandle nh, ros::NodeHandle private_nh);

 private:
  void stepCallback(const DpfStep::ConstPtr& msg);

  ros::Publisher estimate_publisher_;
  ros::Subscriber step_subscriber_;
  std::unique_ptr<core::DpfLocalStream> stream_;
  int index_ = 0;
  std::uint64_t sender_;    // DpfLocalEstimate::sender, drawn at start
  long crash_at_step_ = 0;  // ~crash_at_step (tests): exit at once when this step arrives
};

}  // namespace rosbridge
}  // namespace rbpf_slam

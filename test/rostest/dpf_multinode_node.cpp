// dpf_multinode.test: waits for dpf_master_node (with its dpf_local_node processes) to finish
// a simulated bag, runs the threaded distributed filter on the same bag with the same seed and
// fault, and compares the two trajectories update by update (within ~tolerance_m).
// dpf_missing_local.test (~expect_error): the master's error naming a local that never came.
// dpf_local_restart.test (~restart_local): this node runs that local itself, which crashes in
// the middle of the run (~crash_at_step), and starts it again; the master must finish, and the
// local rejoin.

#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <rbpf_slam/DpfLocalEstimate.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/anchored_filter.h"
#include "rbpf_slam/core/filters/distributed_filter.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/io/evaluation.h"
#include "rbpf_slam/io/trajectory.h"
#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/offline_runner.h"

namespace {

namespace rb = rbpf_slam::rosbridge;
namespace io = rbpf_slam::io;
namespace core = rbpf_slam::core;

bool exists(const std::string& path) { return std::ifstream(path).good(); }

/// Waits for one of the files; returns the one that appeared ("" on timeout).
std::string waitForEither(const std::string& a, const std::string& b, double wait_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(wait_s);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    if (exists(a)) return a;
    if (exists(b)) return b;
    ros::WallDuration(0.5).sleep();
  }
  return "";
}

TEST(DpfMultiNode, MasterNamesAMissingLocalFilter) {
  ros::NodeHandle private_nh("~");
  std::string workdir, expect_error;
  double wait_s = 240.0;
  if (!private_nh.getParam("expect_error", expect_error)) GTEST_SKIP() << "no ~expect_error";
  ASSERT_TRUE(private_nh.getParam("workdir", workdir));
  private_nh.getParam("wait", wait_s);
  const std::string error = workdir + "/master/dpf_master.error";
  const std::string done = workdir + "/master/dpf_master.done";
  ASSERT_EQ(waitForEither(error, done, wait_s), error) << "dpf_master_node reported no error";
  std::ifstream in(error);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find(expect_error), std::string::npos) << text;
}

TEST(DpfMultiNode, SameTrajectoryAsTheThreadedFilter) {
  ros::NodeHandle private_nh("~");
  if (private_nh.hasParam("expect_error")) GTEST_SKIP() << "the error case";
  if (private_nh.hasParam("restart_local")) GTEST_SKIP() << "the restart case";
  std::string workdir, config_path;
  int seed = 3, fault_start = 50, fault_local = 1;
  double wait_s = 240.0, tolerance_m = 0.01;
  ASSERT_TRUE(private_nh.getParam("workdir", workdir));
  ASSERT_TRUE(private_nh.getParam("config", config_path));
  private_nh.getParam("seed", seed);
  private_nh.getParam("fault_start_step", fault_start);
  private_nh.getParam("fault_local_index", fault_local);
  private_nh.getParam("wait", wait_s);
  private_nh.getParam("tolerance_m", tolerance_m);

  const std::string done = workdir + "/master/dpf_master.done";
  const std::string error = workdir + "/master/dpf_master.error";
  ASSERT_EQ(waitForEither(done, error, wait_s), done)
      << "dpf_master_node did not finish the bag; see " << error << " and its log";

  const io::SlamConfig config = io::loadSlamConfig(
      config_path, {"seed=" + std::to_string(seed), "fault.enabled=true",
                    "fault.start_step=" + std::to_string(fault_start),
                    "fault.local_index=" + std::to_string(fault_local)});
  rb::OfflineOptions options;
  options.bag_path = workdir + "/sim.bag";
  options.output_dir = workdir + "/threaded";
  options.progress = false;
  rb::OfflineRunner runner(config, options);
  runner.run();
  // The session may run the filter inside an AnchoredFilter (filter_origin: start).
  const core::SlamFilter* filter = &runner.pipeline().session().filter();
  if (const auto* anchored = dynamic_cast<const core::AnchoredFilter*>(filter)) {
    filter = &anchored->inner();
  }
  const auto* threaded = dynamic_cast<const core::DistributedFilter*>(filter);
  ASSERT_NE(threaded, nullptr);
  EXPECT_GT(threaded->master().health()[fault_local].isolations, 0)
      << "the faulty local filter was never isolated";

  const auto multi = io::readTum(workdir + "/master/trajectory.tum");
  const auto single = io::readTum(workdir + "/threaded/trajectory.tum");
  ASSERT_GT(single.size(), 100u);
  ASSERT_EQ(multi.size(), single.size());
  double worst = 0.0;
  for (size_t k = 0; k < single.size(); ++k) {
    EXPECT_DOUBLE_EQ(multi[k].stamp, single[k].stamp) << "update " << k;
    worst = std::max(worst, (multi[k].pose.head<2>() - single[k].pose.head<2>()).norm());
  }
  EXPECT_LE(worst, tolerance_m) << "largest position difference over " << single.size()
                                << " updates";
  RecordProperty("max_difference_m", std::to_string(worst));
}

/// Starts `rosrun rbpf_slam dpf_local_node __name:=NAME _crash_at_step:=K` (rosrun execs: the
/// pid is the node's).
pid_t startLocal(const std::string& name, int crash_at_step) {
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string remap = "__name:=" + name;
    const std::string crash = "_crash_at_step:=" + std::to_string(crash_at_step);
    execlp("rosrun", "rosrun", "rbpf_slam", "dpf_local_node", remap.c_str(), crash.c_str(),
           static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

/// The exit status of pid, waiting up to wait_s (-1: still running, then killed).
int waitForExit(pid_t pid, double wait_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(wait_s);
  int status = 0;
  while (ros::WallTime::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
    ros::WallDuration(0.05).sleep();
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1;
}

/// The value of `"key": number` in a summary.json (NaN when missing).
double summaryNumber(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = text.find("\"" + key + "\":");
  if (at == std::string::npos) return std::nan("");
  std::istringstream value(text.substr(at + key.size() + 3));
  double x = std::nan("");
  value >> x;
  return x;
}

TEST(DpfMultiNode, ALocalThatCrashesAndIsStartedAgainRejoinsAndTheMasterFinishes) {
  ros::NodeHandle nh, private_nh("~");
  int index = -1, crash_at_step = 10, seed = 1;
  if (!private_nh.getParam("restart_local", index)) GTEST_SKIP() << "no ~restart_local";
  std::string workdir, config_path;
  double wait_s = 240.0;
  ASSERT_TRUE(private_nh.getParam("workdir", workdir));
  ASSERT_TRUE(private_nh.getParam("config", config_path));
  private_nh.getParam("crash_at_step", crash_at_step);
  private_nh.getParam("seed", seed);
  private_nh.getParam("wait", wait_s);

  // The answers of local `index`, by process (each draws its own sender id).
  std::mutex mutex;
  std::map<uint64_t, std::pair<long, long>> steps_by_sender;  // first and last step answered
  ros::Subscriber sub = nh.subscribe<rbpf_slam::DpfLocalEstimate>(
      "dpf/estimate", 1000,
      [&](const rbpf_slam::DpfLocalEstimate::ConstPtr& msg) {
        if (msg->index != index || msg->step <= 0) return;
        std::lock_guard<std::mutex> lock(mutex);
        auto found = steps_by_sender.find(msg->sender);
        if (found == steps_by_sender.end()) {
          steps_by_sender[msg->sender] = {msg->step, msg->step};
        } else {
          found->second.second = std::max(found->second.second, static_cast<long>(msg->step));
        }
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const std::string name = "dpf_local_" + std::to_string(index);
  // The first process exits (status 3) when step crash_at_step arrives, without answering it.
  const pid_t first = startLocal(name, crash_at_step);
  ASSERT_GT(first, 0);
  ASSERT_EQ(waitForExit(first, wait_s), 3)
      << "local " << index << " did not crash at step " << crash_at_step;
  const pid_t second = startLocal(name, 0);

  const std::string done = workdir + "/master/dpf_master.done";
  const std::string error = workdir + "/master/dpf_master.error";
  const std::string finished = waitForEither(done, error, wait_s);
  kill(second, SIGINT);
  waitForExit(second, 10.0);
  ASSERT_EQ(finished, done) << "dpf_master_node did not finish the bag; see " << error;
  const std::string summary = workdir + "/master/summary.json";
  const double updates = summaryNumber(summary, "updates");
  {
    std::lock_guard<std::mutex> lock(mutex);
    ASSERT_EQ(steps_by_sender.size(), 2u)
        << "answers from " << steps_by_sender.size() << " process(es) of local " << index;
    for (const auto& [sender, steps] : steps_by_sender) {
      if (steps.first == 1) {  // the first process: up to the step before its crash
        EXPECT_EQ(steps.second, crash_at_step - 1);
      } else {  // the second: from a later step (resynchronised) to the last one
        EXPECT_GT(steps.first, crash_at_step);
        EXPECT_EQ(steps.second, static_cast<long>(updates)) << "it stopped answering";
        RecordProperty("rejoined_at_step", std::to_string(steps.first));
      }
    }
  }
  EXPECT_GE(summaryNumber(summary, "dpf_missed_answers"), 1.0) << summary;

  // The run as a whole: it must still do what the filter is for. A lost local costs its block's
  // map (mapped again from the master's pose), measured at 1.2-1.9x the fault-free threaded
  // filter's ATE (docs/results.md): not the paper's 1.5x for an injected fault, so the
  // yardstick is the odometry, whose error the run must still at least halve.
  const io::SlamConfig config = io::loadSlamConfig(config_path, {"seed=" + std::to_string(seed)});
  rb::OfflineOptions options;
  options.bag_path = workdir + "/sim.bag";
  options.output_dir = workdir + "/threaded";
  options.reference_path = workdir + "/reference.tum";
  options.progress = false;
  rb::OfflineRunner runner(config, options);
  runner.run();
  const double lossy = summaryNumber(summary, "ate_rmse_m");
  const double clean = summaryNumber(workdir + "/threaded/summary.json", "ate_rmse_m");
  std::vector<io::StampedPose> odometry;
  rosbag::Bag bag(workdir + "/sim.bag");
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(std::string("/odom")))) {
    if (const auto odom = m.instantiate<nav_msgs::Odometry>()) {
      odometry.push_back({odom->header.stamp.toSec(), rb::toPose2(odom->pose.pose)});
    }
  }
  ASSERT_GT(odometry.size(), 100u);
  const double odometry_ate = io::evaluateTrajectory(odometry,
                                                     io::readTum(workdir + "/reference.tum"),
                                                     io::EvaluationOptions())
                                  .ate_rmse_m;
  ASSERT_TRUE(std::isfinite(lossy) && std::isfinite(clean)) << lossy << " " << clean;
  EXPECT_LE(lossy, 0.5 * odometry_ate) << "ATE with the local lost " << lossy << " m against "
                                       << odometry_ate << " m for the odometry (" << clean
                                       << " m fault-free)";
  RecordProperty("ate_m", std::to_string(lossy));
  RecordProperty("fault_free_ate_m", std::to_string(clean));
  RecordProperty("odometry_ate_m", std::to_string(odometry_ate));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "dpf_multinode_test");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}

// dpf_multinode.test: waits for dpf_master_node (with its dpf_local_node processes) to finish
// a simulated bag, runs the threaded distributed filter on the same bag with the same seed and
// fault, and compares the two trajectories update by update (within ~tolerance_m).

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/anchored_filter.h"
#include "rbpf_slam/core/filters/distributed_filter.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/io/trajectory.h"
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

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "dpf_multinode_test");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}

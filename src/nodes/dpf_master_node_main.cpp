// dpf_master_node: the master filter of the distributed filter, its local filters being
// dpf_local_node processes (include/rbpf_slam/ros/dpf_nodes.h). Two modes:
//  - live (default): rbpf_slam_node's topics, tf and services, with the remote filter;
//  - ~bag set: reads the bag like offline_slam (same pipeline, as fast as the locals answer)
//    and writes ~output/{trajectory.tum,landmarks.yaml,summary.json,map.png}, then
//    ~output/dpf_master.done, and exits 0. On an error, or a run that used no frame or could not
//    evaluate ~reference (offline_slam's rules), it writes ~output/dpf_master.error with the
//    message instead and exits 1.
#include <ros/ros.h>

#include <exception>
#include <fstream>
#include <memory>
#include <string>

#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/ros/dpf_nodes.h"
#include "rbpf_slam/ros/offline_runner.h"
#include "rbpf_slam/ros/param_loader.h"
#include "rbpf_slam/ros/slam_node.h"

namespace {

namespace rb = rbpf_slam::rosbridge;

int runBag(ros::NodeHandle nh, ros::NodeHandle private_nh) {
  rb::OfflineOptions options;
  private_nh.getParam("bag", options.bag_path);
  private_nh.getParam("output", options.output_dir);
  private_nh.getParam("reference", options.reference_path);
  options.progress = false;
  if (options.output_dir.empty()) throw std::invalid_argument("~output is required with ~bag");
  // The status files too, before the run (a pipe there would block the node at its end; the
  // run directory's own files are checked by OfflineRunner::run()).
  const std::string error_file = options.output_dir + "/dpf_master.error";
  const std::string done_file = options.output_dir + "/dpf_master.done";
  rbpf_slam::io::requireReplaceableFile(error_file);
  rbpf_slam::io::requireReplaceableFile(done_file);
  rbpf_slam::io::SlamConfig config =
      rb::loadConfigFromParams(private_nh, {"bag", "output", "reference"});
  config.filter.variant = "dpf";
  rb::OfflineSummary s;
  long conflicting = 0;
  try {
    auto filter = std::make_unique<rb::RemoteDpfFilter>(nh, config.filter);
    filter->stopOnShutdown();
    const rb::RemoteDpfFilter* remote = filter.get();
    // At the start every local must be there (a bag run is meant to be complete); a local
    // lost later is left out of the steps it misses (RemoteDpfFilter::update).
    std::string problem;
    if (!filter->waitForLocals(config.filter.dpf.step_timeout_s, &problem)) {
      throw std::runtime_error(problem);
    }
    rb::OfflineRunner runner(config, options, std::move(filter));
    s = runner.run();
    conflicting = remote->conflictingAnswers();
  } catch (const std::exception& e) {
    std::ofstream(error_file) << e.what() << "\n";
    throw;
  }
  ROS_INFO("dpf_master_node: %ld updates, %d landmarks, %.1f s wall, update %.2f ms mean",
           s.updates, s.landmarks, s.wall_s, s.update_ms_mean);
  // The same end-of-run report and verdict as offline_slam: a run that used no frame, or whose
  // ~reference could not be evaluated, is an error (dpf_master.error, exit 1), not "done".
  bool failed = false;
  std::string report;
  for (const std::string& line : rb::describeOutcome(s, options, config.filter.variant, &failed)) {
    ROS_WARN("dpf_master_node: %s", line.c_str());
    report += line + "\n";
  }
  if (conflicting > 0) {
    // The run fused whichever answer came first: not reproducible, so not "done".
    const std::string line = std::to_string(conflicting) +
                             " step answer(s) came from a second dpf_local_node with the same "
                             "~index: give each local filter its own ~index";
    ROS_ERROR("dpf_master_node: %s", line.c_str());
    report += line + "\n";
    failed = true;
  }
  if (failed) {
    std::ofstream(error_file) << report;
    return 1;
  }
  std::ofstream(done_file) << s.updates << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "dpf_master_node");
  ros::NodeHandle nh, private_nh("~");
  try {
    if (private_nh.hasParam("bag")) return runBag(nh, private_nh);
    rb::SlamNodeCustomisation custom;
    custom.make_filter = [nh](const rbpf_slam::io::SlamConfig& config) {
      rbpf_slam::core::FilterOptions options = config.filter;
      options.variant = "dpf";
      return std::make_unique<rb::RemoteDpfFilter>(nh, options);
    };
    rb::SlamNode node(nh, private_nh, custom);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("dpf_master_node: " << e.what());
    return 1;
  }
  return 0;
}

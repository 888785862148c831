// simulate: drives the robot of a world file (worlds/*.yaml) and writes a bag shaped like the
// real ones (/tf, /tf_static, /odom, /ground_truth, /scan, /sonar, /sonar_cloud, /features,
// /ir), plus OUT.ref.tum (ground truth) and OUT.landmarks.yaml (true landmarks and objects,
// before and after the world's changes) beside it.
//
//   simulate --world WORLD.yaml --output OUT.bag [--seed N] [--duration S]

#include <rosbag/bag.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/sim/simulator.h"
#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/tool_arguments.h"
#include "rbpf_slam/io/world_yaml.h"
#include "rbpf_slam/ros/bag_files.h"
#include "rbpf_slam/ros/sim_messages.h"

namespace {

namespace sim = rbpf_slam::core::sim;
namespace rosbridge = rbpf_slam::rosbridge;

const char kUsage[] =
    "usage: simulate --world WORLD.yaml --output OUT.bag [--seed N] [--duration S]\n"
    "  writes OUT.bag, OUT.ref.tum (ground truth) and OUT.landmarks.yaml (true landmarks)\n";

struct Arguments {
  std::string world;
  std::string output;
  std::uint64_t seed = 0;
  double duration_s = 0.0;  // 0: until the route is driven
};

Arguments parseArguments(int argc, char** argv) {
  Arguments arguments;
  rbpf_slam::io::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    if (cursor.arg() == "--world") {
      arguments.world = cursor.value();
    } else if (cursor.arg() == "--output") {
      arguments.output = cursor.value();
    } else if (cursor.arg() == "--seed") {
      arguments.seed = cursor.count();
    } else if (cursor.arg() == "--duration") {
      arguments.duration_s = cursor.number(rbpf_slam::io::NumberRule::kNonNegative);
    } else {
      cursor.unknown();
    }
  }
  if (arguments.world.empty() || arguments.output.empty()) {
    throw std::invalid_argument("--world and --output are required");
  }
  return arguments;
}

/// Writes the simulator's events to a bag with the topics of the real ones.
class BagWriter {
 public:
  BagWriter(const std::string& path, const sim::Simulator& simulator, const std::string& ref_path)
      : simulator_(simulator),
        bag_(path),
        ref_path_(ref_path),
        ref_partial_(ref_path + ".part"),
        reference_(std::fopen(ref_partial_.c_str(), "w"), &std::fclose) {
    if (!reference_) throw std::runtime_error(ref_path + ": cannot be written");
    const tf2_msgs::TFMessage mounts =
        rosbridge::simStaticTransforms(simulator_, clock_.stamp(0.0));
    if (!mounts.transforms.empty()) {
      // Latched, so that rviz or a node started after `rosbag play` began still gets the mounts.
      bag_.write("/tf_static", clock_.stamp(0.0), mounts,
                 rosbridge::latchedConnectionHeader<tf2_msgs::TFMessage>("/simulate"));
      ++counts_["/tf_static"];
    }
  }

  void write(const sim::SimEvent& event) {
    const ros::Time stamp = clock_.stamp(event.stamp);
    const rosbridge::SimMessages messages =
        rosbridge::toSimMessages(event, simulator_, clock_);
    if (messages.tf) put("/tf", stamp, *messages.tf);
    if (messages.odom) put("/odom", stamp, *messages.odom);
    if (messages.ground_truth) {
      put("/ground_truth", stamp, *messages.ground_truth);
      std::fputs(rosbridge::groundTruthTumLine(event, clock_).c_str(), reference_.get());
    }
    if (messages.scan) put("/scan", stamp, *messages.scan);
    for (const auto& range : messages.sonar) put("/sonar", stamp, range);
    if (messages.sonar_cloud) put("/sonar_cloud", stamp, *messages.sonar_cloud);
    for (const auto& range : messages.infrared) put("/ir", stamp, range);
    if (messages.features) put("/features", stamp, *messages.features);
  }

  /// Like the bag, the ground truth appears only when complete (REF.part renamed).
  ~BagWriter() {
    if (!committed_) std::remove(ref_partial_.c_str());
  }

  void close() {
    bag_.commit();
    if (std::fclose(reference_.release()) != 0 ||
        std::rename(ref_partial_.c_str(), ref_path_.c_str()) != 0) {
      std::remove(ref_partial_.c_str());
      throw std::runtime_error(ref_path_ + ": ground truth not written");
    }
    committed_ = true;
  }
  const std::map<std::string, long>& counts() const { return counts_; }
  const rosbridge::SimClock& clock() const { return clock_; }

 private:
  template <typename Message>
  void put(const std::string& topic, const ros::Time& stamp, const Message& message) {
    bag_.write(topic, stamp, message);
    ++counts_[topic];
  }

  const sim::Simulator& simulator_;
  const rosbridge::SimClock clock_;
  rosbridge::PartialBag bag_;                        // the bag appears when complete
  const std::string ref_path_, ref_partial_;
  std::unique_ptr<FILE, int (*)(FILE*)> reference_;  // TUM ground truth, one line per odometry
  bool committed_ = false;
  std::map<std::string, long> counts_;
};

/// A number as a YAML scalar with format's precision (yaml-cpp would print 17 digits).
YAML::Node number(double value, const char* format = "%.9g") {
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return YAML::Node(std::string(text));
}

YAML::Node pointList(const std::vector<Eigen::Vector2d>& points) {
  YAML::Node list(YAML::NodeType::Sequence);
  for (const Eigen::Vector2d& p : points) {
    YAML::Node point(YAML::NodeType::Sequence);
    point.SetStyle(YAML::EmitterStyle::Flow);
    point.push_back(number(p.x()));
    point.push_back(number(p.y()));
    list.push_back(point);
  }
  list.SetStyle(YAML::EmitterStyle::Flow);
  return list;
}

/// The true landmarks and objects, before and after the changes that were applied.
void writeTruth(const std::string& path, const Arguments& arguments,
                const sim::Simulator& simulator) {
  YAML::Node root;
  root["world"] = arguments.world;
  root["seed"] = arguments.seed;
  root["frame"] = "map";
  root["start_stamp"] = static_cast<std::uint32_t>(rosbridge::SimClock().stamp(0.0).sec);
  std::map<int, const sim::Landmark*> final_landmarks;
  for (const sim::Landmark& l : simulator.landmarks()) final_landmarks[l.id] = &l;
  for (const sim::Landmark& l : simulator.world().landmarks) {
    YAML::Node node;
    node.SetStyle(YAML::EmitterStyle::Flow);
    node["id"] = l.id;
    node["x_m"] = number(l.position.x());
    node["y_m"] = number(l.position.y());
    node["radius_m"] = number(l.radius_m);
    const auto final_landmark = final_landmarks.find(l.id);
    if (final_landmark == final_landmarks.end()) {
      node["removed"] = true;
    } else if (final_landmark->second->position != l.position) {
      node["after_x_m"] = number(final_landmark->second->position.x());
      node["after_y_m"] = number(final_landmark->second->position.y());
    }
    root["landmarks"].push_back(node);
  }
  for (const sim::WorldObject& object : simulator.world().objects) {
    YAML::Node node;
    node["name"] = object.name;
    node["shape"] = object.shape == sim::ShapeType::kPolygon ? "polygon" : "polyline";
    node["closed"] = sim::isClosed(object);
    node["points"] = pointList(object.points);
    bool present = false;
    for (const sim::WorldObject& now : simulator.objects()) {
      if (now.name != object.name) continue;
      present = true;
      if (now.points != object.points) node["after_points"] = pointList(now.points);
    }
    if (!present) node["removed"] = true;
    root["objects"].push_back(node);
  }
  for (const sim::AppliedChange& change : simulator.appliedChanges()) {
    YAML::Node node;
    node["change"] = change.change_index;
    node["stamp"] = number(rosbridge::SimClock().seconds(change.stamp), "%.6f");
    node["laps_completed"] = change.laps_completed;
    for (const sim::LandmarkChange& l : change.landmarks) {
      YAML::Node moved;
      moved.SetStyle(YAML::EmitterStyle::Flow);
      moved["id"] = l.id;
      moved["before"] = pointList({l.before})[0];
      if (l.removed) {
        moved["removed"] = true;
      } else {
        moved["after"] = pointList({l.after})[0];
      }
      node["landmarks"].push_back(moved);
    }
    for (const sim::ObjectChange& o : change.objects) {
      YAML::Node moved;
      moved["name"] = o.name;
      moved["before"] = pointList(o.before);
      if (o.removed) {
        moved["removed"] = true;
      } else {
        moved["after"] = pointList(o.after);
      }
      node["objects"].push_back(moved);
    }
    root["changes"].push_back(node);
  }
  YAML::Emitter out;
  out << YAML::Comment(
             "True world written by simulate: landmarks and objects in the map frame, "
             "before and after the changes")
      << YAML::Newline << root;
  std::ofstream file(path);
  file << out.c_str() << "\n";
  if (!file) throw std::runtime_error(path + ": cannot be written");
}

int run(const Arguments& arguments) {
  const auto wall_start = std::chrono::steady_clock::now();
  sim::SimulatorOptions options;
  options.seed = arguments.seed;
  options.max_duration_s = arguments.duration_s;
  sim::Simulator simulator(rbpf_slam::io::loadWorld(arguments.world), options);

  const std::string reference_path = rbpf_slam::io::besideBag(arguments.output, ".ref.tum");
  const std::string truth_path = rbpf_slam::io::besideBag(arguments.output, ".landmarks.yaml");
  // Nothing is written when one output cannot be (a directory, pipe or device there): close()
  // renames the ground truth onto its path, and the truth file is opened for writing.
  // The output's directory is made, as offline_slam makes its --output.
  rbpf_slam::io::makeParentDirectories(arguments.output);
  for (const std::string& path : {reference_path, reference_path + ".part", truth_path}) {
    rbpf_slam::io::requireReplaceableFile(path);
  }
  BagWriter writer(arguments.output, simulator, reference_path);
  sim::SimEvent event;
  while (simulator.next(&event)) writer.write(event);
  writer.close();
  writeTruth(truth_path, arguments, simulator);

  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  std::printf("simulated %.1f s (%d of %d laps%s) in %.2f s wall time\n", simulator.time(),
              simulator.lapsCompleted(), simulator.world().laps,
              simulator.routeCompleted() ? "" : ", stopped by the time limit", wall_s);
  for (const auto& [topic, count] : writer.counts()) {
    std::printf("  %-14s %ld messages\n", topic.c_str(), count);
  }
  std::printf("wrote %s\n      %s\n      %s\n", arguments.output.c_str(), reference_path.c_str(),
              truth_path.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return rbpf_slam::io::runTool("simulate", kUsage, argc, argv, parseArguments, run);
}

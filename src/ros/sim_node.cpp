#include "rbpf_slam/ros/sim_node.h"

#include <rosgraph_msgs/Clock.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <utility>
#include <vector>

#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/world_yaml.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

constexpr double kIdlePublishPeriodS = 0.1;  // clock and odometry after the route is done

core::sim::SimulatorOptions simulatorOptions(const SimNodeOptions& options) {
  core::sim::SimulatorOptions out;
  out.seed = static_cast<std::uint64_t>(options.seed);
  out.max_duration_s = options.duration_s;
  return out;
}

}  // namespace

SimNodeOptions loadSimNodeOptions(const ros::NodeHandle& private_nh) {
  SimNodeOptions options;
  const std::string ns = private_nh.getNamespace();
  // Every private parameter must be one of these, of its type: ros::param() would fall back
  // to the default on a mistyped name or value without a word (`_rate:=fast` ran at 1x).
  using Type = XmlRpc::XmlRpcValue::Type;
  const std::map<std::string, std::pair<std::vector<Type>, const char*>> known = {
      {"world", {{Type::TypeString}, "a file path"}},
      {"seed", {{Type::TypeInt}, "an integer"}},
      {"rate", {{Type::TypeDouble, Type::TypeInt}, "a number"}},
      {"duration", {{Type::TypeDouble, Type::TypeInt}, "a number"}},
      {"start_delay", {{Type::TypeDouble, Type::TypeInt}, "a number"}},
      {"publish_clock", {{Type::TypeBoolean}, "true or false"}},
      {"ground_truth_file", {{Type::TypeString}, "a file path"}},
      {"tf_prefix", {{Type::TypeString}, "a string"}}};  // added by ROS itself
  XmlRpc::XmlRpcValue tree;
  std::map<std::string, double> numbers;  // numeric parameters given as text
  if (private_nh.getParam("", tree) && tree.getType() == Type::TypeStruct) {
    for (auto it = tree.begin(); it != tree.end(); ++it) {
      const auto k = known.find(it->first);
      if (k == known.end()) {
        std::string list;
        for (const auto& [name, type] : known) {
          if (name != "tf_prefix") list += (list.empty() ? "" : ", ") + name;
        }
        throw std::invalid_argument(ns + "/" + it->first + " is not a sim_node parameter (" + list +
                                    ")");
      }
      const auto& types = k->second.first;
      const bool number = std::find(types.begin(), types.end(), Type::TypeDouble) != types.end();
      if (number && it->second.getType() == Type::TypeString) {
        // roslaunch passes "1e3" as a string: a number all the same.
        const std::string text = static_cast<std::string>(it->second);
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (!text.empty() && end == text.c_str() + text.size() && std::isfinite(value)) {
          numbers[it->first] = value;
          continue;
        }
      }
      if (std::find(types.begin(), types.end(), it->second.getType()) == types.end()) {
        throw std::invalid_argument(ns + "/" + it->first + " must be " + k->second.second);
      }
    }
  }
  if (!private_nh.getParam("world", options.world) || options.world.empty()) {
    throw std::invalid_argument(ns + "/world is required: the path of a world file (worlds/)");
  }
  private_nh.param("seed", options.seed, options.seed);
  private_nh.param("rate", options.rate, options.rate);
  private_nh.param("duration", options.duration_s, options.duration_s);
  private_nh.param("start_delay", options.start_delay_s, options.start_delay_s);
  if (numbers.count("rate")) options.rate = numbers["rate"];
  if (numbers.count("duration")) options.duration_s = numbers["duration"];
  if (numbers.count("start_delay")) options.start_delay_s = numbers["start_delay"];
  bool use_sim_time = false;
  ros::param::param("/use_sim_time", use_sim_time, false);
  private_nh.param("publish_clock", options.publish_clock, use_sim_time);
  private_nh.param<std::string>("ground_truth_file", options.ground_truth_file, "");
  if (options.seed < 0) {
    throw std::invalid_argument(ns + "/seed = " + std::to_string(options.seed) +
                                " must be >= 0");
  }
  if (!std::isfinite(options.rate) || options.rate <= 0.0) {
    throw std::invalid_argument(ns + "/rate = " + std::to_string(options.rate) +
                                " must be a positive number (simulated s per wall s)");
  }
  if (!std::isfinite(options.duration_s) || options.duration_s < 0.0) {
    throw std::invalid_argument(ns + "/duration = " + std::to_string(options.duration_s) +
                                " must be >= 0 (0: the whole route)");
  }
  if (!std::isfinite(options.start_delay_s) || options.start_delay_s < 0.0) {
    throw std::invalid_argument(ns + "/start_delay = " + std::to_string(options.start_delay_s) +
                                " must be >= 0 (wall s)");
  }
  if (!options.publish_clock && options.rate != 1.0) {
    throw std::invalid_argument(ns + "/rate = " + std::to_string(options.rate) +
                                " needs simulated time: set /use_sim_time or ~publish_clock");
  }
  return options;
}

SimNode::SimNode(ros::NodeHandle nh, const SimNodeOptions& options)
    : nh_(nh),
      options_(options),
      simulator_(io::loadWorld(options.world), simulatorOptions(options)),
      ground_truth_file_(nullptr, &std::fclose) {
  if (options_.publish_clock) {
    clock_publisher_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  } else {
    clock_ = SimClock(ros::Time::now());
  }
  odom_publisher_ = nh_.advertise<nav_msgs::Odometry>("odom", 50);
  ground_truth_publisher_ = nh_.advertise<nav_msgs::Odometry>("ground_truth", 50);
  const core::sim::SensorsConfig& sensors = simulator_.world().sensors;
  if (sensors.laser.enabled) scan_publisher_ = nh_.advertise<sensor_msgs::LaserScan>("scan", 10);
  if (sensors.sonar.enabled) {
    sonar_publisher_ = nh_.advertise<sensor_msgs::Range>("sonar", 100);
    sonar_cloud_publisher_ = nh_.advertise<sensor_msgs::PointCloud>("sonar_cloud", 10);
  }
  if (sensors.infrared.enabled) infrared_publisher_ = nh_.advertise<sensor_msgs::Range>("ir", 100);
  if (sensors.range_bearing.enabled) {
    features_publisher_ = nh_.advertise<FeatureArray>("features", 10);
  }
  if (!options_.ground_truth_file.empty()) {
    // Written as FILE.part and renamed when the route is done: FILE appears complete.
    io::makeParentDirectories(options_.ground_truth_file);
    const std::string partial = options_.ground_truth_file + ".part";
    ground_truth_file_.reset(std::fopen(partial.c_str(), "w"));
    if (!ground_truth_file_) {
      throw std::invalid_argument("~ground_truth_file: cannot write '" + partial + "'");
    }
  }
  ROS_INFO_STREAM("sim_node: world " << options_.world << " (" << simulator_.world().name
                                     << "), seed " << options_.seed << ", rate "
                                     << options_.rate << "x"
                                     << (options_.publish_clock ? ", publishing /clock" : ""));
}

void SimNode::publishClock(double t) {
  if (!options_.publish_clock) return;
  rosgraph_msgs::Clock message;
  message.clock = clock_.stamp(t);
  clock_publisher_.publish(message);
}

void SimNode::waitFor(double t) {
  const ros::WallTime target = wall_start_ + ros::WallDuration(t / options_.rate);
  while (ros::ok()) {
    const ros::WallTime now = ros::WallTime::now();
    if (now >= target) return;
    // Keep the clock moving while waiting so timers and tf of other nodes advance smoothly.
    const double elapsed_sim = (now - wall_start_).toSec() * options_.rate;
    publishClock(elapsed_sim);
    const ros::WallDuration remaining = target - now;
    ros::WallDuration(std::min(remaining.toSec(), 0.01)).sleep();
  }
}

void SimNode::publish(const core::sim::SimEvent& event) {
  publishClock(event.stamp);
  const SimMessages messages = toSimMessages(event, simulator_, clock_);
  if (messages.tf) tf_broadcaster_.sendTransform(messages.tf->transforms);
  if (messages.odom) odom_publisher_.publish(*messages.odom);
  if (messages.ground_truth) {
    ground_truth_publisher_.publish(*messages.ground_truth);
    if (ground_truth_file_) {
      std::fputs(groundTruthTumLine(event, clock_).c_str(), ground_truth_file_.get());
      std::fflush(ground_truth_file_.get());
    }
  }
  if (messages.scan) scan_publisher_.publish(*messages.scan);
  for (const auto& range : messages.sonar) sonar_publisher_.publish(range);
  if (messages.sonar_cloud) sonar_cloud_publisher_.publish(*messages.sonar_cloud);
  for (const auto& range : messages.infrared) infrared_publisher_.publish(range);
  if (messages.features) features_publisher_.publish(*messages.features);
  if (event.type == core::sim::SimEventType::kWorldChange) {
    ROS_INFO_STREAM("sim_node: world change " << event.change.change_index << " applied at "
                                              << event.stamp << " s: "
                                              << event.change.landmarks.size()
                                              << " landmarks and "
                                              << event.change.objects.size()
                                              << " objects moved or removed");
  }
}

void SimNode::run() {
  // Let subscribers connect before the first message, with the clock held at time 0.
  const ros::WallTime connect_until = ros::WallTime::now() + ros::WallDuration(options_.start_delay_s);
  while (ros::ok() && ros::WallTime::now() < connect_until) {
    publishClock(0.0);
    ros::WallDuration(0.05).sleep();
  }
  wall_start_ = ros::WallTime::now();
  publishClock(0.0);
  static_broadcaster_.sendTransform(simStaticTransforms(simulator_, clock_.stamp(0.0)).transforms);
  core::sim::SimEvent event, last_odometry;
  bool have_odometry = false;
  while (ros::ok() && simulator_.next(&event)) {
    waitFor(event.stamp);
    publish(event);
    if (event.type == core::sim::SimEventType::kOdometry) {
      last_odometry = event;
      have_odometry = true;
    }
    ros::spinOnce();
  }
  if (!ros::ok()) return;
  if (ground_truth_file_) {
    ground_truth_file_.reset();
    const std::string partial = options_.ground_truth_file + ".part";
    if (std::rename(partial.c_str(), options_.ground_truth_file.c_str()) != 0) {
      ROS_ERROR_STREAM("sim_node: cannot rename " << partial << " to "
                                                  << options_.ground_truth_file);
    }
  }
  ROS_INFO_STREAM("sim_node: route done after " << simulator_.time() << " s simulated ("
                                                << simulator_.lapsCompleted() << " of "
                                                << simulator_.world().laps
                                                << " laps); the robot stands still");
  // Standing still: the clock and odometry go on so that tf lookups keep working.
  double t = simulator_.time();
  while (ros::ok()) {
    t += kIdlePublishPeriodS;
    waitFor(t);
    if (have_odometry) {
      last_odometry.stamp = t;
      last_odometry.odom_twist.setZero();
      last_odometry.true_speed_mps = 0.0;
      last_odometry.true_turn_rate_radps = 0.0;
      publish(last_odometry);
    } else {
      publishClock(t);
    }
    ros::spinOnce();
  }
}

}  // namespace rosbridge
}  // namespace rbpf_slam

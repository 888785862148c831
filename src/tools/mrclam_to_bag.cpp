// mrclam_to_bag DATASET_DIR ROBOT OUT.bag [--known-ids] [--start S] [--duration S]
//               [--sigma-range-m F] [--sigma-range-per-m F] [--sigma-bearing-rad F]
// Converts one robot of a UTIAS MRCLAM dataset into a bag: /tf (odom -> base_link) and /odom
// dead-reckoned from the velocity commands, /features (rbpf_slam/FeatureArray in base_link,
// one message per camera frame, landmark sightings only) and /ground_truth (Vicon, frame map).
// Beside the bag: OUT.ref.tum (ground truth), OUT.odom.tum (the dead-reckoned track, to
// evaluate odometry alone) and OUT.landmarks.yaml (surveyed landmarks). The dataset's stamps
// are Unix times and are kept. The odometry starts at the ground-truth pose at the first
// command, so odom (and the filter's map frame) coincide with the ground-truth frame at start.

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rbpf_slam/FeatureArray.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/require_range.h"
#include "rbpf_slam/io/json_writer.h"
#include "rbpf_slam/io/mrclam.h"
#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/tool_arguments.h"
#include "rbpf_slam/io/trajectory.h"
#include "rbpf_slam/ros/bag_files.h"
#include "rbpf_slam/ros/conversions.h"

namespace {

namespace io = rbpf_slam::io;
namespace core = rbpf_slam::core;
namespace rosbridge = rbpf_slam::rosbridge;

const char kUsage[] =
    "usage: mrclam_to_bag DATASET_DIR ROBOT OUT.bag [--known-ids] [--start S] [--duration S]\n"
    "                     [--sigma-range-m F] [--sigma-range-per-m F] [--sigma-bearing-rad F]\n"
    "                     [--max-gap S] [--command-delay S]\n"
    "  ROBOT                  1..5 (RobotN_*.dat in DATASET_DIR)\n"
    "  --known-ids            give every feature its landmark subject as id (default: -1)\n"
    "  --start S              begin S seconds after the first odometry command (a recording\n"
    "                         that starts later, elsewhere; ground truth and odometry from there)\n"
    "  --duration S           keep only the first S seconds after the start\n"
    "  --sigma-range-m F      feature range sigma at zero range (default 0.03 m)\n"
    "  --sigma-range-per-m F  ... growing by this per metre of range (default 0.035)\n"
    "  --sigma-bearing-rad F  feature bearing sigma (default 0.02 rad)\n"
    "  --max-gap S            commands further apart are not integrated (the robot stood\n"
    "                         still; default 2 s: dataset 6 drives with commands 1.03 s apart)\n"
    "  --command-delay S      apply each velocity command this much after its stamp (default\n"
    "                         0 s; the commands lead Vicon by 0.15-0.2 s on dataset 6)\n"
    "Writes OUT.bag (/tf, /odom, /features, /ground_truth), OUT.ref.tum, OUT.odom.tum and\n"
    "OUT.landmarks.yaml.\n";

/// Command-line settings of one conversion.
struct Arguments {
  std::string dataset_dir;
  int robot = 0;
  std::string bag_path;
  bool known_ids = false;
  double start_s = 0.0;     // skipped after the first odometry command
  double duration_s = 0.0;  // 0: everything
  // Feature noise, fitted to the Vicon residuals of dataset 6 (robust sigmas: ~0.065 m at
  // 1.5 m, ~0.17 m at 5 m; bearing ~0.008 rad with heavy tails).
  double sigma_range_m = 0.03;
  double sigma_range_per_m = 0.035;
  double sigma_bearing_rad = 0.02;
  double max_gap_s = io::kMrclamMaxCommandGapS;
  double command_delay_s = 0.0;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments arguments;
  std::vector<std::string> positional;
  io::ArgumentCursor cursor(argc, argv);
  const auto non_negative = [&] { return cursor.number(io::NumberRule::kNonNegative); };
  while (cursor.next()) {
    if (cursor.arg() == "--known-ids") {
      arguments.known_ids = true;
    } else if (cursor.arg() == "--start") {
      arguments.start_s = non_negative();
    } else if (cursor.arg() == "--duration") {
      arguments.duration_s = non_negative();
    } else if (cursor.arg() == "--sigma-range-m") {
      arguments.sigma_range_m = non_negative();
    } else if (cursor.arg() == "--sigma-range-per-m") {
      arguments.sigma_range_per_m = non_negative();
    } else if (cursor.arg() == "--sigma-bearing-rad") {
      arguments.sigma_bearing_rad = non_negative();
    } else if (cursor.arg() == "--max-gap") {
      arguments.max_gap_s = cursor.number(io::NumberRule::kPositive);
    } else if (cursor.arg() == "--command-delay") {
      arguments.command_delay_s = non_negative();
    } else if (cursor.isOption()) {
      cursor.unknown();
    } else {
      positional.push_back(cursor.arg());
    }
  }
  if (positional.size() != 3) {
    throw std::invalid_argument("expected DATASET_DIR ROBOT OUT.bag, got " +
                                std::to_string(positional.size()) + " argument(s)");
  }
  arguments.dataset_dir = positional[0];
  const std::string& robot = positional[1];
  if (robot.size() != 1 || robot[0] < '1' || robot[0] > '5') {
    throw std::invalid_argument("ROBOT must be 1..5, got '" + robot + "'");
  }
  arguments.robot = robot[0] - '0';
  arguments.bag_path = positional[2];
  if (arguments.sigma_range_m + arguments.sigma_range_per_m <= 0.0 ||
      arguments.sigma_bearing_rad <= 0.0) {
    throw std::invalid_argument("feature sigmas must be positive");
  }
  // Beyond these the features' covariances are meaningless (1e300 gave inf in the bag), and a
  // command delay of hours pushes stamps past what ros::Time holds.
  const struct {
    const char* option;
    double value, max;
  } limits[] = {{"--sigma-range-m", arguments.sigma_range_m, 100.0},
                {"--sigma-range-per-m", arguments.sigma_range_per_m, 10.0},
                {"--sigma-bearing-rad", arguments.sigma_bearing_rad, M_PI},
                {"--command-delay", arguments.command_delay_s, 60.0}};
  for (const auto& limit : limits) {
    if (limit.value > limit.max) {
      throw std::invalid_argument(std::string(limit.option) + " " +
                                  core::formatNumber(limit.value) + " is above " +
                                  core::formatNumber(limit.max));
    }
  }
  return arguments;
}

nav_msgs::Odometry odometryMessage(const std::string& frame, const core::Pose2& pose, double v_mps,
                                   double w_radps, const ros::Time& stamp, std::uint32_t seq) {
  nav_msgs::Odometry odometry = rosbridge::toOdometryMsg(pose, Eigen::Vector3d(v_mps, 0.0, w_radps),
                                                         frame, "base_link", stamp);
  odometry.header.seq = seq;
  return odometry;
}

tf2_msgs::TFMessage odomTransform(const core::Pose2& pose, const ros::Time& stamp) {
  tf2_msgs::TFMessage message;
  message.transforms.push_back(rosbridge::toTransformStamped(pose, "odom", "base_link", stamp));
  return message;
}

rbpf_slam::FeatureArray featureMessage(const io::MrclamMeasurementGroup& group,
                                       const Arguments& arguments, std::uint32_t seq) {
  rbpf_slam::FeatureArray message;
  message.header.seq = seq;
  message.header.stamp = ros::Time(group.stamp);
  message.header.frame_id = "base_link";
  for (const io::MrclamMeasurement& m : group.measurements) {
    rbpf_slam::PointFeature point;
    point.range = m.range_m;
    point.bearing = m.bearing_rad;
    const double sigma_range = arguments.sigma_range_m + arguments.sigma_range_per_m * m.range_m;
    point.covariance = {sigma_range * sigma_range, 0.0, 0.0,
                        arguments.sigma_bearing_rad * arguments.sigma_bearing_rad};
    point.id = arguments.known_ids ? m.subject : -1;
    message.points.push_back(point);
  }
  return message;
}

/// One message to write: what and when (at equal stamps tf comes before the features).
struct Event {
  double stamp;
  int kind;  // 0 odometry (+ tf), 1 ground truth, 2 features
  std::size_t index;
};

/// What was written, for the closing report.
struct Counts {
  std::size_t odometry = 0, ground_truth = 0, feature_messages = 0, features = 0;
};

Counts writeBag(const Arguments& arguments, const io::MrclamRobot& data,
                const std::vector<io::StampedPose>& odometry,
                const std::vector<io::MrclamMeasurementGroup>& groups) {
  std::vector<Event> events;
  for (std::size_t i = 0; i < odometry.size(); ++i) events.push_back({odometry[i].stamp, 0, i});
  for (std::size_t i = 0; i < data.ground_truth.size(); ++i) {
    events.push_back({data.ground_truth[i].stamp, 1, i});
  }
  for (std::size_t i = 0; i < groups.size(); ++i) events.push_back({groups[i].stamp, 2, i});
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return a.stamp != b.stamp ? a.stamp < b.stamp : a.kind < b.kind;
  });

  // The command in force at each integrated pose, for the twist of /odom: the first of the
  // commands at its stamp, as integrateMrclamOdometry integrates.
  std::vector<const io::MrclamOdometry*> command_at(odometry.size(), nullptr);
  for (std::size_t i = 0, j = 0; i < odometry.size(); ++i) {
    while (j + 1 < data.odometry.size() && data.odometry[j + 1].stamp <= odometry[i].stamp) ++j;
    std::size_t first = j;
    while (first > 0 && data.odometry[first - 1].stamp == data.odometry[first].stamp) --first;
    command_at[i] = &data.odometry[first];
  }

  Counts counts;
  rbpf_slam::rosbridge::PartialBag output(arguments.bag_path);  // the bag appears when complete
  std::uint32_t gt_seq = 0, feature_seq = 0;
  for (const Event& event : events) {
    const ros::Time stamp(event.stamp);
    if (event.kind == 0) {
      const io::StampedPose& pose = odometry[event.index];
      const io::MrclamOdometry& command = *command_at[event.index];
      output.write("/tf", stamp, odomTransform(pose.pose, stamp));
      output.write("/odom", stamp,
                   odometryMessage("odom", pose.pose, command.v_mps, command.w_radps, stamp,
                                   static_cast<std::uint32_t>(counts.odometry++)));
    } else if (event.kind == 1) {
      const io::StampedPose& pose = data.ground_truth[event.index];
      output.write("/ground_truth", stamp,
                   odometryMessage("map", pose.pose, 0.0, 0.0, stamp, gt_seq++));
      ++counts.ground_truth;
    } else {
      const rbpf_slam::FeatureArray message =
          featureMessage(groups[event.index], arguments, feature_seq++);
      output.write("/features", stamp, message);
      ++counts.feature_messages;
      counts.features += message.points.size();
    }
  }
  output.commit();
  return counts;
}

void writeLandmarks(const std::string& path, const Arguments& arguments,
                    const io::MrclamRobot& data) {
  std::ofstream out(path);
  out << "# Surveyed landmarks of the UTIAS MRCLAM dataset (Landmark_Groundtruth.dat), frame map\n"
      << "# (the Vicon frame of /ground_truth and OUT.ref.tum), written by mrclam_to_bag.\n"
      << "dataset: " << io::jsonString(arguments.dataset_dir) << "\n"  // valid YAML too
      << "robot: " << arguments.robot << "\n"
      << "frame: map\n"
      << "landmarks:\n"
      << std::fixed << std::setprecision(8);
  for (const io::MrclamLandmark& l : data.landmarks) {
    out << "  - {id: " << l.subject << ", x_m: " << l.x_m << ", y_m: " << l.y_m
        << ", sd_x_m: " << l.sd_x_m << ", sd_y_m: " << l.sd_y_m << "}\n";
  }
  if (!out) throw std::runtime_error(path + ": cannot be written");
}

/// Ground truth may begin this much after the first command without a warning (Vicon's period
/// is 0.01 s; a crop by --start/--duration cuts it at the first kept command).
constexpr double kGroundTruthLateS = 0.5;

/// The work once the arguments are understood; the exit status.
int run(const Arguments& arguments) {
  ros::Time::init();
  const std::string robot_files = arguments.dataset_dir + "/Robot" +
                                  std::to_string(arguments.robot) + "_";
  io::MrclamRobot data = io::readMrclamRobot(arguments.dataset_dir, arguments.robot);
  io::cropMrclamRobot(arguments.start_s, arguments.duration_s, &data);
  // Stretches without ground truth in the part kept only.
  io::reportGroundTruthGaps(robot_files + "Groundtruth.dat", &data);
  io::delayMrclamCommands(arguments.command_delay_s, &data);
  const std::size_t measurements_read = data.measurements.size();  // within --start/--duration
  if (data.odometry.size() < 2) {
    throw std::runtime_error(robot_files + "Odometry.dat: " +
                             std::to_string(data.odometry.size()) +
                             " command(s) kept by --start/--duration; at least 2 are needed");
  }
  const double first_command = data.odometry.front().stamp;
  const double last_command = data.odometry.back().stamp;
  if (data.ground_truth.empty() || data.ground_truth.back().stamp < first_command ||
      data.ground_truth.front().stamp > last_command) {
    std::ostringstream why;
    why << std::fixed << std::setprecision(3) << robot_files
        << "Groundtruth.dat: no ground-truth pose while the commands run (" << first_command
        << " to " << last_command << " s)";
    throw std::runtime_error(why.str());
  }
  if (data.ground_truth.front().stamp > first_command + kGroundTruthLateS) {
    std::ostringstream why;
    why << std::setprecision(3) << robot_files << "Groundtruth.dat begins "
        << data.ground_truth.front().stamp - first_command
        << " s after the first command: the run starts at the first ground-truth pose, not "
           "where the robot was";
    data.warnings.push_back(why.str());
  }
  for (const std::string& warning : data.warnings) {
    std::cerr << "mrclam_to_bag: warning: " << warning << "\n";
  }
  const core::Pose2 start = io::interpolatePose(data.ground_truth, first_command);
  int not_integrated = 0;
  const std::vector<io::StampedPose> odometry =
      io::integrateMrclamOdometry(data.odometry, start, arguments.max_gap_s, &not_integrated);
  const std::vector<io::MrclamMeasurementGroup> groups =
      io::groupLandmarkMeasurements(data.measurements);

  std::size_t robots = 0, unknown = 0;
  for (const io::MrclamMeasurement& m : data.measurements) {
    if (m.subject < 0)
      ++unknown;
    else if (m.subject < io::kMrclamFirstLandmarkSubject)
      ++robots;
  }
  if (groups.empty()) {
    throw std::runtime_error(
        robot_files + "Measurement.dat: no landmark sighting" +
        (arguments.start_s > 0.0 || arguments.duration_s > 0.0 ? " kept by --start/--duration"
                                                               : "") +
        " (" + std::to_string(measurements_read) + " sightings: " + std::to_string(robots) +
        " of robots, " + std::to_string(unknown) +
        " of barcodes not in Barcodes.dat); the bag would have no /features");
  }
  // Sightings with no odometry around them have no pose to be seen from (a file of another
  // run, a shifted clock): all of them is an error, some a warning.
  std::size_t outside = 0;
  const double odometry_begin = odometry.front().stamp, odometry_end = odometry.back().stamp;
  // --command-delay moves the odometry later: the window widens by it.
  const double margin = 1.0 + arguments.command_delay_s;
  for (const io::MrclamMeasurementGroup& g : groups) {
    if (g.stamp < odometry_begin - margin || g.stamp > odometry_end + margin) ++outside;
  }
  if (outside > 0) {
    std::ostringstream why;
    why << std::fixed << std::setprecision(3) << robot_files << "Measurement.dat: " << outside
        << " of " << groups.size() << " sighting time(s) lie more than " << margin
        << " s outside the odometry (" << odometry_begin << " .. " << odometry_end
        << " s; sightings " << groups.front().stamp << " .. " << groups.back().stamp << " s)";
    if (outside == groups.size()) throw std::runtime_error(why.str() + ": is it the same run?");
    std::cerr << "mrclam_to_bag: warning: " << why.str() << "\n";
  }

  // The side files first: the bag appears only when complete, so a bag on disk means a whole
  // conversion (benchmarks/run_mrclam reuses one it finds); an older bag there goes first.
  const std::string reference_path = io::besideBag(arguments.bag_path, ".ref.tum");
  const std::string odometry_path = io::besideBag(arguments.bag_path, ".odom.tum");
  const std::string landmarks_path = io::besideBag(arguments.bag_path, ".landmarks.yaml");
  for (const std::string& path : {arguments.bag_path, arguments.bag_path + ".part",
                                  reference_path, odometry_path, landmarks_path}) {
    io::requireReplaceableFile(path);  // nothing written when one cannot be
  }
  std::error_code ignored;
  if (std::filesystem::is_regular_file(arguments.bag_path, ignored)) {
    std::filesystem::remove(arguments.bag_path, ignored);
  }
  io::writeTum(reference_path, data.ground_truth);
  io::writeTum(odometry_path, odometry);
  writeLandmarks(landmarks_path, arguments, data);
  const Counts counts = writeBag(arguments, data, odometry, groups);
  std::cerr << "mrclam_to_bag: robot " << arguments.robot << ": " << counts.odometry
            << " odometry poses over " << (odometry.back().stamp - odometry.front().stamp)
            << " s (start at the ground-truth pose " << start.transpose() << "), "
            << counts.features << " landmark sightings in " << counts.feature_messages
            << " /features messages (" << (arguments.known_ids ? "known" : "unknown")
            << " ids; dropped " << robots << " sightings of robots and " << unknown
            << " of unknown barcodes, of " << measurements_read << " sightings"
            << (arguments.start_s > 0.0 || arguments.duration_s > 0.0
                    ? " kept by --start/--duration"
                    : "")
            << "), "
            << counts.ground_truth << " ground-truth poses; " << not_integrated
            << " command interval(s) over " << arguments.max_gap_s << " s not integrated\n"
            << "mrclam_to_bag: wrote " << arguments.bag_path << ", " << reference_path << ", "
            << odometry_path << ", " << landmarks_path << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return io::runTool("mrclam_to_bag", kUsage, argc, argv, parseArguments, run);
}

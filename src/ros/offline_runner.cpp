#include "rbpf_slam/ros/offline_runner.h"

#include <console_bridge/console.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include "rbpf_slam/core/grid/grid_map_data.h"
#include "rbpf_slam/core/grid/grid_options.h"
#include "rbpf_slam/io/evaluation.h"
#include "rbpf_slam/io/grid_map_file.h"
#include "rbpf_slam/io/json_writer.h"
#include "rbpf_slam/io/landmark_file.h"
#include "rbpf_slam/io/map_image.h"
#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/trajectory.h"
#include "rbpf_slam/ros/bag_files.h"
#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/markers.h"
#include "rbpf_slam/ros/node_support.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

constexpr double kCloudAxisTolerance = 0.05;  // m: a cloud point lies on its transducer's axis
constexpr double kLandmarkPointRadius = 0.1;  // m: a point landmark's disc in map.pgm

// The files of a run directory, named once: run() checks them all before reading the bag and
// writeOutputs() writes them.
struct RunFiles {
  explicit RunFiles(const std::string& dir)
      : trajectory(dir + "/trajectory.tum"),
        online(dir + "/trajectory_online.tum"),
        trajectory_filter(dir + "/trajectory_filter.tum"),
        landmarks(dir + "/landmarks.yaml"),
        landmarks_filter(dir + "/landmarks_filter.yaml"),
        summary(dir + "/summary.json"),
        picture(dir + "/map.png"),
        map_prefix(dir + "/map") {}

  /// Every file the run writes; the filter's own path and map only with smoothing.
  std::vector<std::string> all(bool smoothing) const {
    std::vector<std::string> files = {trajectory, online, landmarks, summary, picture};
    for (const std::string& f : io::gridMapFiles(map_prefix)) files.push_back(f);
    if (smoothing) {
      files.push_back(trajectory_filter);
      files.push_back(landmarks_filter);
    }
    return files;
  }

  std::string trajectory, online, trajectory_filter, landmarks, landmarks_filter, summary,
      picture, map_prefix;
};

bool topicIs(const std::string& topic, const std::string& name) {
  return stripSlash(topic) == stripSlash(name);
}

/// Peak resident set of this process ("VmHWM"), MB; NaN when /proc is not there.
double peakResidentMb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// A terminal progress bar: percentage, rate and time left.
class ProgressBar {
 public:
  explicit ProgressBar(bool enabled) : enabled_(enabled && isatty(STDERR_FILENO)) {}
  void show(double fraction, double wall_s, double bag_s) {
    if (!enabled_ || fraction - last_ < 0.005) return;
    last_ = fraction;
    const int width = 30, filled = static_cast<int>(fraction * width);
    const double left = fraction > 0.0 ? wall_s * (1.0 - fraction) / fraction : 0.0;
    std::fprintf(stderr, "\r[%s%s] %5.1f%%  %.0fx real time  %.0f s left ",
                 std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(),
                 100.0 * fraction, wall_s > 0.0 ? bag_s / wall_s : 0.0, left);
  }
  void done() {
    if (enabled_) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_;
  double last_ = -1.0;
};

/// An odometry transform (odom -> base) as the bag holds it.
struct OdometryArrival {
  ros::Time received;  // the bag's time of the message
  double stamp = 0.0;  // the transform's stamp, s
};

/// The bag's tf from one bag time on: a bag holding two logs (or a restarted driver) has one
/// per run, since one tf buffer cannot hold two runs whose stamps overlap.
struct TfSegment {
  ros::Time starts;  // bag time of the message that started it
  std::unique_ptr<tf2::BufferCore> buffer;
};

const std::vector<std::string> kTfTopics{"/tf", "/tf_static", "tf", "tf_static"};

/// The message, or null when it is of another type or does not decode (a damaged bag).
template <typename Message>
boost::shared_ptr<Message> instantiateOrNull(const rosbag::MessageInstance& m) {
  try {
    return m.instantiate<Message>();
  } catch (const std::exception&) {
    return nullptr;
  }
}

/// The stamps of the odometry (odom_frame -> base_frame on tf), in bag order, each with the
/// time the bag received it.
std::vector<OdometryArrival> readOdometry(const rosbag::Bag& bag, const std::string& odom_frame,
                                          const std::string& base_frame) {
  std::vector<OdometryArrival> odometry;
  rosbag::View view(bag, rosbag::TopicQuery(kTfTopics));
  for (const rosbag::MessageInstance& m : view) {
    if (topicIs(m.getTopic(), "tf_static")) continue;
    const auto msg = instantiateOrNull<tf2_msgs::TFMessage>(m);
    if (!msg) continue;
    for (const auto& t : msg->transforms) {
      // A transform tf2 refuses (transformProblem) is no odometry that arrived.
      if (stripSlash(t.header.frame_id) == odom_frame &&
          stripSlash(t.child_frame_id) == base_frame && transformProblem(t).empty()) {
        odometry.push_back({m.getTime(), t.header.stamp.toSec()});
      }
    }
  }
  return odometry;
}

/// Bag times where the odometry starts a new run (a second log in the bag, a restarted
/// driver): `in_a_row` odometry stamps in a row more than jump_back_s behind the newest one
/// before them. One stale stamp is no new run. None when jump_back_s is 0.
std::vector<ros::Time> runStarts(const std::vector<OdometryArrival>& odometry, double jump_back_s,
                                 int in_a_row) {
  std::vector<ros::Time> starts;
  if (!(jump_back_s > 0.0)) return starts;
  double newest = -std::numeric_limits<double>::infinity();
  int back = 0;
  ros::Time first_back;
  for (const OdometryArrival& a : odometry) {
    if (a.stamp < newest - jump_back_s) {
      if (back++ == 0) first_back = a.received;
      if (back >= std::max(1, in_a_row)) {
        starts.push_back(first_back);
        newest = a.stamp;
        back = 0;
      }
    } else {
      back = 0;
      newest = std::max(newest, a.stamp);
    }
  }
  return starts;
}

/// How long each tf buffer keeps transforms: tf2 drops those older than the newest stamp less
/// this, so it must span the header stamps, not only the bag's record time (a converter may
/// write a 600 s log in 6 s of bag time; stamps may jump forward, e.g. a clock set by NTP
/// after boot). 60 s of margin; tf2 adds it to stamps, which must stay under 2^32 s (the
/// odometry has no far stamps: readOdometry skips those, as transformProblem refuses them).
ros::Duration tfCacheLength(const std::vector<OdometryArrival>& odometry, double bag_duration_s) {
  double first = std::numeric_limits<double>::infinity();
  double last = -first;
  for (const OdometryArrival& a : odometry) {
    first = std::min(first, a.stamp);
    last = std::max(last, a.stamp);
  }
  const double span = odometry.empty() ? 0.0 : last - first;
  // ros::Duration holds at most 2^31 - 1 s.
  const double headroom = std::min(2147483647.0, odometry.empty() ? 1e6 : 4294967295.0 - last - 1.0);
  return ros::Duration(std::clamp(std::max(span, bag_duration_s) + 60.0, 10.0,
                                  std::max(10.0, headroom)));
}

/// Loads every transform of the bag into one tf buffer per run (run_starts: bag times where a
/// new one begins, with the static transforms seen so far), since one buffer cannot hold two
/// runs whose stamps overlap. Repeated stamps of a child frame (common in converted logs) are
/// skipped here instead of letting tf2 warn for each, and so are transforms tf2 would refuse
/// (transformProblem; tf2 would log each one and drop it), counted in *malformed with the first
/// named in *first_malformed. Returns how many were skipped, both kinds.
long loadTransforms(const rosbag::Bag& bag, const std::vector<ros::Time>& run_starts,
                    const ros::Duration& cache, std::vector<TfSegment>* segments, long* malformed,
                    std::string* first_malformed) {
  std::map<std::string, std::set<ros::Time>> stamps_seen;  // per frame pair, this segment
  std::vector<geometry_msgs::TransformStamped> statics;
  segments->clear();
  segments->push_back({ros::Time(0), std::make_unique<tf2::BufferCore>(cache)});
  size_t next_start = 0;
  long skipped = 0;
  // tf2 warns on its own for each transform older than its buffer keeps (TF_OLD_DATA); they
  // are counted and the first named here instead.
  const console_bridge::LogLevel log_level = console_bridge::getLogLevel();
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_ERROR);
  struct RestoreLogLevel {
    console_bridge::LogLevel level;
    ~RestoreLogLevel() { console_bridge::setLogLevel(level); }
  } restore{log_level};
  rosbag::View view(bag, rosbag::TopicQuery(kTfTopics));
  for (const rosbag::MessageInstance& m : view) {
    const auto msg = instantiateOrNull<tf2_msgs::TFMessage>(m);
    if (!msg) {
      ++skipped;  // not a TFMessage, or one that does not decode
      continue;
    }
    while (next_start < run_starts.size() && m.getTime() >= run_starts[next_start]) {
      segments->push_back({run_starts[next_start++], std::make_unique<tf2::BufferCore>(cache)});
      for (const auto& t : statics) segments->back().buffer->setTransform(t, "bag", true);
      stamps_seen.clear();
    }
    tf2::BufferCore* buffer = segments->back().buffer.get();
    const bool is_static = topicIs(m.getTopic(), "tf_static");
    // Counts a transform that cannot be used, naming the first.
    const auto refuse = [&](const geometry_msgs::TransformStamped& t, const std::string& why) {
      ++skipped;
      if ((*malformed)++ > 0) return;
      char at[32];
      std::snprintf(at, sizeof(at), "%.3f", t.header.stamp.toSec());
      *first_malformed = m.getTopic() + " " + t.header.frame_id + " -> " + t.child_frame_id +
                         " at " + at + ": " + why;
    };
    for (const auto& t : msg->transforms) {
      const std::string problem = transformProblem(t);
      if (!problem.empty()) {
        refuse(t, problem);
        continue;
      }
      if (!is_static) {
        // A repeated stamp is skipped (tf2 would keep the first and complain); an older one
        // that arrives late is inserted in its place, as a node's tf2 does.
        const std::string key = t.header.frame_id + ">" + t.child_frame_id;
        if (!stamps_seen[key].insert(t.header.stamp).second) {
          ++skipped;
          continue;
        }
      }
      bool taken = false;
      try {
        taken = buffer->setTransform(t, "bag", is_static);
      } catch (const std::exception&) {
        // a stamp tf2's arithmetic cannot hold (near 2^32 s): nothing to keep
      }
      if (taken && is_static) statics.push_back(t);
      if (!taken) refuse(t, "refused by tf2 (older than its buffer keeps)");
    }
  }
  return skipped;
}

/// "'/a' (type), '/b' (type)": the bag's topics, for error messages.
std::string describeTopics(const rosbag::Bag& bag) {
  std::map<std::string, std::string> types;
  for (const rosbag::ConnectionInfo* c : rosbag::View(bag).getConnections()) {
    types[c->topic] = c->datatype;
  }
  if (types.empty()) return "no topics";
  std::string out;
  for (const auto& [topic, type] : types) {
    out += (out.empty() ? "'" : ", '") + topic + "' (" + type + ")";
  }
  return out;
}

/// Says on stderr when a start pose given on a prior grid map is off it (outside, in a wall).
void warnIfOffTheMap(const std::string& what, const core::Pose2& pose,
                     const core::SlamSession& session) {
  const std::string problem = session.offPriorMapProblem(pose);
  if (!problem.empty()) {
    std::fprintf(stderr, "offline_slam: %s: the start %s\n", what.c_str(), problem.c_str());
  }
}

/// A recorded initialpose (rviz's 2D Pose Estimate) given to the session as the node would take
/// it (fromInitialPose); one that cannot be taken is counted with the first reason.
void takeInitialPose(const rosbag::MessageInstance& m, const std::string& map_frame,
                     core::SlamSession* session, OfflineSummary* summary) {
  std::string ignored;
  try {
    const auto msg = m.instantiate<geometry_msgs::PoseWithCovarianceStamped>();
    if (!msg) {
      ignored = "a " + m.getDataType() + ", not a geometry_msgs/PoseWithCovarianceStamped";
    } else {
      core::Pose2 pose;
      Eigen::Matrix3d covariance;
      std::string note;
      ignored = fromInitialPose(*msg, map_frame, &pose, &covariance, &note);
      if (ignored.empty() && !note.empty()) {
        std::fprintf(stderr, "offline_slam: %s: covariance %s\n", m.getTopic().c_str(),
                     note.c_str());
      }
      if (ignored.empty() && !session->setPose(pose, covariance)) {
        ignored = "that the filter variant cannot take";
      }
      if (ignored.empty()) warnIfOffTheMap(m.getTopic(), pose, *session);
    }
  } catch (const std::exception& e) {
    ignored = std::string("that does not decode (") + e.what() + ")";
  }
  if (ignored.empty()) {
    ++summary->initial_poses;
  } else if (summary->ignored_initial_poses++ == 0) {
    summary->first_ignored_initial_pose = m.getTopic() + ": " + ignored;
  }
}

/// Refuses a topic of the wrong message type (e.g. scan_topic set to an odometry topic)
/// instead of counting every message as malformed.
void checkTopicTypes(rosbag::View& view, const std::string& bag_path, const io::RosOptions& ros,
                     const std::string& frontend) {
  const auto among = [](const std::string& topic, const std::vector<std::string>& names) {
    for (const std::string& name : names) {
      if (topic == stripSlash(name)) return true;
    }
    return false;
  };
  for (const rosbag::ConnectionInfo* c : view.getConnections()) {
    const std::string topic = stripSlash(c->topic);
    std::vector<std::string> allowed;
    std::string key;
    if (topic == stripSlash(ros.features_topic)) {
      allowed = {"rbpf_slam/FeatureArray"};
      key = "features_topic";
    } else if (frontend == "laser" && topic == stripSlash(ros.scan_topic)) {
      allowed = {"sensor_msgs/LaserScan"};
      key = "scan_topic";
    } else if (frontend == "sonar" && ros.sonar_source == "cloud" &&
               topic == stripSlash(ros.sonar_cloud_topic)) {
      allowed = {"sensor_msgs/PointCloud", "sensor_msgs/PointCloud2"};
      key = "sonar_cloud_topic";
    } else if (frontend == "sonar" && ros.sonar_source != "cloud" &&
               among(topic, ros.sonar_topics)) {
      allowed = {"sensor_msgs/Range"};
      key = "sonar_topic";
    }
    if (allowed.empty() ||
        std::find(allowed.begin(), allowed.end(), c->datatype) != allowed.end()) {
      continue;
    }
    std::string names;
    for (const auto& a : allowed) names += (names.empty() ? "" : " or ") + a;
    throw std::runtime_error(bag_path + ": topic '" + c->topic + "' carries " + c->datatype +
                             ", but " + key + " needs " + names);
  }
}

/// --output-bag: the input's tf, odometry and sensor messages plus what rbpf_slam_node would
/// have published (map -> odom on /tf, ~pose, ~landmarks for the landmark variants, ~map for
/// grid_pf, and ~trajectory and ~map every kTrajectoryPeriodS / kMapPeriodS of bag time and at
/// the end), for rviz.
class ResultBag {
 public:
  /// s of bag time between two ~trajectory messages: each holds the whole path so far, so the
  /// bag grows with the square of the run's length divided by this.
  static constexpr double kTrajectoryPeriodS = 10.0;
  /// s of bag time between two ~map messages (grid_pf's own grid; each a whole map).
  static constexpr double kMapPeriodS = 30.0;

  ResultBag(const std::string& path, const io::RosOptions& ros)
      : ros_(ros), bag_(makeParents(path)) {}

  void update(const ros::Time& stamp, const core::SlamSession& session) {
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = ros_.map_frame;
    const core::Pose2 map_to_odom = session.mapToOdom();
    if (map_to_odom.allFinite()) {
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(toTransformStamped(map_to_odom, ros_.map_frame, ros_.odom_frame, stamp));
      bag_.write("/tf", stamp, tf);
    }
    const core::PoseEstimate estimate = session.filter().estimate();
    if (estimate.mean.allFinite() && estimate.covariance.allFinite()) {
      geometry_msgs::PoseWithCovarianceStamped pose;
      pose.header = header;
      pose.pose.pose = toPoseMsg(estimate.mean);
      pose.pose.covariance = toPoseCovariance(estimate.covariance);
      bag_.write("/rbpf_slam_node/pose", stamp, pose);
    }
    if (session.filter().usesLandmarkFeatures()) {
      bag_.write("/rbpf_slam_node/landmarks", stamp,
                 markers_.update(session.filter().landmarks(), header));
    }
    if (due(stamp, &trajectory_written_, kTrajectoryPeriodS)) {
      bag_.write("/rbpf_slam_node/trajectory", stamp,
                 toPath(session.estimatedTrajectory(), ros_.map_frame));
    }
    if (due(stamp, &map_written_, kMapPeriodS)) writeMap(stamp, session);
  }

  /// Copies the input's tf, odometry (nav_msgs/Odometry, whatever the topic) and sensor topics
  /// and closes the bag.
  void finish(const rosbag::Bag& input, const std::vector<std::string>& sensor_topics,
              const core::SlamSession& session) {
    std::vector<std::string> topics{"/tf", "tf", "/tf_static", "tf_static"};
    topics.insert(topics.end(), sensor_topics.begin(), sensor_topics.end());
    for (const rosbag::ConnectionInfo* c : rosbag::View(input).getConnections()) {
      if (c->datatype == "nav_msgs/Odometry") topics.push_back(c->topic);
    }
    ros::Time last;
    for (const rosbag::MessageInstance& m : rosbag::View(input, rosbag::TopicQuery(topics))) {
      if (topicIs(m.getTopic(), "tf_static")) {
        // Latched (whatever the input's header said), so that rviz started after `rosbag play
        // --clock OUT.bag` began still gets the sensor mounts.
        auto header = boost::make_shared<ros::M_string>(*m.getConnectionHeader());
        (*header)["latching"] = "1";
        bag_.write(m.getTopic(), m.getTime(), m, header);
        continue;
      }
      bag_.write(m.getTopic(), m.getTime(), m);
      last = std::max(last, m.getTime());
    }
    if (!session.trajectory().empty() && !last.isZero()) {
      bag_.write("/rbpf_slam_node/trajectory", last,
                 toPath(session.estimatedTrajectory(), ros_.map_frame));
      writeMap(last, session);
    }
    bag_.commit();
  }

 private:
  /// Whether a message written at *last is period s old at stamp (or none was written, or the
  /// stamps went back); if so, *last becomes stamp.
  static bool due(const ros::Time& stamp, ros::Time* last, double period) {
    if (!last->isZero() && stamp >= *last && (stamp - *last).toSec() < period) return false;
    *last = stamp;
    return true;
  }
  /// ~map: the filter's own grid (grid_pf); the landmark variants have their markers.
  void writeMap(const ros::Time& stamp, const core::SlamSession& session) {
    core::GridMapData grid;
    if (session.filter().occupancyGrid(grid) && grid.width > 0 && grid.height > 0) {
      bag_.write("/rbpf_slam_node/map", stamp, toOccupancyGrid(grid, ros_.map_frame, stamp));
    }
  }

  static const std::string& makeParents(const std::string& path) {
    io::makeParentDirectories(path);  // an unwritable place is reported when the bag is opened
    return path;
  }

  const io::RosOptions ros_;
  PartialBag bag_;  // the output bag appears when complete
  LandmarkMarkers markers_;
  ros::Time trajectory_written_;  // the last ~trajectory's stamp
  ros::Time map_written_;         // the last ~map's stamp
};

}  // namespace

OfflineRunner::OfflineRunner(const io::SlamConfig& config, const OfflineOptions& options)
    : config_(config), options_(options), pipeline_(config.pipeline()) {
  loaded_map_ = io::applyMapConfig(config_, &pipeline_.session());
  startGlobally();
}

OfflineRunner::OfflineRunner(const io::SlamConfig& config, const OfflineOptions& options,
                             std::unique_ptr<core::SlamFilter> filter)
    : config_(config), options_(options), pipeline_(config.pipeline(), std::move(filter)) {
  loaded_map_ = io::applyMapConfig(config_, &pipeline_.session());
  startGlobally();
}

void OfflineRunner::startGlobally() {
  if (!startsGlobally()) return;
  const std::string asked =
      options_.global_localization ? "--global-localization" : "global_localization: true";
  if (options_.has_initial_pose) {
    throw std::runtime_error("--initial-pose and " + asked +
                             " exclude each other (a known start or none)");
  }
  // The config's was taken by applyMapConfig.
  if (!options_.global_localization || pipeline_.session().configuredGlobally()) return;
  std::string why;
  if (!pipeline_.session().localizeGlobally(&why)) {
    throw std::runtime_error(asked + " (" + core::SlamSession::kGlobalLocalizationNeeds +
                             "): " + why);
  }
}

std::vector<std::string> describeOutcome(const OfflineSummary& s, const OfflineOptions& options,
                                         const std::string& variant, bool* failed) {
  std::vector<std::string> lines;
  *failed = false;
  // First: a refused transform is usually why frames had no tf.
  if (s.malformed_transforms > 0) {
    lines.push_back("skipped " + std::to_string(s.malformed_transforms) +
                    " unusable transform(s); the first: " + s.first_malformed_transform);
  }
  if (s.dropped_no_tf > 0) {
    lines.push_back("dropped " + std::to_string(s.dropped_no_tf) +
                    " frame(s) without tf; the first: " + s.first_tf_error);
  }
  if (s.dropped_bad_message > 0) {
    lines.push_back("dropped " + std::to_string(s.dropped_bad_message) +
                    " malformed message(s); the first: " + s.first_bad_message);
  }
  if (s.ignored_initial_poses > 0) {
    lines.push_back("ignored " + std::to_string(s.ignored_initial_poses) +
                    " initialpose message(s); the first: " + s.first_ignored_initial_pose);
  }
  if (s.rejected > 0) {
    lines.push_back(std::to_string(s.rejected) + " frame(s) were not used: stamped before a "
                    "frame already used (inputs stamped out of order across topics or with a "
                    "lag, or a clock that went back without a restart) or with non-finite "
                    "odometry; the first: " + s.first_rejected);
  }
  if (s.dropped_features > 0) {
    lines.push_back("dropped " + std::to_string(s.dropped_features) +
                    " unusable feature(s) (non-finite values or covariance, or a negative range) "
                    "inside otherwise good FeatureArray messages");
  }
  if (s.resets > 0) {
    lines.push_back("the session started " + std::to_string(s.resets) +
                    " new map(s) (stamps went back, or a gap with gap_action: reset): the "
                    "outputs hold the last run only; " + std::to_string(s.discarded_poses) +
                    " pose(s) of the runs before are not in them");
  }
  if (s.features_rejected > 0) {
    lines.push_back("the " + variant + " filter skipped " + std::to_string(s.features_rejected) +
                    " feature(s) it cannot use (non-finite or degenerate, or of a kind it "
                    "ignores: dpf uses points with known ids only)");
  }
  if (s.updates_outside_grid > 0) {
    lines.push_back(std::to_string(s.updates_outside_grid) +
                    " update(s) with the robot outside the grid: nothing was mapped or matched "
                    "there, the pose is dead reckoning; " +
                    (!s.prior_map          ? core::kGridLimitAdvice
                     : s.initial_poses > 0 ? core::kGridOffTheMapGivenStartAdvice
                                           : core::kGridOffTheMapAdvice));
  }
  if (s.readings_beyond_reach > 0) {
    lines.push_back(std::to_string(s.readings_beyond_reach) + " reading(s) " +
                    core::kGridReachAdvice);
  }
  if (s.grid_growth_refused > 0) {
    lines.push_back(std::to_string(s.grid_growth_refused) +
                    " update(s) with readings beyond the grid, which could not grow to hold "
                    "them (they were not mapped); " +
                    core::kGridLimitAdvice);
  }
  if (s.dpf_missed_answers > 0) {
    lines.push_back(std::to_string(s.dpf_missed_answers) +
                    " local filter answer(s) did not come within dpf.step_timeout_s: those steps "
                    "were fused without them (a dpf_local_node stalled, died or restarted)");
  }
  if (s.same_stamp > 0) {
    lines.push_back(std::to_string(s.same_stamp) +
                    " frame(s) had the stamp of the frame before (another input of the same "
                    "instant, e.g. features published with their scan's stamp, or a repeated "
                    "message) and were not used");
  }
  if (s.updates == 0) {
    lines.push_back("no frame was used (" + std::to_string(s.frames) + " read, " +
                    std::to_string(s.dropped_no_tf) + " without tf, " +
                    std::to_string(s.dropped_bad_message) + " malformed, " +
                    std::to_string(s.rejected) + " rejected by the session): nothing was mapped");
    *failed = true;
  }
  if (!options.reference_path.empty() && !s.has_reference) {
    lines.push_back("--reference " + options.reference_path + " was not evaluated");
    *failed = true;
  }
  return lines;
}

OfflineSummary OfflineRunner::run() {
  OfflineSummary summary;
  // The output directory (and its parents) first, not after a long run; also where a caller
  // writes the error when the bag cannot be read.
  std::error_code error;
  std::filesystem::create_directories(options_.output_dir, error);
  if (error || !std::filesystem::is_directory(options_.output_dir)) {
    throw std::runtime_error(options_.output_dir + ": cannot create the output directory" +
                             (error ? ": " + error.message() : ""));
  }
  // Every file of the run directory is checked now: a directory or a pipe at one of them
  // would otherwise be found only after the whole bag was mapped, with the files before it
  // written and those after it not.
  for (const std::string& file : RunFiles(options_.output_dir).all(config_.smoothing.enabled)) {
    io::requireReplaceableFile(file);
  }
  if (!options_.output_bag.empty()) {
    // Also checked by the output bag itself when it opens, but that is after the tf is read.
    io::requireReplaceableFile(options_.output_bag);
    io::requireReplaceableFile(options_.output_bag + ".part");
    std::error_code same_error;
    if (std::filesystem::equivalent(options_.output_bag, options_.bag_path, same_error)) {
      throw std::runtime_error("--output-bag " + options_.output_bag + " is the input bag " +
                               options_.bag_path + ": writing it would destroy the recording");
    }
  }
  rosbag::Bag bag;
  openBagForReading(&bag, options_.bag_path);
  const auto wall_start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  rosbag::View full(bag);
  const ros::Time bag_begin = full.getBeginTime(), bag_end = full.getEndTime();
  // In seconds as doubles: a ros::Duration of bag times near 2^32 s throws.
  summary.bag_duration_s = bag_end.toSec() - bag_begin.toSec();
  const io::RosOptions& ros_options = config_.ros;
  std::vector<std::string> sensor_topics;  // the raw sensor topics of the front end, if any
  if (config_.frontend == "laser") sensor_topics = {ros_options.scan_topic};
  if (config_.frontend == "sonar") {
    sensor_topics = ros_options.sonar_source == "cloud"
                        ? std::vector<std::string>{ros_options.sonar_cloud_topic}
                        : ros_options.sonar_topics;
  }
  // grid_pf maps raw readings only: line and point features are of no use to it.
  const bool uses_features = pipeline_.session().filter().usesLandmarkFeatures();
  std::vector<std::string> topics;
  if (uses_features) {
    topics = {"/" + stripSlash(ros_options.features_topic), stripSlash(ros_options.features_topic)};
  }
  std::string wanted;  // for the message when none of them has a message
  for (const std::string& topic : sensor_topics) {
    topics.push_back("/" + stripSlash(topic));
    topics.push_back(stripSlash(topic));
    wanted += (wanted.empty() ? "'" : ", '") + topic + "'";
  }
  rosbag::View inputs(bag, rosbag::TopicQuery(topics));
  checkTopicTypes(inputs, options_.bag_path, ros_options, config_.frontend);
  if (inputs.size() == 0) {
    if (uses_features) {
      wanted += (wanted.empty() ? "'" : " or '") + ros_options.features_topic + "'";
    } else {
      wanted += " (" + config_.filter.variant + " maps raw " + config_.frontend +
                " readings, not features)";
    }
    throw std::runtime_error(options_.bag_path + ": no messages on " + wanted + "; the bag has " +
                             describeTopics(bag));
  }
  // One of several sensor topics without a message, the others with: most likely a misspelt name.
  for (const std::string& topic : sensor_topics) {
    if (sensor_topics.size() < 2) break;
    const std::vector<std::string> names{"/" + stripSlash(topic), stripSlash(topic)};
    if (rosbag::View(bag, rosbag::TopicQuery(names)).size() > 0) continue;
    std::fprintf(stderr,
                 "offline_slam: no message on sonar topic '%s' (the others of sonar_topic have "
                 "some); the bag has %s\n",
                 topic.c_str(), describeTopics(bag).c_str());
  }
  // The whole bag's tf fits in memory for the bags this runner is meant for (hours of 2D data).
  // Read after the topics are checked: on a large bag that pass takes a while.
  const std::vector<OdometryArrival> odometry =
      readOdometry(bag, stripSlash(ros_options.odom_frame), stripSlash(ros_options.base_frame));
  std::vector<TfSegment> tf_segments;
  summary.skipped_transforms = loadTransforms(
      bag,
      runStarts(odometry, config_.session.reset_on_time_jump_back_s,
                config_.session.reset_after_frames_back),
      tfCacheLength(odometry, summary.bag_duration_s), &tf_segments,
      &summary.malformed_transforms, &summary.first_malformed_transform);
  summary.tf_segments = static_cast<long>(tf_segments.size());
  std::size_t segment = 0;        // the tf segment of the current message
  std::size_t next_odometry = 0;  // the next odometry transform to tell the session of
  double last_odometry_fed = -std::numeric_limits<double>::infinity();    // stamp of the last fed
  double newest_odometry_fed = -std::numeric_limits<double>::infinity();  // ... and the newest
  std::unique_ptr<ResultBag> result_bag;
  if (!options_.output_bag.empty()) {
    result_bag = std::make_unique<ResultBag>(options_.output_bag, ros_options);
  }
  std::vector<core::Pose2> transducers;  // sonar_cloud: found in tf at the first cloud
  std::set<std::string> tilted_frames;   // warned once each
  std::set<std::string> warned_scan_headers;  // scan frames with an inconsistent header, once
  std::vector<double> update_ms;
  double particles_held = 0.0;  // summed over the updates (summary.particles_mean)
  if (!loaded_map_.empty())
    std::fprintf(stderr, "offline_slam: map_file: %s\n", loaded_map_.c_str());
  for (const std::string& note : io::configNotes(config_)) {
    std::fprintf(stderr, "offline_slam: note: %s\n", note.c_str());
  }
  if (options_.has_initial_pose) {
    if (!pipeline_.session().setPose(options_.initial_pose, options_.initial_covariance)) {
      throw std::runtime_error(
          "--initial-pose: the session refused the start pose (a "
          "non-finite pose or an unusable covariance)");
    }
    ++summary.initial_poses;
    warnIfOffTheMap("--initial-pose", options_.initial_pose, pipeline_.session());
  }
  summary.global_localization = startsGlobally();  // asked (startGlobally)
  // rviz's 2D Pose Estimate, recorded with the data: taken where it comes, as the node does.
  std::vector<std::string> read = topics;  // the inputs (copied to --output-bag) and the poses
  read.push_back("/initialpose");
  read.push_back("initialpose");
  rosbag::View view(bag, rosbag::TopicQuery(read));
  ProgressBar progress(options_.progress);
  for (const rosbag::MessageInstance& m : view) {
    if (stripSlash(m.getTopic()) == "initialpose") {
      takeInitialPose(m, ros_options.map_frame, &pipeline_.session(), &summary);
      continue;
    }
    ++summary.frames;
    std::string frame;
    ros::Time stamp;
    sensor_msgs::LaserScan::ConstPtr scan;
    sensor_msgs::Range::ConstPtr range;
    sensor_msgs::PointCloud::ConstPtr cloud;
    FeatureArray::ConstPtr features;
    // A message that does not decode (a damaged bag) is counted, not the end of the run.
    try {
      if ((scan = m.instantiate<sensor_msgs::LaserScan>())) {
        frame = scan->header.frame_id;
        stamp = scan->header.stamp;
      } else if ((range = m.instantiate<sensor_msgs::Range>())) {
        frame = range->header.frame_id;
        stamp = range->header.stamp;
      } else if ((cloud = m.instantiate<sensor_msgs::PointCloud>())) {
        frame = cloud->header.frame_id;
        stamp = cloud->header.stamp;
      } else if (const auto cloud2 = m.instantiate<sensor_msgs::PointCloud2>()) {
        // RosAria's sonar_pointcloud2: the same points.
        auto converted = boost::make_shared<sensor_msgs::PointCloud>();
        std::string error;
        if (!toPointCloud(*cloud2, converted.get(), &error)) {
          if (summary.dropped_bad_message++ == 0)
            summary.first_bad_message = m.getTopic() + ": " + error;
          continue;
        }
        cloud = converted;
        frame = cloud->header.frame_id;
        stamp = cloud->header.stamp;
      } else if ((features = m.instantiate<FeatureArray>())) {
        frame = features->header.frame_id;
        stamp = features->header.stamp;
      } else {
        if (summary.dropped_bad_message++ == 0) {
          summary.first_bad_message = m.getTopic() + ": unreadable " + m.getDataType();
        }
        continue;
      }
    } catch (const std::exception& e) {
      if (summary.dropped_bad_message++ == 0) {
        summary.first_bad_message =
            m.getTopic() + ": a message that does not decode (" + e.what() + ")";
      }
      continue;
    }
    if (frame.empty() || stamp.isZero()) {
      if (summary.dropped_bad_message++ == 0) {
        summary.first_bad_message =
            m.getTopic() + ": " + (frame.empty() ? "no frame_id" : "a zero stamp");
      }
      continue;
    }
    if (const std::string far = farStampProblem(stamp); !far.empty()) {
      if (summary.dropped_bad_message++ == 0) summary.first_bad_message = m.getTopic() + ": " + far;
      continue;
    }
    while (segment + 1 < tf_segments.size() && m.getTime() >= tf_segments[segment + 1].starts) {
      ++segment;
    }
    const tf2::BufferCore& tf = *tf_segments[segment].buffer;
    core::Pose2 odom_pose;
    SensorMount mount;
    const std::string* from = &ros_options.odom_frame;
    const std::string* to = &ros_options.base_frame;
    try {
      odom_pose = toPose2(tf.lookupTransform(ros_options.odom_frame, ros_options.base_frame,
                                             stamp).transform);
      from = &ros_options.base_frame;
      to = &frame;
      mount = toSensorMount(
          tf.lookupTransform(ros_options.base_frame, stripSlash(frame), stamp).transform);
    } catch (const std::exception& e) {
      // tf2::TransformException, or std::runtime_error from tf2's time arithmetic (a stamp
      // more than 2^31 s from the transforms it is compared with: a corrupt stamp): this frame
      // is lost, not the run.
      if (summary.dropped_no_tf++ == 0) {
        char at[32];
        std::snprintf(at, sizeof(at), "%.3f", stamp.toSec());
        const bool arithmetic = dynamic_cast<const tf2::TransformException*>(&e) == nullptr;
        summary.first_tf_error =
            *from + " -> " + *to + " at " + at + ": " +
            (arithmetic ? std::string("the stamp is too far from the bag's transforms for tf2's "
                                      "time arithmetic (a corrupt stamp?): ") +
                              e.what()
                        : std::string(e.what()));
      }
      continue;
    }
    if (isTilted(mount) && tilted_frames.insert(frame).second) {
      std::fprintf(stderr, "offline_slam: %s\n", tiltWarning(frame, mount).c_str());
    }
    // The session learns of the odometry as a node would: what the bag received up to this
    // frame, and on until a stamp at or after the frame's (the transform that made the lookup
    // possible; a node's MessageFilter waits for it), but not past stamps going back (a loop).
    while (next_odometry < odometry.size()) {
      const OdometryArrival& next = odometry[next_odometry];
      const bool bracketed = newest_odometry_fed >= stamp.toSec();
      if (next.received > m.getTime() && (bracketed || next.stamp < last_odometry_fed)) break;
      pipeline_.session().addOdometryStamp(next.stamp);
      // A loop (stamps back by more than a second) starts the newest over.
      newest_odometry_fed = next.stamp < last_odometry_fed - 1.0
                                ? next.stamp
                                : std::max(newest_odometry_fed, next.stamp);
      last_odometry_fed = next.stamp;
      ++next_odometry;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const std::size_t poses_before = pipeline_.session().trajectory().size();
    core::FrameResult result;
    if (scan) {
      core::RangeScan range_scan;
      std::string error;
      const bool usable = toRangeScan(*scan, mount.pose, &range_scan, &error, mount.upside_down);
      if (!usable) {
        if (summary.dropped_bad_message++ == 0) summary.first_bad_message = "scan: " + error;
        continue;
      }
      if (!error.empty() && warned_scan_headers.insert(frame).second) {
        // Used, but its header is inconsistent (as the node warns): said once per frame.
        std::fprintf(stderr, "offline_slam: %s (%s) at %.3f: %s\n", m.getTopic().c_str(),
                     frame.c_str(), stamp.toSec(), error.c_str());
      }
      result = pipeline_.processScan(range_scan, odom_pose);
    } else if (range) {
      core::ConeReading reading;
      std::string error;
      if (!toConeReading(*range, mount.pose, &reading, &error)) {
        if (summary.dropped_bad_message++ == 0) summary.first_bad_message = "sonar: " + error;
        continue;
      }
      result = pipeline_.processSonar({reading}, odom_pose, stamp.toSec());
    } else if (cloud) {
      if (transducers.empty()) {
        transducers = lookupTransducers(tf, ros_options.base_frame, ros_options.sonar_frame_prefix,
                                        stamp);
        if (transducers.empty()) {
          throw std::runtime_error(options_.bag_path + ": " + ros_options.sonar_cloud_topic +
                                   " needs the transducer poses, but tf has no frame " +
                                   ros_options.sonar_frame_prefix + "0 under " +
                                   ros_options.base_frame);
        }
      }
      int unmatched = 0;
      const std::vector<core::ConeReading> readings = core::coneReadingsFromCloud(
          toBasePoints(*cloud, mount.pose, mount.upside_down), transducers,
          ros_options.sonar_cloud_fov, 0.0, ros_options.sonar_cloud_max_range, stamp.toSec(),
          kCloudAxisTolerance, &unmatched);
      summary.dropped_cloud_points += unmatched;
      result = pipeline_.processSonar(readings, odom_pose, stamp.toSec());
    } else {
      int dropped = 0;
      result = pipeline_.processFeatures(
          toFeatureSet(*features, mount.pose, &dropped, mount.upside_down), odom_pose);
      summary.dropped_features += dropped;
    }
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    switch (result) {
      case core::FrameResult::kReset:
        summary.discarded_poses += static_cast<long>(poses_before);
        std::fprintf(stderr,
                     "offline_slam: %s at %.3f: the session started a new map (stamps went back, "
                     "or a gap with gap_action: reset); the %zu pose(s) before are not in the "
                     "outputs\n",
                     m.getTopic().c_str(), stamp.toSec(), poses_before);
        [[fallthrough]];
      case core::FrameResult::kUpdated:
      case core::FrameResult::kFirstFrame:
        update_ms.push_back(ms);
        summary.particles_final = static_cast<int>(pipeline_.session().filter().particles().size());
        particles_held += summary.particles_final;
        summary.features_rejected += pipeline_.session().lastStats().features_rejected;
        if (result_bag) result_bag->update(stamp, pipeline_.session());
        break;
      case core::FrameResult::kSkippedNoMotion:
        ++summary.skipped;
        break;
      case core::FrameResult::kBuffered:
        ++summary.buffered;
        break;
      case core::FrameResult::kSkippedSameStamp:
        ++summary.same_stamp;
        break;
      case core::FrameResult::kRejectedStamp:
      case core::FrameResult::kRejectedPose:
        if (summary.rejected++ == 0) {
          char text[160];
          std::snprintf(text, sizeof(text), " at %.3f: %s %.3f", stamp.toSec(),
                        result == core::FrameResult::kRejectedPose
                            ? "odometry not finite; last frame used at"
                            : "stamped before the last frame used, at",
                        pipeline_.session().lastStamp());
          summary.first_rejected = m.getTopic() + text;
        }
        break;
    }
    if (options_.verbose && (result == core::FrameResult::kUpdated)) {
      const core::UpdateStats& u = pipeline_.session().lastStats();
      const core::Pose2 p = pipeline_.session().trajectory().back().pose;
      std::fprintf(
          stderr,
          "t=%.2f lines=%zu points=%zu assoc=%d new=%d neff=%.1f resampled=%d reloc=%d "
          "pose=(%.2f %.2f %.1fdeg) %.2fms match=%d (%.3f %.3f %.4f) inl=%.2f rms=%.3f info=%.1f "
          "gaps=%ld\n",
          stamp.toSec(), pipeline_.lastFeatures().lines.size(),
          pipeline_.lastFeatures().points.size(), u.associated, u.new_landmarks, u.neff,
          u.resampled ? 1 : 0, u.relocalized, p.x(), p.y(), p.z() * 180 / M_PI, ms,
          pipeline_.lastMatch().ok ? 1 : 0, pipeline_.lastMatch().delta.x(),
          pipeline_.lastMatch().delta.y(), pipeline_.lastMatch().delta.z(),
          pipeline_.lastMatch().inlier_ratio, pipeline_.lastMatch().residual_rms_m,
          pipeline_.lastMatch().weakest_information, pipeline_.session().gaps());
      // The features of this update, base frame, with the odometry pose they were taken at.
      for (const core::LineFeature& l : pipeline_.lastFeatures().lines) {
        std::fprintf(stderr, "  line t=%.3f odom=(%.4f %.4f %.5f) rho=%.4f theta=%.5f sd=(%.4f %.5f) start=(%.3f %.3f) end=(%.3f %.3f)\n",
                     stamp.toSec(), odom_pose.x(), odom_pose.y(), odom_pose.z(), l.rho, l.theta,
                     std::sqrt(l.covariance(0, 0)), std::sqrt(l.covariance(1, 1)), l.start.x(),
                     l.start.y(), l.end.x(), l.end.y());
      }
    }
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    const double into_bag = m.getTime().toSec() - bag_begin.toSec();
    progress.show(into_bag / std::max(summary.bag_duration_s, 1e-9), wall, into_bag);
  }
  progress.done();
  if (result_bag) result_bag->finish(bag, topics, pipeline_.session());
  summary.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  summary.cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  summary.updates = static_cast<long>(update_ms.size());
  summary.tilted_frames = static_cast<long>(tilted_frames.size());
  summary.resets = pipeline_.session().resets();
  summary.gaps = pipeline_.session().gaps();
  if (!update_ms.empty()) {
    double sum = 0.0;
    for (double v : update_ms) sum += v;
    summary.update_ms_mean = sum / update_ms.size();
    std::vector<double> sorted = update_ms;
    std::sort(sorted.begin(), sorted.end());
    summary.update_ms_p99 = sorted[std::min(sorted.size() - 1,
                                            static_cast<size_t>(0.99 * sorted.size()))];
    summary.update_ms_max = sorted.back();
    summary.particles_mean = particles_held / update_ms.size();
  }
  summary.landmarks = static_cast<int>(pipeline_.session().filter().landmarks().size());
  summary.particles = config_.filter.particles;
  summary.fallbacks = pipeline_.session().filter().stats().fallbacks;
  summary.hinf_theta = pipeline_.session().filter().stats().attenuation;
  summary.relocalizations = pipeline_.session().filter().stats().relocalizations;
  summary.heading_measurements = pipeline_.session().filter().stats().heading_measurements;
  summary.robust_steps = pipeline_.session().filter().stats().robust_steps;
  summary.ensemble_leader_changes = pipeline_.session().filter().stats().leader_changes;
  summary.updates_outside_grid = pipeline_.session().filter().stats().outside_grid;
  summary.prior_map = pipeline_.session().hasPriorMap();
  summary.grid_growth_refused = pipeline_.session().filter().stats().grid_growth_refused;
  summary.readings_beyond_reach = pipeline_.session().filter().stats().readings_beyond_reach;
  summary.dpf_missed_answers = pipeline_.session().filter().stats().missed_answers;
  summary.ensemble_members = pipeline_.session().filter().members();
  summary.ensemble_leader = pipeline_.session().filter().leader();
  return writeOutputs(summary);
}

OfflineSummary OfflineRunner::writeOutputs(const OfflineSummary& in) const {
  OfflineSummary summary = in;
  const RunFiles files(options_.output_dir);  // its directory made by run() before the bag
  // The trajectory: the best particle's path when the filter keeps paths (FastSLAM's estimate
  // of the whole path, the one its map was built from, corrected by every loop it closed),
  // else the pose estimated at each update. The latter is always in trajectory_online.tum.
  std::vector<io::StampedPose> estimate, online;
  std::vector<core::Pose2> path;
  for (const auto& p : pipeline_.session().trajectory()) online.push_back({p.stamp, p.pose});
  bool use_best_path = false;
  for (const core::TrajectoryPoint& p : pipeline_.session().estimatedTrajectory(&use_best_path)) {
    estimate.push_back({p.stamp, p.pose});
    path.push_back(p.pose);
  }
  summary.trajectory_source = use_best_path ? "best_particle_path" : "online_estimate";
  std::vector<core::LandmarkEstimate> landmarks = pipeline_.session().filter().landmarks();
  if (config_.smoothing.enabled) {
    // The filter's own path and map stay beside the smoothed ones.
    io::writeTum(files.trajectory_filter, estimate);
    io::writeLandmarksYaml(files.landmarks_filter, landmarks);
    const auto start = std::chrono::steady_clock::now();
    const core::SmoothingResult smoothed =
        core::smoothSession(pipeline_.session(), config_.filter, config_.smoothing);
    summary.smoothing_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    summary.smoothing = smoothed.message;
    summary.smoothed = smoothed.ok;
    if (smoothed.ok) {
      for (size_t i = 0; i < estimate.size(); ++i) estimate[i].pose = path[i] = smoothed.path[i];
      landmarks = smoothed.landmarks;
      // The map written: on an ensemble the smoothed member's, which may not be the leader's.
      summary.landmarks = static_cast<int>(landmarks.size());
      summary.trajectory_source = "smoothed_" + summary.trajectory_source;
    } else {
      std::fprintf(stderr, "offline_slam: not smoothed (the filter's path and map are written): "
                           "%s\n", smoothed.message.c_str());
    }
  }
  io::writeTum(files.trajectory, estimate);
  io::writeTum(files.online, online);

  std::vector<core::Pose2> reference_path;
  if (!options_.reference_path.empty()) {
    // A reference that cannot be read or matched costs the comparison, not the run's outputs.
    try {
      const std::vector<io::StampedPose> reference = io::readTum(options_.reference_path);
      io::EvaluationOptions eval;
      eval.max_dt_s = 0.05;
      const io::EvaluationResult r = io::evaluateTrajectory(estimate, reference, eval);
      summary.has_reference = r.matched_poses > 1;  // the alignment needs two
      summary.ate_matched_poses = r.matched_poses;
      // An ATE over a few poses says nothing (another bag's reference, another clock): as
      // evaluate does, say so.
      if (2 * r.matched_poses < std::min(estimate.size(), reference.size())) {
        std::fprintf(stderr,
                     "offline_slam: only %ld of %zu poses matched a reference pose (%zu poses, "
                     "within 0.05 s): %s; is %s this bag's reference?\n",
                     static_cast<long>(r.matched_poses), estimate.size(), reference.size(),
                     summary.has_reference ? "the ATE covers those only" : "no ATE",
                     options_.reference_path.c_str());
      }
      summary.ate_rmse_m = r.ate_rmse_m;
      summary.final_position_error_m = r.final_position_error_m;
      summary.ate_online_rmse_m = io::evaluateTrajectory(online, reference, eval).ate_rmse_m;
      if (pipeline_.session().hasPriorMap() && summary.has_reference) {
        io::EvaluationOptions unaligned = eval;
        unaligned.align = false;
        summary.has_map_frame_ate = true;
        summary.ate_map_frame_rmse_m =
            io::evaluateTrajectory(estimate, reference, unaligned).ate_rmse_m;
      }
      // Draw the reference in the estimate's frame.
      const core::Pose2 to_estimate = core::inverse(r.alignment);
      for (const auto& p : reference) reference_path.push_back(core::compose(to_estimate, p.pose));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "offline_slam: reference not evaluated: %s\n", e.what());
    }
  }

  io::writeLandmarksYaml(files.landmarks, landmarks);

  io::JsonObjectWriter json;
  json.string("variant", config_.filter.variant)
      .unsignedInteger("seed", config_.filter.seed)
      .number("wall_s", summary.wall_s)
      .number("bag_duration_s", summary.bag_duration_s)
      .number("realtime_factor",
              summary.wall_s > 0.0 ? summary.bag_duration_s / summary.wall_s : 0.0)
      .number("cpu_s", summary.cpu_s)
      .integer("frames", summary.frames)
      .boolean("global_localization", summary.global_localization)
      .integer("initial_poses", summary.initial_poses)
      .integer("ignored_initial_poses", summary.ignored_initial_poses)
      .integer("updates", summary.updates)
      .integer("skipped_no_motion", summary.skipped)
      .integer("sonar_buffered", summary.buffered)
      .integer("rejected", summary.rejected)
      .integer("same_stamp", summary.same_stamp)
      .integer("resets", summary.resets)
      .integer("gaps", summary.gaps)
      .integer("dropped_no_tf", summary.dropped_no_tf)
      .integer("dropped_bad_message", summary.dropped_bad_message)
      .integer("skipped_transforms", summary.skipped_transforms)
      .integer("malformed_transforms", summary.malformed_transforms)
      .integer("discarded_poses", summary.discarded_poses)
      .integer("tf_segments", summary.tf_segments)
      .integer("dropped_features", summary.dropped_features)
      .integer("tilted_frames", summary.tilted_frames)
      .integer("features_rejected", summary.features_rejected)
      .integer("landmarks", summary.landmarks)
      .integer("particles", summary.particles)
      .number("particles_mean", summary.particles_mean)
      .integer("particles_final", summary.particles_final)
      .integer("fallbacks", summary.fallbacks)
      .number("hinf_theta", summary.hinf_theta)
      .integer("relocalizations", summary.relocalizations)
      .integer("heading_measurements", summary.heading_measurements)
      .integer("robust_steps", summary.robust_steps)
      .integer("ensemble_members", summary.ensemble_members)
      .integer("ensemble_leader", summary.ensemble_leader)
      .integer("ensemble_leader_changes", summary.ensemble_leader_changes)
      .integer("updates_outside_grid", summary.updates_outside_grid)
      .integer("grid_growth_refused", summary.grid_growth_refused)
      .integer("readings_beyond_reach", summary.readings_beyond_reach)
      .integer("dpf_missed_answers", summary.dpf_missed_answers)
      .number("update_ms_mean", summary.update_ms_mean)
      .number("update_ms_p99", summary.update_ms_p99)
      .number("update_ms_max", summary.update_ms_max)
      .integer("scans_matched", pipeline_.scansMatched())
      .integer("scans_unmatched", pipeline_.scansUnmatched());
  if (config_.frontend == "sonar") {
    const core::SonarExtractorStats& sonar = pipeline_.sonarExtractor().stats();
    json.integer("sonar_readings", sonar.readings)
        .integer("sonar_echoes", sonar.echoes)
        .integer("sonar_no_echo", sonar.no_echo)
        .integer("sonar_too_close", sonar.too_close)
        .integer("sonar_invalid", sonar.invalid)
        .integer("sonar_extractions", sonar.extractions)
        .integer("sonar_lines", sonar.lines)
        .integer("sonar_points", sonar.points)
        .integer("dropped_cloud_points", summary.dropped_cloud_points);
  }
  // The map in map_server conventions: the variant's grid, or its landmarks rasterised.
  core::GridMapData grid;
  const bool has_grid = pipeline_.session().filter().occupancyGrid(grid);
  try {
    if (!has_grid) {
      grid = core::rasterizeLandmarks(landmarks, config_.ros.map_resolution, 1.0,
                                      kLandmarkPointRadius);
    }
    io::writeGridMap(files.map_prefix, grid);
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "offline_slam: map.pgm not written: %s\n", e.what());
  }
  json.integer("map_width", grid.width)
      .integer("map_height", grid.height)
      .number("map_resolution", grid.resolution_m)
      .integer("map_occupied_cells", grid.count(65, 100))
      .integer("map_free_cells", grid.count(0, 19))
      .number("peak_rss_mb", peakResidentMb());
  if (summary.has_reference) {
    json.number("ate_rmse_m", summary.ate_rmse_m)
        .integer("ate_matched_poses", summary.ate_matched_poses)
        .number("ate_online_rmse_m", summary.ate_online_rmse_m)
        .number("final_position_error_m", summary.final_position_error_m);
  }
  if (summary.has_map_frame_ate) json.number("ate_map_frame_rmse_m", summary.ate_map_frame_rmse_m);
  json.string("trajectory_source", summary.trajectory_source);
  if (config_.smoothing.enabled) {
    json.boolean("smoothed", summary.smoothed)
        .number("smoothing_s", summary.smoothing_s)
        .string("smoothing", summary.smoothing);
  }
  std::ofstream summary_file(files.summary);
  summary_file << json.str();
  const bool summary_written = static_cast<bool>(summary_file.flush());
  if (has_grid) {
    io::drawGridRunMap(files.picture, grid, path, reference_path);
  } else {
    io::drawRunMap(files.picture, path, reference_path, landmarks);
  }
  if (!summary_written) throw std::runtime_error(files.summary + ": cannot be written");
  return summary;
}

}  // namespace rosbridge
}  // namespace rbpf_slam

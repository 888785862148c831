#include "rbpf_slam/ros/slam_node.h"

#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/MapMetaData.h>
#include <nav_msgs/Path.h>
#include <visualization_msgs/MarkerArray.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "rbpf_slam/core/grid/grid_map_data.h"
#include "rbpf_slam/core/grid/grid_options.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/io/grid_map_file.h"
#include "rbpf_slam/io/landmark_file.h"
#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/param_loader.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

constexpr double kMapPointRadiusM = 0.1;  // a point landmark's disc on ~map

constexpr double kTfCacheS = 30.0;
constexpr double kSummaryPeriodS = 30.0;

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

const char* describe(core::FrameResult result) {
  switch (result) {
    case core::FrameResult::kUpdated:
      return "updated";
    case core::FrameResult::kSkippedNoMotion:
      return "skipped (no motion)";
    case core::FrameResult::kFirstFrame:
      return "first frame";
    case core::FrameResult::kRejectedStamp:
      return "rejected (stamp not after the last)";
    case core::FrameResult::kRejectedPose:
      return "rejected (odometry pose not finite)";
    case core::FrameResult::kReset:
      return "first frame of a new map (the session reset)";
    case core::FrameResult::kSkippedSameStamp:
      return "skipped (the stamp of the last frame: another input of that instant, or a repeat)";
    case core::FrameResult::kBuffered:
      return "buffered (a sonar reading joined the echo window)";
  }
  return "unknown";
}

}  // namespace

SlamNode::SlamNode(ros::NodeHandle nh, ros::NodeHandle private_nh,
                   const SlamNodeCustomisation& customisation)
    : nh_(nh),
      private_nh_(private_nh),
      config_(loadConfigFromParams(private_nh, customisation.own_parameters)),
      pipeline_(customisation.make_filter
                    ? core::SlamPipeline(config_.pipeline(), customisation.make_filter(config_))
                    : core::SlamPipeline(config_.pipeline())),
      tf_buffer_(ros::Duration(kTfCacheS)),
      tf_listener_(tf_buffer_, nh, "rbpf_slam_node") {
  const io::RosOptions& ros_options = config_.ros;
  if (config_.frontend == "laser") {
    scan_input_ = subscribeFiltered(ros_options.scan_topic, &SlamNode::scanCallback);
  } else if (config_.frontend == "sonar" && ros_options.sonar_source == "cloud") {
    sonar_cloud_input_ = subscribeFiltered(std::string(), &SlamNode::sonarCloudCallback);
    sonar_cloud_subscriber_ =
        nh_.subscribe(ros_options.sonar_cloud_topic, static_cast<uint32_t>(ros_options.queue_size),
                      &SlamNode::sonarCloudArrived, this);
  } else if (config_.frontend == "sonar") {
    for (const std::string& topic : ros_options.sonar_topics) {
      sonar_inputs_.push_back(subscribeFiltered(topic, &SlamNode::sonarCallback));
    }
  }
  // grid_pf maps raw readings only; as offline_slam, the node leaves features alone.
  if (pipeline_.session().filter().usesLandmarkFeatures()) {
    features_input_ = subscribeFiltered(ros_options.features_topic, &SlamNode::featuresCallback);
  }
  odometry_tf_subscriber_ = nh_.subscribe("/tf", 100, &SlamNode::odometryTfCallback, this);

  pose_publisher_ = private_nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 10);
  trajectory_publisher_ = private_nh_.advertise<nav_msgs::Path>("trajectory", 1, true);
  if (ros_options.trajectory_publish_period > 0.0) {
    trajectory_timer_ = nh_.createWallTimer(
        ros::WallDuration(ros_options.trajectory_publish_period), &SlamNode::flushTrajectory, this);
  }
  landmarks_publisher_ =
      private_nh_.advertise<visualization_msgs::MarkerArray>("landmarks", 1, true);
  particles_publisher_ = private_nh_.advertise<geometry_msgs::PoseArray>("particles", 1);
  reset_server_ = private_nh_.advertiseService("reset", &SlamNode::resetService, this);
  pause_server_ = private_nh_.advertiseService("pause", &SlamNode::pauseService, this);
  resume_server_ = private_nh_.advertiseService("resume", &SlamNode::resumeService, this);
  save_map_server_ = private_nh_.advertiseService("save_map", &SlamNode::saveMapService, this);
  load_map_server_ = private_nh_.advertiseService("load_map", &SlamNode::loadMapService, this);
  global_localization_server_ = private_nh_.advertiseService(
      "global_localization", &SlamNode::globalLocalizationService, this);
  initial_pose_subscriber_ =
      nh_.subscribe("initialpose", 1, &SlamNode::initialPoseCallback, this);
  diagnostics_publisher_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  diagnostics_timer_ =
      nh_.createWallTimer(ros::WallDuration(1.0), &SlamNode::publishDiagnostics, this);
  // The map, localization_only and the config's global start (every run, also after ~reset).
  const std::string loaded_map = io::applyMapConfig(config_, &pipeline_.session());  // throws
  if (!config_.map_file.empty()) {
    ROS_INFO_STREAM(
        "rbpf_slam_node: started from the map "
        << config_.map_file << ", " << loaded_map << " ("
        << (config_.localization_only ? "localization only" : "mapping on") << ")"
        << (pipeline_.session().configuredGlobally() ? "" : "; set the pose with initialpose"));
  }
  for (const std::string& note : io::configNotes(config_)) {
    ROS_WARN_STREAM("rbpf_slam_node: note: " << note);
  }
  if (pipeline_.session().configuredGlobally()) {
    ROS_INFO_STREAM(
        "rbpf_slam_node: global_localization: the start is unknown; the particles "
        "will be spread over the map's free cells at the first frame");
  }
  map_publisher_ = private_nh_.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  map_metadata_publisher_ = private_nh_.advertise<nav_msgs::MapMetaData>("map_metadata", 1, true);
  dynamic_map_server_ =
      private_nh_.advertiseService("dynamic_map", &SlamNode::dynamicMapService, this);
  if (ros_options.map_update_period > 0.0) {
    map_timer_ = nh_.createTimer(ros::Duration(ros_options.map_update_period),
                                 &SlamNode::publishMap, this);
  }
  if (ros_options.transform_publish_period > 0.0) {
    transform_timer_ = nh_.createTimer(ros::Duration(ros_options.transform_publish_period),
                                       &SlamNode::publishTransform, this);
  }
  ROS_INFO_STREAM("rbpf_slam_node: " << config_.filter.variant << " with "
                                     << config_.filter.particles << " particles, frontend "
                                     << config_.frontend << ", frames " << ros_options.map_frame
                                     << " -> " << ros_options.odom_frame << " -> "
                                     << ros_options.base_frame);
}

template <typename Message>
std::unique_ptr<TfGatedSubscriber<Message>> SlamNode::subscribeFiltered(
    const std::string& topic, void (SlamNode::*callback)(const boost::shared_ptr<const Message>&)) {
  using Ptr = boost::shared_ptr<const Message>;
  typename TfGatedSubscriber<Message>::Handlers handlers;
  handlers.on_message = [this, callback](const Ptr& msg) { (this->*callback)(msg); };
  handlers.on_failure = [this](const Ptr& msg, tf2_ros::FilterFailureReason reason) {
    messageDropped(msg->header, reason);
  };
  handlers.on_unknown_frame = [this](const Ptr& msg, const std::string& error) {
    frameNotInTf(msg->header, error);
  };
  handlers.on_before_tf = [this](const Ptr& msg) { beforeTf(msg->header); };
  handlers.on_bad_stamp = [this](const Ptr& msg, const std::string& why) {
    diagnostics_.recordDrop("stamp tf cannot handle");
    warnThrottled("far stamp " + msg->header.frame_id,
                  "Dropping a message in " + msg->header.frame_id + ": " + why);
  };
  return std::make_unique<TfGatedSubscriber<Message>>(
      nh_, topic, static_cast<uint32_t>(config_.ros.queue_size), &tf_buffer_, config_.ros.base_frame,
      config_.ros.odom_frame, std::move(handlers));
}

void SlamNode::sonarCallback(const sensor_msgs::Range::ConstPtr& msg) {
  const SlamDiagnostics::BusyScope busy(&diagnostics_);
  if (!readyForFrame()) return;
  core::Pose2 odom_pose;
  SensorMount mount;
  if (!lookupPoses(msg->header, &odom_pose, &mount)) return;
  core::ConeReading reading;
  std::string error;
  if (!toConeReading(*msg, mount.pose, &reading, &error)) {
    warnThrottled("sonar " + msg->header.frame_id,
                  "Dropping a sonar reading from " + msg->header.frame_id + ": " + error);
    diagnostics_.recordDrop("bad sonar reading");
    return;
  }
  if (!std::isfinite(reading.range)) {
    warnThrottled("sonar range " + msg->header.frame_id,
                  "Sonar " + msg->header.frame_id +
                      " sent a non-finite range (counted as no echo)");
  }
  const auto t0 = std::chrono::steady_clock::now();
  const core::FrameResult result =
      pipeline_.processSonar({reading}, odom_pose, msg->header.stamp.toSec());
  handleResult(result, msg->header.stamp, millisecondsSince(t0));
}

void SlamNode::sonarCloudArrived(const topic_tools::ShapeShifter::ConstPtr& msg) {
  const SlamDiagnostics::BusyScope busy(&diagnostics_);
  const std::string& type = msg->getDataType();
  // Decoding happens here, not in roscpp: a message that does not decode (a truncated one
  // from a damaged bag) must be dropped, not end the node.
  try {
    if (type == "sensor_msgs/PointCloud") {
      sonar_cloud_input_->add(msg->instantiate<sensor_msgs::PointCloud>());
      return;
    }
    if (type == "sensor_msgs/PointCloud2") {
      auto cloud = boost::make_shared<sensor_msgs::PointCloud>();
      std::string error;
      if (toPointCloud(*msg->instantiate<sensor_msgs::PointCloud2>(), cloud.get(), &error)) {
        sonar_cloud_input_->add(cloud);
        return;
      }
      diagnostics_.recordDrop("bad sonar cloud");
      warnThrottled("sonar cloud2", "Dropping a sonar_cloud PointCloud2: " + error);
      return;
    }
  } catch (const std::exception& e) {
    diagnostics_.recordDrop("bad sonar cloud");
    warnThrottled("sonar cloud decode",
                  "Dropping a sonar_cloud " + type + " that does not decode: " + e.what());
    return;
  }
  diagnostics_.recordDrop("sonar cloud of another type");
  warnThrottled("sonar cloud type", config_.ros.sonar_cloud_topic + " carries " + type +
                                        ": sonar_cloud must be sensor_msgs/PointCloud or "
                                        "PointCloud2");
}

void SlamNode::sonarCloudCallback(const sensor_msgs::PointCloud::ConstPtr& msg) {
  const SlamDiagnostics::BusyScope busy(&diagnostics_);
  constexpr double kAxisTolerance = 0.05;  // m: a cloud point lies on its transducer's axis
  if (!readyForFrame()) return;
  core::Pose2 odom_pose;
  SensorMount cloud_frame;
  if (!lookupPoses(msg->header, &odom_pose, &cloud_frame)) return;
  const io::RosOptions& o = config_.ros;
  // The whole ring (it used to stop at sonar_0), looked up at every cloud: static transforms
  // of a ring may come in one by one after the first cloud.
  std::vector<core::Pose2> ring =
      lookupTransducers(tf_buffer_, o.base_frame, o.sonar_frame_prefix, ros::Time(0));
  if (ring.empty()) {
    diagnostics_.recordDrop("no sonar transducer in tf");
    warnThrottled("sonar transducers", "sonar_cloud needs the transducer poses, but tf has "
                                       "no frame " + o.sonar_frame_prefix + "0 under " +
                                       o.base_frame);
    return;
  }
  if (ring.size() != sonar_transducers_.size()) {
    ROS_INFO_STREAM("rbpf_slam_node: sonar_cloud read through " << ring.size()
                    << " transducer(s), " << o.sonar_frame_prefix << "0.." << ring.size() - 1
                    << " in tf");
  }
  sonar_transducers_ = std::move(ring);
  int unmatched = 0;
  const std::vector<core::ConeReading> readings = core::coneReadingsFromCloud(
      toBasePoints(*msg, cloud_frame.pose, cloud_frame.upside_down), sonar_transducers_,
      o.sonar_cloud_fov, 0.0, o.sonar_cloud_max_range, msg->header.stamp.toSec(), kAxisTolerance,
      &unmatched);
  if (unmatched > 0) {
    diagnostics_.recordDrop("sonar cloud point off every axis", unmatched);
    warnThrottled("sonar cloud points", std::to_string(unmatched) +
                                            " sonar_cloud point(s) lie on no transducer's axis");
  }
  const auto t0 = std::chrono::steady_clock::now();
  const core::FrameResult result =
      pipeline_.processSonar(readings, odom_pose, msg->header.stamp.toSec());
  handleResult(result, msg->header.stamp, millisecondsSince(t0));
}

void SlamNode::scanCallback(const sensor_msgs::LaserScan::ConstPtr& msg) {
  const SlamDiagnostics::BusyScope busy(&diagnostics_);
  if (!readyForFrame()) return;
  core::Pose2 odom_pose;
  SensorMount mount;
  if (!lookupPoses(msg->header, &odom_pose, &mount)) return;
  core::RangeScan scan;
  std::string error;
  const bool ok = toRangeScan(*msg, mount.pose, &scan, &error, mount.upside_down);
  if (!error.empty()) warnThrottled("scan header " + msg->header.frame_id, "Scan: " + error);
  if (!ok) {
    diagnostics_.recordDrop("bad scan");
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const core::FrameResult result = pipeline_.processScan(scan, odom_pose);
  handleResult(result, msg->header.stamp, millisecondsSince(t0));
}

void SlamNode::featuresCallback(const FeatureArray::ConstPtr& msg) {
  const SlamDiagnostics::BusyScope busy(&diagnostics_);
  if (!readyForFrame()) return;
  core::Pose2 odom_pose;
  SensorMount frame;
  if (!lookupPoses(msg->header, &odom_pose, &frame)) return;
  int dropped = 0;
  const core::FeatureSet features = toFeatureSet(*msg, frame.pose, &dropped, frame.upside_down);
  if (dropped > 0) {
    diagnostics_.recordDrop("non-finite feature", dropped);
    warnThrottled("non-finite features", "Dropped " + std::to_string(dropped) +
                                             " feature(s) with non-finite values from " +
                                             features_input_->topic());
  }
  const int unusable = countUnusableCovariances(features);
  if (unusable > 0 && config_.filter.measurement.use_feature_covariance) {
    diagnostics_.recordReplacedCovariances(unusable);
    warnThrottled("feature covariances",
                  unusableCovarianceWarning(unusable, features_input_->topic()));
  }
  const auto t0 = std::chrono::steady_clock::now();
  const core::FrameResult result = pipeline_.processFeatures(features, odom_pose);
  handleResult(result, msg->header.stamp, millisecondsSince(t0));
}

void SlamNode::odometryTfCallback(const tf2_msgs::TFMessage::ConstPtr& msg) {
  const SlamDiagnostics::BusyScope busy(&diagnostics_);
  const std::string odom = stripSlash(config_.ros.odom_frame);
  const std::string base = stripSlash(config_.ros.base_frame);
  for (const auto& t : msg->transforms) {
    if (stripSlash(t.child_frame_id) == base && stripSlash(t.header.frame_id) == odom) {
      pipeline_.session().addOdometryStamp(t.header.stamp.toSec());
    }
  }
}

void SlamNode::frameNotInTf(const std_msgs::Header& header, const std::string& tf_error) {
  const std::string& base = config_.ros.base_frame;
  diagnostics_.recordDrop("frame not in tf");
  warnThrottled("frame " + header.frame_id,
                "Dropping a message in frame '" + header.frame_id + "': tf has no transform " +
                    base + " -> " + header.frame_id + " (" + tf_error +
                    "); is the frame name right and its transform published?");
}

void SlamNode::beforeTf(const std_msgs::Header& header) {
  // Stamped before tf's first transform on its way (a driver that publishes its readings before
  // its odometry, every cycle; a bag recorded from such a driver): it can never be placed.
  // Normal at start-up, so counted and said once.
  diagnostics_.recordExpectedDrop("stamped before tf's first transform");
  if (!said_before_first_transform_) {
    said_before_first_transform_ = true;
    ROS_INFO_STREAM("rbpf_slam_node: messages stamped before tf's first transform to "
                    << config_.ros.odom_frame << " (e.g. from " << header.frame_id
                    << ") cannot be placed and are dropped (normal at start-up)");
  }
}

void SlamNode::messageDropped(const std_msgs::Header& header, tf2_ros::FilterFailureReason reason) {
  const std::string& odom = config_.ros.odom_frame;
  diagnostics_.recordDrop(reason == tf2_ros::filter_failure_reasons::EmptyFrameID ? "empty frame_id"
                          : reason == tf2_ros::filter_failure_reasons::OutTheBack
                              ? "older than the tf cache"
                              : "no tf in time");
  switch (reason) {
    case tf2_ros::filter_failure_reasons::EmptyFrameID:
      warnThrottled("empty frame_id", "Dropping a message with an empty header.frame_id");
      break;
    case tf2_ros::filter_failure_reasons::OutTheBack: {
      warnThrottled("too old " + header.frame_id,
                    "Dropping a message in " + header.frame_id + " stamped " +
                        std::to_string(header.stamp.toSec()) +
                        ": older than the tf cache (is the node too slow, or the clock wrong?)");
      // Sensor stamps that went back while the clock did not (a restarted driver, two logs in
      // one bag): tf refuses the old-stamped odometry too, so nothing would ever be processed
      // again. As for a clock jump, several such frames in a row start a new map.
      const core::SessionOptions& session = config_.session;
      const double behind = pipeline_.session().lastStamp() - header.stamp.toSec();
      if (session.reset_on_time_jump_back_s > 0.0 && !pipeline_.session().trajectory().empty() &&
          behind > session.reset_on_time_jump_back_s &&
          ++stale_drops_in_a_row_ >= session.reset_after_frames_back) {
        std::ostringstream why;
        why << "sensor stamps went back by " << behind << " s while the clock did not";
        resetAll(why.str());
      }
      break;
    }
    default:
      warnThrottled("no tf " + header.frame_id,
                    "Dropping a message: no transform " + odom + " -> " + header.frame_id +
                        " at its stamp " + std::to_string(header.stamp.toSec()) +
                        " came in time (the topic's tf queue of " +
                        std::to_string(config_.ros.queue_size) +
                        " filled up, or tf's cache moved past the stamp); is " + odom + " -> " +
                        config_.ros.base_frame + " -> " + header.frame_id + " published?");
      break;
  }
}

bool SlamNode::lookupPoses(const std_msgs::Header& header, core::Pose2* odom_pose,
                           SensorMount* frame_mount) {
  const io::RosOptions& o = config_.ros;
  const std::string* from = &o.odom_frame;
  const std::string* to = &o.base_frame;
  try {
    *odom_pose =
        toPose2(tf_buffer_.lookupTransform(o.odom_frame, o.base_frame, header.stamp).transform);
    from = &o.base_frame;
    to = &header.frame_id;
    // tf2 refuses frame names with a leading '/' (old drivers and bags still write them).
    const geometry_msgs::Transform mount =
        tf_buffer_.lookupTransform(o.base_frame, stripSlash(header.frame_id), header.stamp)
            .transform;
    *frame_mount = toSensorMount(mount);
  } catch (const tf2::TransformException& e) {
    diagnostics_.recordDrop("tf lookup failed");
    warnThrottled("tf " + *from + " -> " + *to, "No transform " + *from + " -> " + *to + " at " +
                                                    std::to_string(header.stamp.toSec()) + ": " +
                                                    e.what());
    return false;
  }
  if (!odom_pose->allFinite() || !frame_mount->pose.allFinite()) {
    diagnostics_.recordDrop("tf not finite");
    warnThrottled("non-finite tf", "tf gave a non-finite pose for " + o.odom_frame + " -> " +
                                       o.base_frame + " -> " + header.frame_id);
    return false;
  }
  if (isTilted(*frame_mount)) {
    warnThrottled("tilt " + header.frame_id, tiltWarning(header.frame_id, *frame_mount));
  }
  return true;
}

void SlamNode::handleResult(core::FrameResult result, const ros::Time& stamp, double update_ms) {
  ROS_DEBUG_STREAM("Frame at " << stamp << ": " << describe(result));
  if (result == core::FrameResult::kReset) {
    // The session threw the map away itself: stamps far back several frames in a row, or an
    // odometry gap with gap_action: reset. Said and counted like the node's own resets.
    diagnostics_.recordReset();
    ROS_WARN_STREAM("rbpf_slam_node: frame at " << stamp << ": " << describe(result)
                                                << " (stamps went back, or an odometry gap with "
                                                   "gap_action: reset)");
  }
  if (result == core::FrameResult::kSkippedSameStamp) {
    diagnostics_.recordSameStamp();  // counted, not a problem (slam_session.h)
    return;
  }
  if (result != core::FrameResult::kUpdated && result != core::FrameResult::kFirstFrame &&
      result != core::FrameResult::kReset) {
    if (result == core::FrameResult::kRejectedStamp || result == core::FrameResult::kRejectedPose) {
      warnThrottled(describe(result), std::string("Frame ") + describe(result));
      diagnostics_.recordDrop(result == core::FrameResult::kRejectedStamp ? "stamp not after the last"
                                                                         : "odometry not finite");
    }
    return;
  }
  diagnostics_.recordUpdate(update_ms);
  ++updates_;
  stale_drops_in_a_row_ = 0;
  const int rejected = pipeline_.session().lastStats().features_rejected;
  if (rejected > 0) {
    diagnostics_.recordSkippedFeatures(rejected);
    warnThrottled("features rejected",
                  "The " + config_.filter.variant + " filter skipped " + std::to_string(rejected) +
                      " feature(s) of the frame at " + std::to_string(stamp.toSec()) +
                      ": non-finite or degenerate, or of a kind it ignores (dpf uses points "
                      "with known ids only)");
  }
  const core::FilterStats stats = pipeline_.session().filter().stats();
  ROS_INFO_STREAM_THROTTLE(kSummaryPeriodS,
                           "rbpf_slam_node: " << updates_ << " updates, " << stats.landmarks
                                              << " landmarks, Neff " << stats.last_neff << ", "
                                              << stats.resamples << " resamples");
  // After a reset the old map's path must not stay up for a period.
  publishState(stamp, result == core::FrameResult::kReset);
}

void SlamNode::publishState(const ros::Time& stamp, bool trajectory_now) {
  const core::SlamSession& session = pipeline_.session();
  const core::PoseEstimate estimate = session.filter().estimate();
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = config_.ros.map_frame;
  if (estimate.mean.allFinite() && estimate.covariance.allFinite()) {
    geometry_msgs::PoseWithCovarianceStamped pose;
    pose.header = header;
    pose.pose.pose = toPoseMsg(estimate.mean);
    pose.pose.covariance = toPoseCovariance(estimate.covariance);
    pose_publisher_.publish(pose);
  } else {
    warnThrottled("non-finite estimate", "The filter's estimate is not finite; not published");
  }
  publishTrajectory(trajectory_now);
  publishLandmarks(stamp);
  if (config_.ros.publish_particles && particles_publisher_.getNumSubscribers() > 0) {
    particles_publisher_.publish(toPoseArray(session.filter().particles(), header));
  }
}

bool SlamNode::currentMap(const ros::Time& stamp, nav_msgs::OccupancyGrid* map) {
  core::GridMapData grid;
  if (!pipeline_.session().filter().occupancyGrid(grid)) {
    try {
      grid = core::rasterizeLandmarks(pipeline_.session().filter().landmarks(),
                                      config_.ros.map_resolution, 1.0, kMapPointRadiusM);
    } catch (const std::runtime_error& e) {
      warnThrottled("map", std::string("No map: ") + e.what());
      return false;
    }
  }
  *map = toOccupancyGrid(grid, config_.ros.map_frame, stamp);
  return true;
}

void SlamNode::publishMap(const ros::TimerEvent&) {
  // Nothing new; before the first update only a map loaded from a file.
  if (updates_ == map_published_at_update_ ||
      (updates_ == 0 && !pipeline_.session().hasPriorMap())) {
    return;
  }
  nav_msgs::OccupancyGrid map;
  if (!currentMap(ros::Time::now(), &map)) return;
  map_published_at_update_ = updates_;
  map_metadata_publisher_.publish(map.info);
  map_publisher_.publish(map);
}

bool SlamNode::dynamicMapService(nav_msgs::GetMap::Request&, nav_msgs::GetMap::Response& response) {
  return currentMap(ros::Time::now(), &response.map);
}

void SlamNode::publishLandmarks(const ros::Time& stamp) {
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = config_.ros.map_frame;
  landmarks_publisher_.publish(
      landmark_markers_.update(pipeline_.session().filter().landmarks(), header));
}

void SlamNode::publishTransform(const ros::TimerEvent&) {
  if (!checkClock()) return;
  const ros::Time stamp = ros::Time::now() + ros::Duration(config_.ros.transform_tolerance);
  if (stamp <= last_transform_stamp_) return;  // the clock has not moved (paused bag)
  const core::Pose2 map_to_odom = pipeline_.session().mapToOdom();
  if (!map_to_odom.allFinite()) {
    warnThrottled("non-finite map->odom", "map -> odom is not finite; not published");
    return;
  }
  geometry_msgs::TransformStamped transform;
  transform.header.stamp = stamp;
  transform.header.frame_id = config_.ros.map_frame;
  transform.child_frame_id = config_.ros.odom_frame;
  transform.transform = toTransform(map_to_odom);
  tf_broadcaster_.sendTransform(transform);
  last_transform_stamp_ = stamp;
}

bool SlamNode::resetService(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  resetAll("reset requested through " + reset_server_.getService(),
           core::SlamSession::ResetCause::kRequested);
  return true;
}

bool SlamNode::globalLocalizationService(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  std::string why;
  if (!pipeline_.session().localizeGlobally(&why)) {
    ROS_ERROR_STREAM("rbpf_slam_node: " << global_localization_server_.getService() << " refused ("
                                        << core::SlamSession::kGlobalLocalizationNeeds
                                        << "): " << why);
    return false;
  }
  if (!pipeline_.session().started()) {
    // Nothing to publish yet: the estimate is not spread until the first frame.
    ROS_INFO_STREAM(
        "rbpf_slam_node: global localization: the particles will be spread over the "
        "map's free cells at the first frame");
    return true;
  }
  ROS_INFO_STREAM(
      "rbpf_slam_node: particles spread over the map's free cells (global "
      "localization); they gather as the robot moves and observes");
  const ros::Time now = ros::Time::now();
  if (!now.isZero()) publishState(now, true);  // simulated time: not before the first /clock
  return true;
}

bool SlamNode::pauseService(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  if (!paused_) ROS_INFO("rbpf_slam_node: paused (frames are ignored, map -> odom still published)");
  paused_ = true;
  return true;
}

bool SlamNode::resumeService(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  if (paused_) {
    ROS_INFO_STREAM("rbpf_slam_node: resumed after ignoring " << frames_while_paused_
                                                             << " frame(s)");
  }
  paused_ = false;
  frames_while_paused_ = 0;
  return true;
}

bool SlamNode::saveMapService(MapFile::Request& request, MapFile::Response& response) {
  // A relative prefix is the node's working directory (roslaunch's: $ROS_HOME, ~/.ros), not the
  // caller's: the reply names the absolute paths written.
  std::string prefix = request.path.empty() ? config_.ros.map_save_prefix : request.path;
  try {
    prefix = std::filesystem::absolute(prefix).lexically_normal().string();
    std::vector<core::LandmarkEstimate> landmarks = pipeline_.session().filter().landmarks();
    std::string smoothing;
    if (config_.smoothing.enabled) {
      // The saved map is smoothed over every frame so far; the filter itself is left as it is.
      const core::SmoothingResult smoothed =
          core::smoothSession(pipeline_.session(), config_.filter, config_.smoothing);
      if (smoothed.ok) landmarks = smoothed.landmarks;
      smoothing = (smoothed.ok ? " (smoothed: " : " (not smoothed: ") + smoothed.message + ")";
    }
    io::writeLandmarksYaml(prefix + ".landmarks.yaml", landmarks);
    core::GridMapData occupancy;  // grid variants save their own grid, not the landmarks'
    const std::vector<std::string> grid =
        pipeline_.session().filter().occupancyGrid(occupancy)
            ? io::writeGridMap(prefix, occupancy)
            : io::writeLandmarkGrid(prefix, landmarks);
    response.success = true;
    response.message = "wrote " + std::to_string(landmarks.size()) + " landmarks to " + prefix +
                       ".landmarks.yaml and the picture to " + grid[0] + " + " + grid[1] +
                       smoothing;
    ROS_INFO_STREAM("rbpf_slam_node: save_map: " << response.message);
  } catch (const std::exception& e) {
    response.success = false;
    response.message = std::string("save_map failed: ") + e.what();
    ROS_ERROR_STREAM("rbpf_slam_node: " << response.message);
  }
  return true;
}

std::string SlamNode::loadedMapAdvice() const {
  const core::SlamSession& session = pipeline_.session();
  std::string why_not;
  if (session.startsGlobally(&why_not))
    return "; the run starts spread over it (global localization)";
  // The config's global start applies from the next ~reset on.
  if (why_not.empty() && session.started() && session.configuredGlobally() &&
      session.canLocalizeGlobally(&why_not)) {
    return "; set the robot's pose on it with initialpose, or spread the particles over it "
           "with ~global_localization (the config's global start: also at the next ~reset)";
  }
  return why_not.empty() ? "; set the robot's pose on it with initialpose"
                         : "; global localization cannot be done on it (" + why_not +
                               "): set the robot's pose with initialpose";
}

bool SlamNode::loadMapService(MapFile::Request& request, MapFile::Response& response) {
  const std::string path = request.path.empty() ? config_.map_file : request.path;
  response.success = false;
  if (path.empty()) {
    response.message = "load_map: no path given and ~map_file is not set";
  } else {
    try {
      const std::string loaded = io::loadPriorMap(path, &pipeline_.session());
      response.success = true;
      response.message = "loaded " + loaded + " from " + path + loadedMapAdvice();
      if (pipeline_.session().filter().usesLandmarkFeatures()) {
        publishLandmarks(ros::Time::now());
      }
      map_published_at_update_ = -1;  // the next map timer publishes the loaded map
    } catch (const std::exception& e) {
      response.message = std::string("load_map failed: ") + e.what();
    }
  }
  if (response.success) {
    ROS_INFO_STREAM("rbpf_slam_node: " << response.message);
  } else {
    ROS_ERROR_STREAM("rbpf_slam_node: " << response.message);
  }
  return true;
}

void SlamNode::initialPoseCallback(const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& msg) {
  core::Pose2 pose;
  Eigen::Matrix3d covariance;
  std::string note;
  const std::string ignored =
      fromInitialPose(*msg, config_.ros.map_frame, &pose, &covariance, &note);
  if (!ignored.empty()) {
    warnThrottled("initialpose", "Ignoring an initialpose " + ignored);
    return;
  }
  if (!note.empty()) warnThrottled("initialpose covariance", "initialpose covariance " + note);
  if (!pipeline_.session().setPose(pose, covariance)) {
    warnThrottled("initialpose", "Ignoring an initialpose that the filter variant cannot take");
    return;
  }
  ROS_INFO_STREAM("rbpf_slam_node: pose set to (" << pose.x() << ", " << pose.y() << ", "
                                                  << pose.z() << " rad) from initialpose");
  const std::string off = pipeline_.session().offPriorMapProblem(pose);
  if (!off.empty()) ROS_WARN_STREAM("rbpf_slam_node: initialpose: the start " << off);
  const ros::Time now = ros::Time::now();
  publishState(now.isZero() ? msg->header.stamp : now, true);  // ~trajectory's source changed
}

bool SlamNode::readyForFrame() {
  if (!checkClock()) return false;
  if (paused_) {
    ++frames_while_paused_;
    return false;
  }
  return true;
}

bool SlamNode::checkClock() {
  const ros::Time now = ros::Time::now();
  if (now.isZero()) return false;  // simulated time before the first /clock
  if (!last_now_.isZero() && now < last_now_) {
    std::ostringstream why;
    why << "time jumped back by " << (last_now_ - now).toSec() << " s (bag restarted?)";
    resetAll(why.str());
    // Only a clock that went back lets map -> odom stamps start over; after any other reset
    // (sensor stamps back, ~reset) the next one must still be later than the last one sent.
    last_transform_stamp_ = ros::Time();
  }
  last_now_ = now;
  return true;
}

std::string SlamNode::inputTopics() const {
  const io::RosOptions& o = config_.ros;
  std::vector<std::string> topics;
  if (scan_input_) topics.push_back(o.scan_topic);
  if (!sonar_inputs_.empty())
    topics.insert(topics.end(), o.sonar_topics.begin(), o.sonar_topics.end());
  if (sonar_cloud_input_) topics.push_back(o.sonar_cloud_topic);
  if (features_input_) topics.push_back(o.features_topic);
  std::string text;
  for (const std::string& topic : topics) {
    text += (text.empty() ? "'" : ", '") + nh_.resolveName(topic) + "'";
  }
  return text.empty() ? "no topic" : text;
}

void SlamNode::publishDiagnostics(const ros::WallTimerEvent&) {
  // A user who got a topic or frame name wrong sees nothing happen: say what is awaited.
  constexpr double kSilentInputWarnS = 15.0;
  const double waited = (ros::WallTime::now() - started_).toSec();
  if (updates_ == 0 && !paused_ && waited >= kSilentInputWarnS) {
    const io::RosOptions& o = config_.ros;
    std::ostringstream why;
    why << "no update in " << static_cast<int>(waited) << " s: waiting for " << inputTopics()
        << " and tf " << o.odom_frame << " -> " << o.base_frame
        << " (check the names against `rostopic list` and the config's *_topic / *_frame keys)";
    warnThrottled("no input", why.str());
  }
  // One of several sonar topics silent for kSilentInputWarnS while another has been talking
  // (not merely since the node started: a driver's topics come up one by one): most likely a
  // misspelt name.
  if (sonar_inputs_.size() > 1) {
    const TfGatedSubscriber<sensor_msgs::Range>* talking = nullptr;
    for (const auto& input : sonar_inputs_) {
      if (input->received() > 0 &&
          (!talking || input->firstReceived() < talking->firstReceived())) {
        talking = input.get();
      }
    }
    const double talked = talking ? (ros::WallTime::now() - talking->firstReceived()).toSec() : 0.0;
    for (const auto& input : sonar_inputs_) {
      if (!talking || talked < kSilentInputWarnS || input->received() > 0) continue;
      if (!silent_sonar_topics_.insert(input->topic()).second) continue;  // said once
      ROS_WARN_STREAM("rbpf_slam_node: no message on sonar topic '"
                      << input->topic() << "' while '" << talking->topic() << "' has had them for "
                      << static_cast<int>(talked)
                      << " s: check the name in sonar_topic against `rostopic list`");
    }
  }
  diagnostics_.setPaused(paused_);
  diagnostics_.setActivity(pipeline_.session().mapping() ? "mapping" : "localizing (mapping off)");
  diagnostics_.setOdometryGaps(pipeline_.session().gaps());
  // grid_pf's limits: a warning when a count grew since the last report.
  const core::FilterStats stats = pipeline_.session().filter().stats();
  if (stats.outside_grid > grid_seen_.outside_grid) {
    warnThrottled("outside grid",
                  std::string("the robot is outside the grid: nothing is mapped "
                              "or matched there and the pose is dead "
                              "reckoning; ") +
                      (pipeline_.session().hasPriorMap() ? core::kGridOffTheMapAdvice
                                                         : core::kGridLimitAdvice));
  }
  if (stats.grid_growth_refused > grid_seen_.grid_growth_refused) {
    warnThrottled("grid growth", std::string("readings beyond the grid are not mapped: the grid "
                                             "could not grow to hold them; ") +
                                     core::kGridLimitAdvice);
  }
  if (stats.readings_beyond_reach > grid_seen_.readings_beyond_reach) {
    warnThrottled("grid reach",
                  std::to_string(stats.readings_beyond_reach - grid_seen_.readings_beyond_reach) +
                      " reading(s) " + core::kGridReachAdvice);
  }
  grid_seen_ = stats;
  if (const long refused = tf_listener_.takeRefused()) {
    diagnostics_.recordDrop("refused transform", refused);
  }
  const ros::Time now = ros::Time::now();
  diagnostics_publisher_.publish(
      diagnostics_.report(now.isZero() ? ros::Time(ros::WallTime::now().toSec()) : now, stats,
                          static_cast<int>(pipeline_.session().filter().particles().size())));
  // Input coming faster than it is handled overflows the topic's queue, which roscpp empties
  // without a word: say it when the inputs take most of the time (the report's own figure).
  const double busy = diagnostics_.lastBusyFraction();
  if (busy > diagnostics_.options().busy_fraction) {
    std::ostringstream why;
    why << "handling input " << std::lround(100.0 * busy)
        << " % of the time: the node falls behind its input, and the topic's queue (queue_size "
        << config_.ros.queue_size << ") drops frames unseen when full; play the bag slower, "
        << "or lower particles (or ensemble.members), or raise linear_update / angular_update";
    warnThrottled("busy", why.str());
  }
}

void SlamNode::resetAll(const std::string& why, core::SlamSession::ResetCause cause) {
  diagnostics_.recordReset();
  grid_seen_ = core::FilterStats();  // the filter's counts start over
  ROS_WARN_STREAM("rbpf_slam_node: " << why << ": clearing the map, the trajectory and tf");
  pipeline_.reset(cause);  // filter, history and the scan matcher's reference
  std::string why_not;
  if (pipeline_.session().startsGlobally(&why_not)) {
    // The config's global start (kept by ~reset), or one asked before a restarted run.
    ROS_INFO_STREAM(
        "rbpf_slam_node: the next run starts spread over the map's free cells at its "
        "first frame (global localization)");
  } else if (!why_not.empty()) {
    ROS_WARN_STREAM("rbpf_slam_node: global localization after the reset: " << why_not);
  }
  tf_listener_.clear();  // the buffer and the stamps the listener has taken
  if (scan_input_) scan_input_->clear();
  for (const auto& input : sonar_inputs_) input->clear();
  if (sonar_cloud_input_) sonar_cloud_input_->clear();
  if (features_input_) features_input_->clear();
  updates_ = 0;
  started_ = ros::WallTime::now();  // the "nothing arrives" warning waits afresh
  map_published_at_update_ = -1;  // the new map's first grid is published like the first one
  stale_drops_in_a_row_ = 0;
  publishLandmarks(ros::Time::now());  // DELETE for every landmark shown
  publishTrajectory(true);             // the empty path
}

void SlamNode::publishTrajectory(bool now) {
  const double period = config_.ros.trajectory_publish_period;
  const ros::WallTime wall = ros::WallTime::now();
  if (!now && period > 0.0) {
    // Nobody listening: nothing is built; the flush timer sends the path once someone is (a
    // latecomer first gets the latched older path). The timer ticks every period, so a pending
    // path waits at most about two periods.
    if (trajectory_publisher_.getNumSubscribers() == 0 ||
        (wall - trajectory_published_at_).toSec() < 0.999 * period) {
      trajectory_pending_ = true;
      return;
    }
  }
  trajectory_publisher_.publish(
      toPath(pipeline_.session().estimatedTrajectory(), config_.ros.map_frame));
  trajectory_published_at_ = wall;
  trajectory_pending_ = false;
}

void SlamNode::flushTrajectory(const ros::WallTimerEvent&) {
  if (trajectory_pending_) publishTrajectory(false);  // still at most once per period
}

}  // namespace rosbridge
}  // namespace rbpf_slam

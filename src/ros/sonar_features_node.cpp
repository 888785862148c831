#include "rbpf_slam/ros/sonar_features_node.h"

#include <rbpf_slam/FeatureArray.h>

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/param_loader.h"

namespace rbpf_slam {
namespace rosbridge {
SonarFeaturesNode::SonarFeaturesNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : config_(loadConfigFromParams(private_nh)),
      extractor_(config_.sonar),
      tf_listener_(tf_buffer_, nh, "sonar_features"),
      diagnostics_("sonar_features", DiagnosticsOptions::withoutFilter("extracting features")),
      clock_(config_.session) {
  if (config_.ros.sonar_source != "range") {
    throw std::invalid_argument("sonar_source = '" + config_.ros.sonar_source +
                                "': sonar_features reads sensor_msgs/Range (sonar_source: "
                                "range); give sonar_cloud to rbpf_slam_node directly");
  }
  using Ptr = sensor_msgs::Range::ConstPtr;
  TfGatedSubscriber<sensor_msgs::Range>::Handlers handlers;
  handlers.on_message = [this](const Ptr& msg) { sonarCallback(msg); };
  handlers.on_failure = [this](const Ptr& msg, tf2_ros::FilterFailureReason reason) {
    messageDropped(msg, reason);
  };
  handlers.on_bad_stamp = [this](const Ptr& msg, const std::string& why) {
    drop("stamp tf cannot handle", "far stamp " + msg->header.frame_id,
         "Dropping a sonar reading from " + msg->header.frame_id + ": " + why);
  };
  handlers.on_unknown_frame = [this](const Ptr& msg, const std::string& error) {
    drop("frame not in tf", "frame " + msg->header.frame_id,
         "Dropping a sonar reading in frame '" + msg->header.frame_id + "': tf has no transform " +
             config_.ros.base_frame + " -> " + msg->header.frame_id + " (" + error +
             "); is the frame name right and its transform published?");
  };
  handlers.on_before_tf = [this](const Ptr& msg) {
    // Stamped before the earliest transform tf holds (a driver that publishes its readings
    // before its first odometry): normal at start-up, counted, not warned.
    diagnostics_.recordExpectedDrop("stamped before tf's first transform");
    ROS_DEBUG_STREAM("sonar_features: a reading from "
                     << msg->header.frame_id << " stamped before tf's earliest transform");
  };
  // Echoes are placed by odometry, so wait for odom -> base as well as base -> transducer.
  for (const std::string& topic : config_.ros.sonar_topics) {
    sonar_inputs_.push_back(std::make_unique<TfGatedSubscriber<sensor_msgs::Range>>(
        nh, topic, static_cast<uint32_t>(config_.ros.queue_size), &tf_buffer_,
        config_.ros.base_frame, config_.ros.odom_frame, handlers));
  }
  features_publisher_ = nh.advertise<FeatureArray>(config_.ros.features_topic, 10);
  diagnostics_publisher_ = nh.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  diagnostics_timer_ =
      nh.createWallTimer(ros::WallDuration(1.0), &SonarFeaturesNode::publishDiagnostics, this);
}

void SonarFeaturesNode::sonarCallback(const sensor_msgs::Range::ConstPtr& msg) {
  const SlamDiagnostics::BusyScope busy(&diagnostics_);
  const double stamp = msg->header.stamp.toSec();
  if (!(stamp > 0.0)) {
    // tf reads a zero stamp as "the latest", so it passed the gate; the window would take it as
    // a clock gone back.
    drop("zero stamp", "zero stamp " + msg->header.frame_id,
         "Dropping a sonar reading from " + msg->header.frame_id + " with a zero stamp");
    return;
  }
  // As the SLAM pipeline does (ClockRestartDetector, slam_session.h; SlamPipeline::processSonar):
  // stamps far back for long enough, with nothing in order in between, are a restarted clock (a
  // looping bag) and clear the window; a ring far back once is dropped and the window kept; a
  // reading a little late (transducers stamped apart, two publishers) joins the window but
  // extracts nothing (features at an earlier stamp than the last published would be refused).
  const auto verdict = clock_.classify(stamp, last_stamp_);
  if (verdict == core::ClockRestartDetector::Verdict::kRestart) {
    warnings_.warn("time jump", "Sonar stamps went back by " +
                                    std::to_string(last_stamp_ - stamp) +
                                    " s and stayed back: clearing the echo window");
    extractor_.reset();
    diagnostics_.recordReset();
  } else if (stamp < last_stamp_ && (verdict == core::ClockRestartDetector::Verdict::kLate ||
                                     extractor_.wouldClearWindow(stamp))) {
    drop("old stamp", "old stamp " + msg->header.frame_id,
         "Dropping a sonar reading from " + msg->header.frame_id + " stamped " +
             std::to_string(last_stamp_ - stamp) + " s before the newest one");
    return;
  }
  const bool late = stamp < last_stamp_;
  if (!late) last_stamp_ = stamp;
  core::Pose2 odom_pose, sensor_in_base;
  try {
    odom_pose = toPose2(tf_buffer_
                            .lookupTransform(config_.ros.odom_frame, config_.ros.base_frame,
                                             msg->header.stamp)
                            .transform);
    sensor_in_base =
        toPose2(tf_buffer_
                    .lookupTransform(config_.ros.base_frame, stripSlash(msg->header.frame_id),
                                     msg->header.stamp)
                    .transform);
  } catch (const tf2::TransformException& e) {
    drop("no tf", "tf " + msg->header.frame_id, std::string("No transform: ") + e.what());
    return;
  }
  core::ConeReading reading;
  std::string error;
  if (!toConeReading(*msg, sensor_in_base, &reading, &error)) {
    drop("bad sonar reading", "sonar " + msg->header.frame_id,
         "Dropping a sonar reading from " + msg->header.frame_id + ": " + error);
    return;
  }
  if (!std::isfinite(reading.range)) {
    warnings_.warn("sonar range " + msg->header.frame_id,
                   "Sonar " + msg->header.frame_id +
                       " sent a non-finite range (no feature from it; counted as invalid)");
  }
  const auto t0 = std::chrono::steady_clock::now();
  extractor_.addReadings({reading}, odom_pose, stamp);
  if (late || !extractor_.extractionDue(odom_pose)) return;
  std_msgs::Header header;
  header.stamp = msg->header.stamp;
  header.frame_id = config_.ros.base_frame;
  features_publisher_.publish(toMsg(extractor_.extract(odom_pose, stamp), header));
  ++published_;
  diagnostics_.recordUpdate(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
}

void SonarFeaturesNode::messageDropped(const sensor_msgs::Range::ConstPtr& msg,
                                       tf2_ros::FilterFailureReason reason) {
  if (reason == tf2_ros::filter_failure_reasons::EmptyFrameID) {
    drop("empty frame_id", "empty frame_id",
         "Dropping a sonar reading with an empty header.frame_id");
  } else {
    drop(reason == tf2_ros::filter_failure_reasons::OutTheBack ? "older than the tf cache"
                                                              : "no tf in time",
         "no tf " + msg->header.frame_id,
         "Dropping a sonar reading: no transform " + config_.ros.odom_frame + " -> " +
             config_.ros.base_frame + " -> " + msg->header.frame_id + " at " +
             std::to_string(msg->header.stamp.toSec()));
  }
}

void SonarFeaturesNode::drop(const std::string& cause, const std::string& key,
                             const std::string& message) {
  diagnostics_.recordDrop(cause);
  warnings_.warn(key, message);
}

void SonarFeaturesNode::publishDiagnostics(const ros::WallTimerEvent&) {
  if (const long refused = tf_listener_.takeRefused()) {
    diagnostics_.recordDrop("refused transform", refused);
  }
  const ros::Time now = ros::Time::now();
  diagnostics_publisher_.publish(diagnostics_.report(
      now.isZero() ? ros::Time(ros::WallTime::now().toSec()) : now, core::FilterStats(), 0));
}

}  // namespace rosbridge
}  // namespace rbpf_slam

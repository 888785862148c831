#include "rbpf_slam/ros/landmark_tracker_node.h"

#include <rbpf_slam/TrackerEvent.h>
#include <visualization_msgs/MarkerArray.h>

#include <chrono>
#include <cmath>

#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/param_loader.h"

namespace rbpf_slam {
namespace rosbridge {
LandmarkTrackerNode::LandmarkTrackerNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : config_(loadConfigFromParams(private_nh)),
      frontend_(config_.filter),
      clock_(config_.session),
      tf_listener_(tf_buffer_, nh, "landmark_tracker"),
      diagnostics_("landmark_tracker", DiagnosticsOptions::withoutFilter("tracking")) {
  using Ptr = FeatureArray::ConstPtr;
  TfGatedSubscriber<FeatureArray>::Handlers handlers;
  handlers.on_message = [this](const Ptr& msg) { featuresCallback(msg); };
  handlers.on_failure = [this](const Ptr& msg, tf2_ros::FilterFailureReason reason) {
    messageDropped(msg, reason);
  };
  handlers.on_bad_stamp = [this](const Ptr& msg, const std::string& why) {
    drop("stamp tf cannot handle", "far stamp", "Dropping features in frame '" +
                                                    msg->header.frame_id + "': " + why);
  };
  handlers.on_unknown_frame = [this](const Ptr& msg, const std::string& error) {
    drop("frame not in tf", "frame " + msg->header.frame_id,
         "Dropping features in frame '" + msg->header.frame_id + "': tf has no transform " +
             config_.ros.base_frame + " -> " + msg->header.frame_id + " (" + error + ")");
  };
  features_input_ = std::make_unique<TfGatedSubscriber<FeatureArray>>(
      nh, config_.ros.features_topic, static_cast<uint32_t>(config_.ros.queue_size), &tf_buffer_,
      config_.ros.base_frame, config_.ros.odom_frame, std::move(handlers));
  events_publisher_ = nh.advertise<TrackerEvent>("tracker/events", 100);
  landmarks_publisher_ = nh.advertise<visualization_msgs::MarkerArray>("tracker/landmarks", 1, true);
  diagnostics_publisher_ = nh.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  diagnostics_timer_ =
      nh.createWallTimer(ros::WallDuration(1.0), &LandmarkTrackerNode::publishDiagnostics, this);
}

void LandmarkTrackerNode::featuresCallback(const FeatureArray::ConstPtr& msg) {
  const SlamDiagnostics::BusyScope busy(&diagnostics_);
  const io::RosOptions& o = config_.ros;
  core::Pose2 odom_pose;
  SensorMount frame;
  try {
    odom_pose =
        toPose2(tf_buffer_.lookupTransform(o.odom_frame, o.base_frame, msg->header.stamp).transform);
    frame = toSensorMount(
        tf_buffer_
            .lookupTransform(o.base_frame, stripSlash(msg->header.frame_id), msg->header.stamp)
            .transform);
  } catch (const tf2::TransformException& e) {
    drop("no tf", "tf " + msg->header.frame_id, std::string("No transform: ") + e.what());
    return;
  }
  if (isTilted(frame)) {
    warnings_.warn("tilt " + msg->header.frame_id, tiltWarning(msg->header.frame_id, frame));
  }
  int dropped = 0;
  core::FeatureSet features = toFeatureSet(*msg, frame.pose, &dropped, frame.upside_down);
  if (dropped > 0) {
    diagnostics_.recordDrop("non-finite feature", dropped);
    warnings_.warn("non-finite features", "Dropped " + std::to_string(dropped) +
                                              " feature(s) with non-finite values from " +
                                              config_.ros.features_topic);
  }
  const int unusable = countUnusableCovariances(features);
  if (unusable > 0 && config_.filter.measurement.use_feature_covariance) {
    diagnostics_.recordReplacedCovariances(unusable);
    warnings_.warn("feature covariances",
                   unusableCovarianceWarning(unusable, config_.ros.features_topic));
  }
  // Another input of the same instant (e.g. a second feature source): skipped and counted,
  // not a problem, as the SLAM pipeline does (FrameResult::kSkippedSameStamp).
  if (frontend_.atLastStamp(features.stamp)) {
    diagnostics_.recordSameStamp();
    return;
  }
  // Stamps far behind the last frame: a bag played again or a restarted driver, told from a
  // late message as the SLAM pipeline does (ClockRestartDetector, slam_session.h): only stamps
  // far back for long enough, with nothing in order in between, start the tracker over. One
  // late message used to throw every tracked landmark away and raise a spurious event.
  using Verdict = core::ClockRestartDetector::Verdict;
  const Verdict verdict = clock_.classify(
      features.stamp, frontend_.steps() > 0 ? frontend_.lastStamp() : -INFINITY);
  if (verdict == Verdict::kLate) {
    drop("old stamp", "old stamp",
         "Dropping a feature frame stamped " + std::to_string(features.stamp) + ", " +
             std::to_string(frontend_.lastStamp() - features.stamp) +
             " s before the last one (a late message; the tracker starts over only when the "
             "stamps stay back, reset_after_frames_back / reset_on_time_jump_back)");
    return;
  }
  if (verdict == Verdict::kRestart) {
    warnings_.warn("time jump", "Feature stamps went back by " +
                                    std::to_string(frontend_.lastStamp() - features.stamp) +
                                    " s and stayed back: the tracker starts over");
    frontend_.reset();
    diagnostics_.recordReset();
  }
  const auto t0 = std::chrono::steady_clock::now();
  core::TrackerEvent event;
  std::string why;
  if (!frontend_.process(features, odom_pose, &event, &why)) {
    drop(why, why, "Dropping a feature frame stamped " +
                       std::to_string(msg->header.stamp.toSec()) + ": " + why);
    return;
  }
  diagnostics_.recordUpdate(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  if (frontend_.lastRejected() > 0) {
    diagnostics_.recordSkippedFeatures(frontend_.lastRejected());
    warnings_.warn("features rejected",
                   "The tracker skipped " + std::to_string(frontend_.lastRejected()) +
                       " feature(s) of the frame at " + std::to_string(msg->header.stamp.toSec()) +
                       ": not finite or degenerate (e.g. a point at range 0)");
  }
  if (event.left_out_full > 0) {
    warnings_.warn("tracker full",
                   "The tracker holds tracker.max_landmarks = " +
                       std::to_string(config_.filter.tracker.max_landmarks) +
                       " landmarks, all seen in the frame at " +
                       std::to_string(msg->header.stamp.toSec()) + ": " +
                       std::to_string(event.left_out_full) +
                       " new sighting(s) left out (no event for them); raise it if this lasts");
  }
  std_msgs::Header header;
  header.stamp = msg->header.stamp;
  header.frame_id = o.odom_frame;
  if (event.new_landmark) {
    TrackerEvent out;
    out.header = header;
    out.step = event.step;
    out.started = event.started;
    out.matched = event.matched;
    out.forgotten = event.forgotten;
    out.tracked = event.tracked;
    events_publisher_.publish(out);
  }
  landmarks_publisher_.publish(markers_.update(frontend_.landmarks(), header));
}

void LandmarkTrackerNode::messageDropped(const FeatureArray::ConstPtr& msg,
                                         tf2_ros::FilterFailureReason reason) {
  if (reason == tf2_ros::filter_failure_reasons::EmptyFrameID) {
    drop("empty frame_id", "empty frame_id", "Dropping features with an empty header.frame_id");
  } else {
    drop(reason == tf2_ros::filter_failure_reasons::OutTheBack ? "older than the tf cache"
                                                              : "no tf in time",
         "no tf " + msg->header.frame_id,
         "Dropping features: no transform " + config_.ros.odom_frame + " -> " +
             config_.ros.base_frame + " -> " + msg->header.frame_id + " at " +
             std::to_string(msg->header.stamp.toSec()));
  }
}

void LandmarkTrackerNode::drop(const std::string& cause, const std::string& key,
                               const std::string& message) {
  diagnostics_.recordDrop(cause);
  warnings_.warn(key, message);
}

void LandmarkTrackerNode::publishDiagnostics(const ros::WallTimerEvent&) {
  if (const long refused = tf_listener_.takeRefused()) {
    diagnostics_.recordDrop("refused transform", refused);
  }
  const ros::Time now = ros::Time::now();
  diagnostics_publisher_.publish(diagnostics_.report(
      now.isZero() ? ros::Time(ros::WallTime::now().toSec()) : now, core::FilterStats(), 0));
}

}  // namespace rosbridge
}  // namespace rbpf_slam

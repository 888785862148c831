#include "rbpf_slam/ros/sonar_features_node.h"

#include <rbpf_slam/FeatureArray.h>

#include <stdexcept>

#include "rbpf_slam/ros/conversions.h"
#include "rbpf_slam/ros/param_loader.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

constexpr double kWarningPeriodS = 10.0;

}  // namespace

SonarFeaturesNode::SonarFeaturesNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : config_(loadConfigFromParams(private_nh)),
      extractor_(config_.sonar),
      tf_listener_(tf_buffer_, nh) {
  if (config_.ros.sonar_source != "range") {
    throw std::invalid_argument("sonar_source = '" + config_.ros.sonar_source +
                                "': sonar_features reads sensor_msgs/Range (sonar_source: "
                                "range); give sonar_cloud to rbpf_slam_node directly");
  }
  const uint32_t queue = static_cast<uint32_t>(config_.ros.queue_size);
  sonar_subscriber_.subscribe(nh, config_.ros.sonar_topic, queue);
  // Echoes are placed by odometry, so wait for odom -> base as well as base -> transducer.
  sonar_filter_ = std::make_unique<tf2_ros::MessageFilter<sensor_msgs::Range>>(
      sonar_subscriber_, tf_buffer_, config_.ros.odom_frame, queue, nh);
  sonar_filter_->registerCallback(&SonarFeaturesNode::sonarCallback, this);
  sonar_filter_->registerFailureCallback(
      [this](const sensor_msgs::Range::ConstPtr& msg, tf2_ros::FilterFailureReason r) {
        messageDropped(msg, r);
      });
  features_publisher_ = nh.advertise<FeatureArray>(config_.ros.features_topic, 10);
}

void SonarFeaturesNode::sonarCallback(const sensor_msgs::Range::ConstPtr& msg) {
  const double stamp = msg->header.stamp.toSec();
  if (stamp + config_.session.reset_on_time_jump_back_s < last_stamp_) {
    warnThrottled("time jump", "Sonar stamps went back by " + std::to_string(last_stamp_ - stamp) +
                                   " s: clearing the echo window");
    extractor_.reset();
  } else if (stamp < last_stamp_) {
    warnThrottled("old stamp", "Dropping a sonar reading older than the last one");
    return;
  }
  last_stamp_ = stamp;
  core::Pose2 odom_pose, sensor_in_base;
  try {
    odom_pose = toPose2(tf_buffer_
                            .lookupTransform(config_.ros.odom_frame, config_.ros.base_frame,
                                             msg->header.stamp)
                            .transform);
    sensor_in_base = toPose2(
        tf_buffer_.lookupTransform(config_.ros.base_frame, msg->header.frame_id, msg->header.stamp)
            .transform);
  } catch (const tf2::TransformException& e) {
    warnThrottled("tf " + msg->header.frame_id, std::string("No transform: ") + e.what());
    return;
  }
  core::ConeReading reading;
  std::string error;
  if (!toConeReading(*msg, sensor_in_base, &reading, &error)) {
    warnThrottled("sonar " + msg->header.frame_id,
                  "Dropping a sonar reading from " + msg->header.frame_id + ": " + error);
    return;
  }
  extractor_.addReadings({reading}, odom_pose, stamp);
  if (!extractor_.extractionDue(odom_pose)) return;
  std_msgs::Header header;
  header.stamp = msg->header.stamp;
  header.frame_id = config_.ros.base_frame;
  features_publisher_.publish(toMsg(extractor_.extract(odom_pose, stamp), header));
  ++published_;
}

void SonarFeaturesNode::messageDropped(const sensor_msgs::Range::ConstPtr& msg,
                                       tf2_ros::FilterFailureReason reason) {
  if (reason == tf2_ros::filter_failure_reasons::EmptyFrameID) {
    warnThrottled("empty frame_id", "Dropping a sonar reading with an empty header.frame_id");
  } else {
    warnThrottled("no tf " + msg->header.frame_id,
                  "Dropping a sonar reading: no transform " + config_.ros.odom_frame + " -> " +
                      config_.ros.base_frame + " -> " + msg->header.frame_id + " at " +
                      std::to_string(msg->header.stamp.toSec()));
  }
}

void SonarFeaturesNode::warnThrottled(const std::string& cause, const std::string& message) {
  const ros::WallTime now = ros::WallTime::now();
  auto it = last_warning_.find(cause);
  if (it != last_warning_.end() && (now - it->second).toSec() < kWarningPeriodS) return;
  last_warning_[cause] = now;
  ROS_WARN_STREAM("sonar_features: " << message);
}

}  // namespace rosbridge
}  // namespace rbpf_slam

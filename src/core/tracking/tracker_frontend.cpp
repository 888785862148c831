#include "rbpf_slam/core/tracking/tracker_frontend.h"

#include <cmath>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/measurement_models.h"

namespace rbpf_slam {
namespace core {

std::vector<TrackerObservation> toTrackerObservations(const std::vector<Observation>& observations) {
  std::vector<TrackerObservation> out(observations.size());
  for (size_t i = 0; i < observations.size(); ++i) {
    out[i].type = observations[i].type;
    out[i].z = observations[i].z;
    out[i].noise = observations[i].noise;
    out[i].start = observations[i].start;
    out[i].end = observations[i].end;
  }
  return out;
}

TrackerFrontend::TrackerFrontend(const FilterOptions& options)
    : options_(options), motion_model_(createMotionModel(options.motion)), tracker_(options.tracker) {}

void TrackerFrontend::reset() {
  tracker_.reset();
  anchored_ = false;
  anchor_ = last_odom_ = Pose2::Zero();
  last_stamp_ = 0.0;
  step_ = 0;
  last_rejected_ = 0;
}

bool TrackerFrontend::process(const FeatureSet& features, const Pose2& odom_pose,
                              TrackerEvent* event, std::string* why) {
  if (!odom_pose.allFinite()) {
    *why = "odometry pose not finite";
    return false;
  }
  if (!std::isfinite(features.stamp) || !(features.stamp > 0.0)) {
    // A NaN stamp kept as the last one would refuse every later frame (!(t > NaN)).
    *why = "stamp not finite or not positive";
    return false;
  }
  if (anchored_ && !(features.stamp > last_stamp_)) {
    *why = "stamp not after the last";
    return false;
  }
  MotionInput motion;
  if (anchored_) {
    motion.stamp = features.stamp;
    motion.dt = features.stamp - last_stamp_;
    motion.delta = between(last_odom_, odom_pose);
  } else {
    anchor_ = odom_pose;
    anchored_ = true;
  }
  last_odom_ = odom_pose;
  last_stamp_ = features.stamp;
  last_rejected_ = 0;
  const std::vector<Observation> prepared =
      prepareObservations(features, options_, &last_rejected_);
  const std::vector<TrackerObservation> observations = toTrackerObservations(prepared);
  // The increment's covariance in the previous base frame (the motion model's, from zero).
  *event = tracker_.update(++step_, motion.delta,
                           motion_model_->covariance(Pose2::Zero(), motion), observations);
  return true;
}

std::vector<LandmarkEstimate> TrackerFrontend::landmarks() const {
  std::vector<LandmarkEstimate> out = tracker_.landmarks();
  for (LandmarkEstimate& e : out) {
    if (e.type == LandmarkType::kLine) {
      // A line of the tracker's frame is an observation from the anchor's pose.
      Eigen::Matrix2d jacobian;
      e.mean = lineFromObservation(anchor_, e.mean, &jacobian);
      e.covariance = jacobian * e.covariance * jacobian.transpose();
    } else {
      const double c = std::cos(anchor_.z()), s = std::sin(anchor_.z());
      Eigen::Matrix2d r;
      r << c, -s, s, c;
      e.mean = transformPoint(anchor_, e.mean);
      e.covariance = r * e.covariance * r.transpose();
    }
    e.start = transformPoint(anchor_, e.start);
    e.end = transformPoint(anchor_, e.end);
  }
  return out;
}

Pose2 TrackerFrontend::pose() const { return compose(anchor_, tracker_.pose()); }

}  // namespace core
}  // namespace rbpf_slam

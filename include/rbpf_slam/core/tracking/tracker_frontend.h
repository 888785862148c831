#pragma once
// The landmark tracker on its own (the `landmark_tracker` node): feature frames with the
// odometry pose of each in, the tracker's steps out. The robust filter runs the same tracker
// inside itself; this is for watching it, or for feeding its events to something else.

#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/motion/motion_model.h"
#include "rbpf_slam/core/tracking/landmark_tracker.h"

namespace rbpf_slam {
namespace core {

struct Observation;

/// The filter's prepared observations as the tracker takes them.
std::vector<TrackerObservation> toTrackerObservations(const std::vector<Observation>& observations);

class TrackerFrontend {
 public:
  /// Uses options.tracker, the observation noise of options.measurement, options.use_lines /
  /// use_points and the odometry noise of options.motion; throws std::invalid_argument on bad
  /// tracker options.
  explicit TrackerFrontend(const FilterOptions& options);

  /// Starts over: the next frame anchors the tracker's frame at its odometry pose.
  void reset();
  /// One feature frame (base frame) taken at odom_pose. False, with the reason in *why, when
  /// the frame cannot be used (non-finite pose, stamp not after the last); *event is then
  /// untouched.
  bool process(const FeatureSet& features, const Pose2& odom_pose, TrackerEvent* event,
               std::string* why);

  /// The tracked landmarks and the robot in the odometry frame.
  std::vector<LandmarkEstimate> landmarks() const;
  Pose2 pose() const;
  int steps() const { return step_; }
  /// A frame at exactly the last processed frame's stamp (another input of that instant): the
  /// node skips it and counts it, as the SLAM session does (kSkippedSameStamp); process()
  /// would refuse it as not after the last.
  bool atLastStamp(double stamp) const { return anchored_ && stamp == last_stamp_; }
  double lastStamp() const { return last_stamp_; }
  /// Features of the last processed frame that could not be used (not finite or degenerate,
  /// e.g. a point at range 0; kinds the options turn off are not counted).
  int lastRejected() const { return last_rejected_; }

 private:
  const FilterOptions options_;
  std::unique_ptr<MotionModel> motion_model_;
  LandmarkTracker tracker_;
  bool anchored_ = false;
  Pose2 anchor_ = Pose2::Zero();     // odometry pose of the first frame = tracker origin
  Pose2 last_odom_ = Pose2::Zero();  // odometry pose of the last frame
  double last_stamp_ = 0.0;
  int step_ = 0;
  int last_rejected_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

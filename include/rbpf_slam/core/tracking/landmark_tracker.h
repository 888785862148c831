#pragma once
// Landmark tracker of Lee, Kim and Chung (ICRA 2010, sec. III): an independent short-horizon
// EKF-SLAM over the robot pose and the nearby landmarks, with its own nearest-neighbour
// association, that reports when the robot starts observing a landmark it was not tracking
// (the timing of the robust filter's multi-ancestor sampling) and forgets landmarks left behind.

#include <Eigen/Core>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/tracking/landmark_tracker_options.h"

namespace rbpf_slam {
namespace core {

/// One observation for the tracker: a point (range, bearing) or a line (rho, theta) in the
/// base frame, with its noise covariance.
struct TrackerObservation {
  LandmarkType type = LandmarkType::kPoint;
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix2d noise = Eigen::Matrix2d::Identity();
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // line: observed extent, base frame
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
};

/// What one tracker step found.
struct TrackerEvent {
  int step = 0;               // the step passed to update()
  bool new_landmark = false;  // at least one observation started a landmark
  int started = 0;            // landmarks started at this step
  int matched = 0;            // observations associated with tracked landmarks (or with one
                              // started by another observation of this step)
  int forgotten = 0;          // landmarks dropped at this step
  int tracked = 0;            // landmarks in the state after this step
  int left_out_full = 0;      // new sightings not started: max_landmarks, all seen this step
};

class LandmarkTracker {
 public:
  explicit LandmarkTracker(const LandmarkTrackerOptions& options);

  /// Forgets every landmark; the tracker's frame restarts at the robot.
  void reset();
  /// Prediction with the odometry increment (base frame of the previous step) and its
  /// covariance in that frame, then the EKF update with the observations of `step`.
  TrackerEvent update(int step, const Pose2& increment, const Eigen::Matrix3d& increment_cov,
                      const std::vector<TrackerObservation>& observations);

  int trackedLandmarks() const { return static_cast<int>(landmarks_.size()); }
  /// The tracked landmarks in the tracker's frame, with ids stable while tracked (a landmark
  /// forgotten and met again gets a new id) and, for lines, the extent observed so far.
  std::vector<LandmarkEstimate> landmarks() const;
  /// The robot pose in the tracker's own frame (origin: the pose at reset).
  Pose2 pose() const { return state_.head<3>(); }
  const Eigen::VectorXd& state() const { return state_; }
  const Eigen::MatrixXd& covariance() const { return covariance_; }

 private:
  struct Tracked {
    LandmarkType type = LandmarkType::kPoint;
    int last_seen_step = 0;
    int id = 0;
    int observations = 0;
    double extent_min = 0.0, extent_max = 0.0;  // line: along its direction, tracker frame
    bool has_extent = false;  // a line seen with usable end points at least once
  };
  /// A line observation's distance along tracked line `landmark` beyond the extent seen so far
  /// (0 when they overlap, or when the observation gives no extent).
  double gapToExtent(int landmark, const TrackerObservation& observation) const;
  /// From `at` (tracker frame) to a point, or to the nearest point of a line's extent.
  double distanceTo(int landmark, const Eigen::Vector2d& at) const;
  /// Widens a line's extent by the observation's end points, when it has usable ones.
  void extend(int landmark, const TrackerObservation& observation);
  /// Finite end points at least 1 um apart (unset ones in a message are both zero).
  static bool usableExtent(const TrackerObservation& observation);
  void predict(const Pose2& increment, const Eigen::Matrix3d& increment_cov);
  /// Index of the tracked landmark nearest in Mahalanobis distance among those from index
  /// `first` on, -1 when none.
  int associate(const TrackerObservation& observation, int first, double* distance2) const;
  /// The EKF correction with an observation of `landmark`, which was seen at `step`.
  void see(int landmark, const TrackerObservation& observation, int step);
  void correct(int landmark, const TrackerObservation& observation);
  void start(const TrackerObservation& observation, int step);
  void remove(int landmark);
  int forget(int step);
  /// The landmark last seen longest ago, before before_step (the farthest of equals); -1: none.
  int leastRecentlySeen(int before_step) const;

  const LandmarkTrackerOptions options_;
  Eigen::VectorXd state_;  // pose (x, y, theta), then two entries per landmark
  Eigen::MatrixXd covariance_;
  std::vector<Tracked> landmarks_;
  int next_id_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// The node's health on /diagnostics (diagnostic_msgs): effective sample size, landmark
// count, update time, share of the time spent on frames, frames processed, dropped messages by
// cause, resets, pause state.

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/time.h>

#include <map>
#include <string>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace rosbridge {

/// Thresholds that turn the status to WARN.
struct DiagnosticsOptions {
  double low_neff_fraction = 0.1;  // Neff below this fraction of the particles
  double slow_update_ms = 200.0;   // mean update time above this
  /// Share of the wall time spent handling frames above this: the node cannot keep up, and a
  /// topic's queue drops frames before the node sees them (roscpp says nothing of it).
  double busy_fraction = 0.9;
  /// false for a node without a filter (a feature extractor): the report leaves out Neff,
  /// particles, landmarks, resamples, weight resets and fallbacks.
  bool filter_fields = true;

  /// For a node without a filter (feature extraction, the landmark tracker).
  static DiagnosticsOptions withoutFilter() {
    DiagnosticsOptions options;
    options.filter_fields = false;
    return options;
  }
};

/// Counts what happened since the last report and builds one DiagnosticStatus from it.
class SlamDiagnostics {
 public:
  explicit SlamDiagnostics(std::string name, DiagnosticsOptions options = DiagnosticsOptions())
      : name_(std::move(name)), options_(options) {}

  const DiagnosticsOptions& options() const { return options_; }

  /// One frame processed in update_ms of wall time (counted as busy time too).
  void recordUpdate(double update_ms);
  /// More wall time spent on frames beyond their updates (what is published after them).
  void recordBusy(double ms) { busy_ms_period_ += ms; }
  /// The share of wall_period_s spent on frames since the last report (0 without a period).
  double busyFraction(double wall_period_s) const {
    return wall_period_s > 0.0 ? busy_ms_period_ / (1000.0 * wall_period_s) : 0.0;
  }
  /// The same over the wall time since the last report.
  double busyFractionNow() const {
    return busyFraction((ros::WallTime::now() - last_report_wall_).toSec());
  }
  /// Something that could not be used (a message, or `count` features or points of one);
  /// cause is a short fixed phrase ("no tf", "bad scan").
  void recordDrop(const std::string& cause, long count = 1);
  void recordReset() { ++resets_total_; }
  /// Features of used frames that the filter skipped (a kind it ignores, degenerate):
  /// reported as a count, not as a problem (dpf on line features would warn for ever).
  void recordSkippedFeatures(long count) { skipped_features_total_ += count; }
  /// Frames at the stamp of the last frame (another input of the same instant): a count, not
  /// a problem.
  void recordSameStamp() { ++same_stamp_total_; }
  /// Steps taken across an odometry gap so far (SlamSession::gaps); reported once set.
  void setOdometryGaps(long total) { odometry_gaps_ = total; }
  void setPaused(bool paused) { paused_ = paused; }

  /// The report for the period since the previous call (then the period counters restart),
  /// with the share of the wall time since then spent on frames.
  diagnostic_msgs::DiagnosticArray report(const ros::Time& stamp, const core::FilterStats& stats,
                                          int particles);
  /// The same over a given wall period (0: no busy share), for tests.
  diagnostic_msgs::DiagnosticArray report(const ros::Time& stamp, const core::FilterStats& stats,
                                          int particles, double wall_period_s);

 private:
  const std::string name_;
  const DiagnosticsOptions options_;
  long updates_period_ = 0, updates_total_ = 0, resets_total_ = 0;
  double update_ms_sum_period_ = 0.0;
  double busy_ms_period_ = 0.0;
  ros::WallTime last_report_wall_ = ros::WallTime::now();
  std::map<std::string, long> drops_period_, drops_total_;
  bool paused_ = false;
  long odometry_gaps_ = -1;  // -1: not reported
  long skipped_features_total_ = 0;
  long same_stamp_total_ = 0;
};

}  // namespace rosbridge
}  // namespace rbpf_slam

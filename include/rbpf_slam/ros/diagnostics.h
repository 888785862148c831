#pragma once
// The node's health on /diagnostics (diagnostic_msgs): effective sample size, landmark
// count, update time, share of the time spent on frames, frames processed, dropped messages by
// cause, resets, pause state.

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/time.h>

#include <chrono>
#include <map>
#include <string>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace rosbridge {

/// Thresholds that turn the status to WARN.
struct DiagnosticsOptions {
  double low_neff_fraction = 0.1;  // Neff below this fraction of the particles
  double slow_update_ms = 200.0;   // mean update time above this
  /// Share of the wall time spent on inputs above this (rounded to a percent): the node cannot
  /// keep up, and a topic's queue drops frames before the node sees them (roscpp says nothing
  /// of it). Bursts and other processes on the CPU can fill the queue below it too.
  double busy_fraction = 0.9;
  /// false for a node without a filter (a feature extractor): the report leaves out Neff,
  /// particles, landmarks, resamples, weight resets and fallbacks.
  bool filter_fields = true;
  /// The node has ~pause / ~resume: the report has a "paused" value.
  bool pausable = true;
  /// The OK message once it has worked ("mapping"; setActivity changes it).
  std::string activity = "mapping";

  /// For a node without a filter (feature extraction, the landmark tracker), which cannot be
  /// paused; `activity` is what it does.
  static DiagnosticsOptions withoutFilter(const std::string& activity) {
    DiagnosticsOptions options;
    options.filter_fields = false;
    options.pausable = false;
    options.activity = activity;
    return options;
  }
};

/// Counts what happened since the last report and builds one DiagnosticStatus from it.
class SlamDiagnostics {
 public:
  explicit SlamDiagnostics(std::string name, DiagnosticsOptions options = DiagnosticsOptions())
      : name_(std::move(name)), options_(options) {}

  const DiagnosticsOptions& options() const { return options_; }

  void recordUpdate(double update_ms);
  /// Wall time the node's thread spent on its inputs (a whole callback: lookups, conversion,
  /// update, publishing); BusyScope records a callback's.
  void recordBusy(double ms) { busy_ms_period_ += ms; }
  /// Records the time from its construction to its end as busy time. Scopes nest (a callback
  /// whose tf gate hands a message on at once runs the gated callback inside it): only the
  /// outermost one records, so no time counts twice.
  class BusyScope {
   public:
    explicit BusyScope(SlamDiagnostics* diagnostics) : diagnostics_(diagnostics) {
      ++diagnostics_->busy_depth_;
    }
    BusyScope(const BusyScope&) = delete;
    BusyScope& operator=(const BusyScope&) = delete;
    ~BusyScope() {
      if (--diagnostics_->busy_depth_ > 0) return;
      diagnostics_->recordBusy(std::chrono::duration<double, std::milli>(
                                   std::chrono::steady_clock::now() - start_)
                                   .count());
    }

   private:
    SlamDiagnostics* diagnostics_;
    const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  };
  /// The busy share of the last report (0 before one, or when it had no period).
  double lastBusyFraction() const { return last_busy_fraction_; }
  /// Something that could not be used (a message, or `count` features or points of one);
  /// cause is a short fixed phrase ("no tf", "bad scan").
  void recordDrop(const std::string& cause, long count = 1);
  /// A drop that is normal (readings before tf's first transform at start-up): counted under
  /// its cause, but it does not turn the report to WARN.
  void recordExpectedDrop(const std::string& cause) { ++drops_total_[cause]; }
  void recordReset() { ++resets_total_; }
  /// Features of used frames that the filter skipped (a kind it ignores, degenerate):
  /// reported as a count, not as a problem (dpf on line features would warn for ever).
  void recordSkippedFeatures(long count) { skipped_features_total_ += count; }
  /// Features used with the configured noise because their own covariance is set but not
  /// positive definite (rosbridge::countUnusableCovariances): a count; the node warns.
  void recordReplacedCovariances(long count) { replaced_covariances_total_ += count; }
  /// Frames at the stamp of the last frame (another input of the same instant): a count, not
  /// a problem.
  void recordSameStamp() { ++same_stamp_total_; }
  /// Steps taken across an odometry gap so far (SlamSession::gaps); reported once set.
  void setOdometryGaps(long total) { odometry_gaps_ = total; }
  void setPaused(bool paused) { paused_ = paused; }
  /// The OK message once it has worked, e.g. "localizing (mapping off)".
  void setActivity(const std::string& activity) { options_.activity = activity; }

  /// The report for the period since the previous call (then the period counters restart),
  /// with the share of the (steady) wall time since the last busy share spent on inputs. A
  /// period under kMinBusyPeriodS (a timer catching up after a long callback) gives no share:
  /// its busy time is carried into the next.
  diagnostic_msgs::DiagnosticArray report(const ros::Time& stamp, const core::FilterStats& stats,
                                          int particles);
  /// The same over a given wall period (0: no busy share, the busy time carried over); the
  /// clock is not read (tests).
  diagnostic_msgs::DiagnosticArray report(const ros::Time& stamp, const core::FilterStats& stats,
                                          int particles, double wall_period_s);
  static constexpr double kMinBusyPeriodS = 0.5;

 private:
  const std::string name_;
  DiagnosticsOptions options_;
  long updates_period_ = 0, updates_total_ = 0, resets_total_ = 0;
  double update_ms_sum_period_ = 0.0;
  double busy_ms_period_ = 0.0;
  int busy_depth_ = 0;  // BusyScopes open
  double last_busy_fraction_ = 0.0;
  std::chrono::steady_clock::time_point busy_since_ = std::chrono::steady_clock::now();
  std::map<std::string, long> drops_period_, drops_total_;
  bool paused_ = false;
  long odometry_gaps_ = -1;  // -1: not reported
  long skipped_features_total_ = 0;
  long replaced_covariances_total_ = 0;
  long same_stamp_total_ = 0;
};

}  // namespace rosbridge
}  // namespace rbpf_slam

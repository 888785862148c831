#include "rbpf_slam/ros/diagnostics.h"

#include <cmath>
#include <sstream>

namespace rbpf_slam {
namespace rosbridge {
namespace {

diagnostic_msgs::KeyValue keyValue(const std::string& key, const std::string& value) {
  diagnostic_msgs::KeyValue kv;
  kv.key = key;
  kv.value = value;
  return kv;
}

template <typename T>
std::string text(T value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

void SlamDiagnostics::recordUpdate(double update_ms) {
  ++updates_period_;
  ++updates_total_;
  update_ms_sum_period_ += update_ms;
}

void SlamDiagnostics::recordDrop(const std::string& cause, long count) {
  drops_period_[cause] += count;
  drops_total_[cause] += count;
}

diagnostic_msgs::DiagnosticArray SlamDiagnostics::report(const ros::Time& stamp,
                                                         const core::FilterStats& stats,
                                                         int particles) {
  const auto now = std::chrono::steady_clock::now();
  const double period_s = std::chrono::duration<double>(now - busy_since_).count();
  if (period_s < kMinBusyPeriodS) return report(stamp, stats, particles, 0.0);
  busy_since_ = now;
  return report(stamp, stats, particles, period_s);
}

diagnostic_msgs::DiagnosticArray SlamDiagnostics::report(const ros::Time& stamp,
                                                         const core::FilterStats& stats,
                                                         int particles,
                                                         double wall_period_s) {
  diagnostic_msgs::DiagnosticStatus status;
  status.name = name_;
  status.hardware_id = "rbpf_slam";
  const double mean_ms = updates_period_ > 0 ? update_ms_sum_period_ / updates_period_ : 0.0;
  long dropped_period = 0;
  for (const auto& [cause, count] : drops_period_) dropped_period += count;

  // The busy share in whole percent, the same figure compared, shown and warned.
  const long busy_percent =
      wall_period_s > 0.0 ? std::lround(busy_ms_period_ / (10.0 * wall_period_s)) : 0;
  last_busy_fraction_ = busy_percent / 100.0;
  std::string problem;
  if (paused_) {
    problem = "paused (~resume to continue)";
  } else if (busy_percent > std::lround(100.0 * options_.busy_fraction)) {
    // First: an overloaded node also drops on its tf gate and loses Neff; this is the cause.
    problem = "handling input " + text(busy_percent) +
              " % of the time: falling behind, the topic's queue drops frames unseen when full";
  } else if (dropped_period > 0) {
    problem = std::to_string(dropped_period) + " message(s) dropped since the last report";
  } else if (options_.filter_fields && updates_total_ > 0 &&
             stats.last_neff < options_.low_neff_fraction * particles) {
    problem = "effective sample size " + text(stats.last_neff) + " of " +
              std::to_string(particles) + " particles";
  } else if (mean_ms > options_.slow_update_ms) {
    problem = "updates take " + text(mean_ms) + " ms on average";
  }
  if (problem.empty()) {
    status.level = diagnostic_msgs::DiagnosticStatus::OK;
    status.message = updates_total_ > 0 ? options_.activity : "waiting for data";
  } else {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    status.message = problem;
  }
  status.values.push_back(keyValue("updates", text(updates_total_)));
  status.values.push_back(keyValue("updates since last report", text(updates_period_)));
  status.values.push_back(keyValue("update time mean [ms]", text(mean_ms)));
  if (wall_period_s > 0.0) status.values.push_back(keyValue("busy [%]", text(busy_percent)));
  if (options_.filter_fields) {
    status.values.push_back(keyValue("Neff", text(stats.last_neff)));
    status.values.push_back(keyValue("particles", text(particles)));
    status.values.push_back(keyValue("landmarks", text(stats.landmarks)));
    status.values.push_back(keyValue("resamples", text(stats.resamples)));
    status.values.push_back(keyValue("weight resets", text(stats.weight_resets)));
    status.values.push_back(keyValue("numeric fallbacks", text(stats.fallbacks)));
    if (stats.attenuation > 0.0) {
      status.values.push_back(keyValue("H-infinity theta", text(stats.attenuation)));
    }
    if (stats.leader_changes > 0) {  // an ensemble whose reported member has changed
      status.values.push_back(keyValue("ensemble leader changes", text(stats.leader_changes)));
    }
    if (stats.outside_grid > 0) {  // grid_pf beyond its extent
      status.values.push_back(keyValue("updates outside the grid", text(stats.outside_grid)));
    }
    if (stats.readings_beyond_reach > 0) {  // grid_pf: echoes beyond the first extent
      status.values.push_back(
          keyValue("readings beyond the grid's reach", text(stats.readings_beyond_reach)));
    }
    if (stats.grid_growth_refused > 0) {  // grid_pf at grid.max_size_m or the memory limit
      status.values.push_back(
          keyValue("updates the grid could not grow for", text(stats.grid_growth_refused)));
    }
    if (stats.missed_answers > 0) {  // dpf_master_node: local filters that did not answer
      status.values.push_back(keyValue("local answers missed", text(stats.missed_answers)));
    }
    for (const auto& [name, state] : stats.details) status.values.push_back(keyValue(name, state));
  }
  status.values.push_back(keyValue("resets", text(resets_total_)));
  if (odometry_gaps_ >= 0) status.values.push_back(keyValue("odometry gaps", text(odometry_gaps_)));
  if (options_.pausable) status.values.push_back(keyValue("paused", paused_ ? "true" : "false"));
  if (same_stamp_total_ > 0) {
    status.values.push_back(keyValue("frames at the last frame's stamp", text(same_stamp_total_)));
  }
  if (skipped_features_total_ > 0) {
    status.values.push_back(keyValue("features the filter skipped", text(skipped_features_total_)));
  }
  if (replaced_covariances_total_ > 0) {
    status.values.push_back(keyValue("feature covariances not positive definite (noise used)",
                                     text(replaced_covariances_total_)));
  }
  for (const auto& [cause, count] : drops_total_) {
    status.values.push_back(keyValue("dropped: " + cause, text(count)));
  }
  updates_period_ = 0;
  update_ms_sum_period_ = 0.0;
  if (wall_period_s > 0.0) busy_ms_period_ = 0.0;  // else carried into the next share
  drops_period_.clear();

  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = stamp;
  array.status.push_back(status);
  return array;
}

}  // namespace rosbridge
}  // namespace rbpf_slam

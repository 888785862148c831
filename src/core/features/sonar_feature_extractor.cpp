// Sonar echo window in the odometry frame and the extraction that turns it into lines and
// points in the base frame; see sonar_fitting.cpp for the two fitting passes.

#include "rbpf_slam/core/features/sonar_feature_extractor.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "sonar_fitting.h"
#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kMountTolerance = 1e-3;  // m and rad: the same transducer
constexpr double kClockJumpBackS = 1.0;   // stamps going back more than this clear the window
constexpr size_t kMaxTransducers = 128;   // distinct mounting poses kept apart
constexpr double kMaxOdomCoordinateM = 1e6;  // beyond: a broken odometry pose, readings dropped
// No sonar or infrared sensor reaches this far: a longer range, or a transducer mounted farther
// from the base, is a broken driver value, and echoes taken farther away than this are not
// extracted from. With no maximum range configured or given, one 3 km echo sized the vote grids
// by its range (17 GB; 1e5 m: std::bad_alloc).
constexpr double kMaxEchoDistanceM = 100.0;

}  // namespace

void validate(const SonarExtractorOptions& o) {
  requireRange("sonar_features.min_range_m", o.min_range_m, 0.0, 100.0);
  requireRange("sonar_features.max_range_m", o.max_range_m, 0.0, 100.0);
  if (o.max_range_m > 0.0 && o.max_range_m <= o.min_range_m) {
    throw std::invalid_argument("sonar_features.max_range_m must exceed min_range_m (or be 0)");
  }
  requireRange("sonar_features.max_range_margin_m", o.max_range_margin_m, 0.0, 10.0);
  requireRange("sonar_features.cone_rad", o.cone_rad, 0.0, 3.0);
  requireRange("sonar_features.sigma_range_m", o.sigma_range_m, 0.0, 10.0, true);
  requireRange("sonar_features.isolated_jump_m", o.isolated_jump_m, 0.0, 100.0, true);
  requireRange("sonar_features.window_distance_m", o.window_distance_m, 0.0, 1000.0, true);
  requireRange("sonar_features.window_time_s", o.window_time_s, 0.0, 1e6, true);
  requireRange("sonar_features.max_echoes", o.max_echoes, 1, 100000);
  requireRange("sonar_features.min_echo_spacing_m", o.min_echo_spacing_m, 0.0, 10.0);
  requireRange("sonar_features.extract_distance_m", o.extract_distance_m, 0.0, 1000.0);
  requireRange("sonar_features.extract_angle_rad", o.extract_angle_rad, 0.0, 10.0);
  requireRange("sonar_features.hough_rho_step_m", o.hough_rho_step_m, 0.005, 1.0);
  requireRange("sonar_features.hough_theta_step_rad", o.hough_theta_step_rad, 0.002, 0.5);
  requireRange("sonar_features.min_line_echoes", o.min_line_echoes, 3, 100000);
  requireRange("sonar_features.min_line_length_m", o.min_line_length_m, 0.0, 100.0);
  requireRange("sonar_features.line_inlier_m", o.line_inlier_m, 0.0, 10.0, true);
  requireRange("sonar_features.cone_margin_rad", o.cone_margin_rad, 0.0, 1.0);
  requireRange("sonar_features.line_max_incidence_rad", o.line_max_incidence_rad, 0.0, 1.5);
  requireRange("sonar_features.max_line_sigma_rho_m", o.max_line_sigma_rho_m, 0.0, 100.0, true);
  requireRange("sonar_features.max_line_sigma_theta_rad", o.max_line_sigma_theta_rad, 0.0, 3.2, true);
  requireRange("sonar_features.line_sigma_rho_m", o.line_sigma_rho_m, 0.0, 100.0, true);
  requireRange("sonar_features.line_sigma_theta_rad", o.line_sigma_theta_rad, 0.0, 3.2, true);
  requireRange("sonar_features.line_theta_per_length_m", o.line_theta_per_length_m, 0.0, 10.0);
  requireRange("sonar_features.point_cell_m", o.point_cell_m, 0.01, 1.0);
  requireRange("sonar_features.min_point_echoes", o.min_point_echoes, 3, 100000);
  requireRange("sonar_features.min_point_baseline_m", o.min_point_baseline_m, 0.0, 100.0);
  requireRange("sonar_features.point_inlier_m", o.point_inlier_m, 0.0, 10.0, true);
  requireRange("sonar_features.max_point_sigma_m", o.max_point_sigma_m, 0.0, 100.0, true);
  requireRange("sonar_features.max_contradiction_ratio", o.max_contradiction_ratio, 0.0, 1000.0);
  requireRange("sonar_features.point_sigma_range_m", o.point_sigma_range_m, 0.0, 100.0, true);
  requireRange("sonar_features.point_sigma_bearing_rad", o.point_sigma_bearing_rad, 0.0, 3.2, true);
}

SonarFeatureExtractor::SonarFeatureExtractor(const SonarExtractorOptions& options)
    : options_(options) {
  validate(options_);
}

void SonarFeatureExtractor::reset() {
  clearWindow();
  mounts_.clear();
  last_kept_.clear();
  stats_ = SonarExtractorStats();
}

void SonarFeatureExtractor::clearWindow() {
  echoes_.clear();
  for (SonarEcho& last : last_kept_) last.range = -1.0;
  has_pose_ = false;
  travel_ = 0.0;
  has_extracted_ = false;
}

int SonarFeatureExtractor::transducerIndex(const Pose2& mount) {
  for (size_t i = 0; i < mounts_.size(); ++i) {
    if ((mounts_[i].head<2>() - mount.head<2>()).norm() < kMountTolerance &&
        std::abs(wrapAngle(mounts_[i].z() - mount.z())) < kMountTolerance) {
      return static_cast<int>(i);
    }
  }
  if (mounts_.size() >= kMaxTransducers) {
    // A mount that keeps moving (a panning sonar, jittery tf): the nearest known transducer,
    // so that the list stays bounded.
    size_t nearest = 0;
    double best = INFINITY;
    for (size_t i = 0; i < mounts_.size(); ++i) {
      const double d = (mounts_[i].head<2>() - mount.head<2>()).norm() +
                       std::abs(wrapAngle(mounts_[i].z() - mount.z()));
      if (d < best) {
        best = d;
        nearest = i;
      }
    }
    return static_cast<int>(nearest);
  }
  mounts_.push_back(mount);
  SonarEcho none;
  none.range = -1.0;
  last_kept_.push_back(none);
  return static_cast<int>(mounts_.size()) - 1;
}

bool SonarFeatureExtractor::wouldClearWindow(double stamp) const {
  // Against the newest echo, not the last added: a chain of late readings must not walk back.
  return !echoes_.empty() && stamp < newest_echo_stamp_ - kClockJumpBackS;
}

int SonarFeatureExtractor::addReadings(const std::vector<ConeReading>& readings,
                                       const Pose2& odom_pose, double stamp) {
  stats_.readings += static_cast<long>(readings.size());
  if (!odom_pose.allFinite() || !std::isfinite(stamp) ||
      odom_pose.head<2>().cwiseAbs().maxCoeff() > kMaxOdomCoordinateM) {
    stats_.invalid += static_cast<long>(readings.size());
    return 0;
  }
  if (wouldClearWindow(stamp)) {
    clearWindow();
    ++stats_.clock_jumps;
  }
  // The distance travelled follows the stamps: a reading a little out of order (transducers
  // stamped apart, two publishers) joins the window but would add the way back and forth again.
  if (!has_pose_ || stamp >= last_pose_stamp_) {
    if (has_pose_) travel_ += (odom_pose.head<2>() - last_pose_.head<2>()).norm();
    has_pose_ = true;
    last_pose_ = odom_pose;
    last_pose_stamp_ = stamp;
  }
  int kept = 0;
  for (const ConeReading& reading : readings) {
    const double cone = options_.cone_rad > 0.0 ? options_.cone_rad : reading.field_of_view;
    if (!std::isfinite(reading.range) || !reading.sensor_pose.allFinite() ||
        !(cone > 0.0 && cone < M_PI) || reading.range > kMaxEchoDistanceM ||
        reading.sensor_pose.head<2>().norm() > kMaxEchoDistanceM) {
      ++stats_.invalid;
      continue;
    }
    const bool sensor_max = std::isfinite(reading.max_range) && reading.max_range > 0.0 &&
                            reading.range >= reading.max_range - options_.max_range_margin_m;
    if (sensor_max || (options_.max_range_m > 0.0 && reading.range > options_.max_range_m)) {
      ++stats_.no_echo;
      continue;
    }
    const double min_range =
        std::max(options_.min_range_m, std::isfinite(reading.min_range) ? reading.min_range : 0.0);
    if (reading.range < min_range) {
      ++stats_.too_close;
      continue;
    }
    const Pose2 sensor = compose(odom_pose, reading.sensor_pose);
    SonarEcho echo;
    echo.sensor = sensor.head<2>();
    echo.axis = sensor.z();
    echo.half_cone = 0.5 * cone;
    echo.range = reading.range;
    echo.stamp = stamp;
    echo.travel = travel_;
    echo.transducer = transducerIndex(reading.sensor_pose);
    if (redundant(echo)) {
      ++stats_.decimated;
      continue;
    }
    last_kept_[echo.transducer] = echo;
    newest_echo_stamp_ = echoes_.empty() ? stamp : std::max(newest_echo_stamp_, stamp);
    echoes_.push_back(echo);
    ++kept;
  }
  stats_.echoes += kept;
  prune(stamp);
  return kept;
}

bool SonarFeatureExtractor::redundant(const SonarEcho& echo) const {
  constexpr double kSameHeadingRad = 0.035;
  const double spacing = options_.min_echo_spacing_m;
  const SonarEcho& last = last_kept_[echo.transducer];
  return spacing > 0.0 && last.range >= 0.0 && echo.travel - last.travel < spacing &&
         std::abs(echo.range - last.range) < spacing &&
         std::abs(wrapAngle(echo.axis - last.axis)) < kSameHeadingRad;
}

void SonarFeatureExtractor::prune(double stamp) {
  while (!echoes_.empty() && (travel_ - echoes_.front().travel > options_.window_distance_m ||
                              stamp - echoes_.front().stamp > options_.window_time_s ||
                              static_cast<int>(echoes_.size()) > options_.max_echoes)) {
    echoes_.pop_front();
  }
}

bool SonarFeatureExtractor::extractionDue(const Pose2& odom_pose) const {
  if (!has_extracted_) return true;
  const Pose2 moved = between(last_extraction_pose_, odom_pose);
  return moved.head<2>().norm() >= options_.extract_distance_m ||
         std::abs(moved.z()) >= options_.extract_angle_rad;
}

FeatureSet SonarFeatureExtractor::extract(const Pose2& odom_pose, double stamp) {
  FeatureSet features;
  features.stamp = stamp;
  if (!odom_pose.allFinite()) return features;
  prune(stamp);
  ++stats_.extractions;
  has_extracted_ = true;
  last_extraction_pose_ = odom_pose;

  // Cross-talk: an echo unlike both its transducer's previous and next echoes in the window.
  const int n = static_cast<int>(echoes_.size());
  std::vector<int> previous(n, -1), next(n, -1), last_of(mounts_.size(), -1);
  for (int i = 0; i < n; ++i) {
    int& last = last_of[echoes_[i].transducer];
    if (last >= 0) {
      previous[i] = last;
      next[last] = i;
    }
    last = i;
  }
  auto unlike = [&](int i, int j) {
    if (j < 0) return true;
    const double moved = std::abs(echoes_[i].travel - echoes_[j].travel);
    return std::abs(echoes_[i].range - echoes_[j].range) > options_.isolated_jump_m + moved;
  };

  const Pose2 to_base = inverse(odom_pose);
  std::vector<sonar::LocalEcho> local;
  local.reserve(n);
  long isolated = 0;
  for (int i = 0; i < n; ++i) {
    const SonarEcho& e = echoes_[i];
    const bool has_neighbour = previous[i] >= 0 || next[i] >= 0;
    if (options_.reject_isolated && has_neighbour && unlike(i, previous[i]) && unlike(i, next[i])) {
      ++isolated;
      continue;
    }
    sonar::LocalEcho l;
    l.sensor = transformPoint(to_base, e.sensor);
    // An echo taken far from here (odometry jumped inside the window) would blow up the vote
    // grids: it cannot describe anything near the robot.
    if (!l.sensor.allFinite() || l.sensor.norm() > kMaxEchoDistanceM) continue;
    l.axis = wrapAngle(e.axis - odom_pose.z());
    l.half_cone = e.half_cone;
    l.range = e.range;
    l.transducer = e.transducer;
    local.push_back(l);
  }
  stats_.isolated = isolated;
  if (options_.extract_lines) features.lines = sonar::extractLines(options_, &local);
  if (options_.extract_points) features.points = sonar::extractPoints(options_, &local);
  stats_.lines += static_cast<long>(features.lines.size());
  stats_.points += static_cast<long>(features.points.size());
  return features;
}

std::vector<ConeReading> coneReadingsFromCloud(const std::vector<Eigen::Vector2d>& points,
                                               const std::vector<Pose2>& transducers,
                                               double field_of_view_rad, double min_range_m,
                                               double max_range_m, double stamp,
                                               double max_axis_offset_m, int* unmatched) {
  std::vector<ConeReading> readings;
  int missed = 0;
  for (const Eigen::Vector2d& p : points) {
    int best = -1;
    double best_offset = max_axis_offset_m, best_range = 0.0;
    for (size_t i = 0; p.allFinite() && i < transducers.size(); ++i) {
      const Pose2& t = transducers[i];
      const Eigen::Vector2d d = p - t.head<2>();
      const Eigen::Vector2d axis(std::cos(t.z()), std::sin(t.z()));
      const double along = d.dot(axis);
      const double offset = std::abs(axis.x() * d.y() - axis.y() * d.x());
      if (along > 0.0 && offset <= best_offset) {
        best = static_cast<int>(i);
        best_offset = offset;
        best_range = along;
      }
    }
    if (best < 0) {
      ++missed;
      continue;
    }
    ConeReading reading;
    reading.stamp = stamp;
    reading.range = best_range;
    reading.min_range = min_range_m;
    reading.max_range = max_range_m;
    reading.field_of_view = field_of_view_rad;
    reading.sensor_pose = transducers[best];
    readings.push_back(reading);
  }
  if (unmatched) *unmatched = missed;
  return readings;
}

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// The whole per-frame path from raw sensor data to a filter update: feature extraction
// (laser scans, or sonar echoes accumulated over a window of motion) then the session.
// rbpf_slam_node and offline_slam both call exactly this.

#include <deque>
#include <memory>
#include <string>

#include "rbpf_slam/core/features/laser_line_extractor.h"
#include "rbpf_slam/core/features/scan_matcher.h"
#include "rbpf_slam/core/features/sonar_feature_extractor.h"
#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/slam/slam_session.h"

namespace rbpf_slam {
namespace core {

struct PipelineOptions {
  FilterOptions filter;
  SessionOptions session;
  LaserExtractorOptions laser;
  ScanMatcherOptions scan_matching;
  SonarExtractorOptions sonar;
};

/// Extraction plus filtering for one robot.
class SlamPipeline {
 public:
  explicit SlamPipeline(const PipelineOptions& options);
  /// With a filter built elsewhere (e.g. dpf_master_node's remote distributed filter).
  SlamPipeline(const PipelineOptions& options, std::unique_ptr<SlamFilter> filter);

  /// A laser scan taken with the robot at odom_pose (odom frame).
  FrameResult processScan(const RangeScan& scan, const Pose2& odom_pose);
  /// Sonar (or other cone sensor) readings taken at stamp with the robot at odom_pose: they
  /// join the echo window; the filter is updated with the window's lines and points once the
  /// robot moved enough since the last extraction (else kBuffered: used later). The update's
  /// FeatureSet::cones holds every reading since the previous update, re-expressed in the base
  /// frame at this odom_pose (for raw-data variants such as grid_pf). Laser scans likewise
  /// arrive in FeatureSet::scan.
  FrameResult processSonar(const std::vector<ConeReading>& readings, const Pose2& odom_pose,
                           double stamp);
  /// Features already extracted (feature nodes, landmark sensors), in the base frame.
  FrameResult processFeatures(const FeatureSet& features, const Pose2& odom_pose);

  const FeatureSet& lastFeatures() const { return last_features_; }
  SlamSession& session() { return session_; }
  const SlamSession& session() const { return session_; }
  const LaserLineExtractor& laserExtractor() const { return extractor_; }
  const SonarFeatureExtractor& sonarExtractor() const { return sonar_extractor_; }
  /// Scans whose laser-corrected increment was used / fell back to odometry.
  long scansMatched() const { return scans_matched_; }
  long scansUnmatched() const { return scans_unmatched_; }
  /// The scan match of the last processScan (ok = false when none was attempted or it failed).
  const ScanMatchResult& lastMatch() const { return last_match_; }
  /// Forgets everything, e.g. after the clock jumped backwards (SlamSession::reset).
  void reset(SlamSession::ResetCause cause = SlamSession::ResetCause::kClockWentBack);

 private:
  LaserLineExtractor extractor_;
  ScanMatcher matcher_;
  SonarFeatureExtractor sonar_extractor_;
  SlamSession session_;
  FeatureSet last_features_;
  /// Adds a scan the filter used to the matching submap; chain_delta is its pose in the
  /// previous such scan's base frame (the match, or odometry when matching failed).
  void addToSubmap(std::vector<Eigen::Vector2d> points, const Pose2& chain_delta);

  struct SubmapScan {
    Pose2 pose = Pose2::Zero();  // in the submap's frame (the chain of increments)
    std::vector<Eigen::Vector2d> points;  // base frame of that scan
  };
  std::deque<SubmapScan> submap_;                  // the last scans the filter used, oldest first
  std::vector<Eigen::Vector2d> reference_points_;  // the submap in the last scan's base frame
  Pose2 reference_odom_pose_ = Pose2::Zero();      // odometry pose of the last scan
  ScanMatchResult last_match_;
  struct PendingCone {
    ConeReading reading;
    Pose2 odom_pose;
  };
  std::vector<PendingCone> pending_cones_;  // cone readings since the last filter update
  std::vector<ConeReading> pendingConesInBase(const Pose2& odom_pose) const;
  long scans_matched_ = 0;
  long scans_unmatched_ = 0;
  // Sonar stamps far back: a restarted clock or late rings (ClockRestartDetector), and the
  // session's last stamp when the run of them began (a frame used since ends the run).
  ClockRestartDetector sonar_clock_;
  double sonar_run_session_stamp_ = 0.0;
};

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// The whole per-frame path from raw sensor data to a filter update: feature extraction
// (laser) then the session. rbpf_slam_node and offline_slam both call exactly this.

#include <memory>
#include <string>

#include "rbpf_slam/core/features/laser_line_extractor.h"
#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/slam/slam_session.h"

namespace rbpf_slam {
namespace core {

struct PipelineOptions {
  FilterOptions filter;
  SessionOptions session;
  LaserExtractorOptions laser;
};

/// Extraction plus filtering for one robot.
class SlamPipeline {
 public:
  explicit SlamPipeline(const PipelineOptions& options);

  /// A laser scan taken with the robot at odom_pose (odom frame).
  FrameResult processScan(const RangeScan& scan, const Pose2& odom_pose);
  /// Features already extracted (sonar node, landmark sensors), in the base frame.
  FrameResult processFeatures(const FeatureSet& features, const Pose2& odom_pose);

  const FeatureSet& lastFeatures() const { return last_features_; }
  SlamSession& session() { return session_; }
  const SlamSession& session() const { return session_; }
  const LaserLineExtractor& laserExtractor() const { return extractor_; }

 private:
  LaserLineExtractor extractor_;
  SlamSession session_;
  FeatureSet last_features_;
};

}  // namespace core
}  // namespace rbpf_slam

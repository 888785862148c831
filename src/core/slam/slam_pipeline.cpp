#include "rbpf_slam/core/slam/slam_pipeline.h"

namespace rbpf_slam {
namespace core {

SlamPipeline::SlamPipeline(const PipelineOptions& options)
    : extractor_(options.laser),
      matcher_(options.scan_matching),
      sonar_extractor_(options.sonar),
      session_(createFilter(options.filter), options.session) {}

void SlamPipeline::reset() {
  session_.reset();
  reference_points_.clear();
  sonar_extractor_.reset();
  last_features_ = FeatureSet();
}

FrameResult SlamPipeline::processScan(const RangeScan& scan, const Pose2& odom_pose) {
  last_features_ = extractor_.extract(scan);
  last_features_.stamp = scan.stamp;
  if (!matcher_.options().enabled) return session_.process(scan.stamp, odom_pose, last_features_);

  // Laser-corrected increment since the last scan the filter used, seeded by odometry.
  std::vector<Eigen::Vector2d> points = scanPointsInBase(scan, matcher_.options().max_range_m);
  MotionInput measured;
  const MotionInput* override_motion = nullptr;
  last_match_ = ScanMatchResult();
  if (!reference_points_.empty() && session_.trajectory().size() > 0) {
    // The match spans reference scan -> this scan; frames from other sources (features) may
    // have been processed in between, so the filter's increment is the part after the last
    // frame: odometry covers reference -> last frame, the match the whole span.
    const Pose2 odometry_delta = between(reference_odom_pose_, odom_pose);
    const ScanMatchResult match = matcher_.match(reference_points_, points, odometry_delta);
    last_match_ = match;
    if (match.ok) {
      const Pose2 reference_to_last = between(reference_odom_pose_, session_.lastOdomPose());
      measured.delta = compose(inverse(reference_to_last), match.delta);
      // A degenerate match carries odometry's error along one direction: odometry's noise.
      measured.noise_scale = match.degenerate ? 1.0 : matcher_.options().noise_scale;
      override_motion = &measured;
      ++scans_matched_;
    } else {
      ++scans_unmatched_;
    }
  }
  const FrameResult result = session_.process(scan.stamp, odom_pose, last_features_, override_motion);
  if (result == FrameResult::kUpdated || result == FrameResult::kFirstFrame) {
    reference_points_ = std::move(points);
    reference_odom_pose_ = odom_pose;
  }
  return result;
}

FrameResult SlamPipeline::processSonar(const std::vector<ConeReading>& readings,
                                       const Pose2& odom_pose, double stamp) {
  sonar_extractor_.addReadings(readings, odom_pose, stamp);
  if (session_.trajectory().empty()) {
    // The first frame anchors the map; the window has nothing to extract from yet.
    last_features_ = FeatureSet();
    last_features_.stamp = stamp;
    return session_.process(stamp, odom_pose, last_features_);
  }
  if (!sonar_extractor_.extractionDue(odom_pose)) return FrameResult::kSkippedNoMotion;
  last_features_ = sonar_extractor_.extract(odom_pose, stamp);
  return session_.process(stamp, odom_pose, last_features_);
}

FrameResult SlamPipeline::processFeatures(const FeatureSet& features, const Pose2& odom_pose) {
  last_features_ = features;
  return session_.process(features.stamp, odom_pose, features);
}

}  // namespace core
}  // namespace rbpf_slam

#include "rbpf_slam/core/slam/slam_pipeline.h"

namespace rbpf_slam {
namespace core {

SlamPipeline::SlamPipeline(const PipelineOptions& options)
    : extractor_(options.laser), session_(createFilter(options.filter), options.session) {}

FrameResult SlamPipeline::processScan(const RangeScan& scan, const Pose2& odom_pose) {
  last_features_ = extractor_.extract(scan);
  last_features_.stamp = scan.stamp;
  return session_.process(scan.stamp, odom_pose, last_features_);
}

FrameResult SlamPipeline::processFeatures(const FeatureSet& features, const Pose2& odom_pose) {
  last_features_ = features;
  return session_.process(features.stamp, odom_pose, features);
}

}  // namespace core
}  // namespace rbpf_slam

#include "rbpf_slam/core/slam/slam_pipeline.h"

#include <memory>
#include <utility>

namespace rbpf_slam {
namespace core {
namespace {

// Cone readings held for the next update at most (a robot standing still for minutes).
constexpr size_t kMaxPendingCones = 4096;

bool usedFrame(FrameResult result) {
  return result == FrameResult::kUpdated || result == FrameResult::kFirstFrame ||
         result == FrameResult::kReset;
}

bool startedMap(FrameResult result) {
  return result == FrameResult::kFirstFrame || result == FrameResult::kReset;
}

}  // namespace

SlamPipeline::SlamPipeline(const PipelineOptions& options)
    : extractor_(options.laser),
      matcher_(options.scan_matching),
      sonar_extractor_(options.sonar),
      session_(createFilter(options.filter), options.session),
      sonar_clock_(options.session) {}

SlamPipeline::SlamPipeline(const PipelineOptions& options, std::unique_ptr<SlamFilter> filter)
    : extractor_(options.laser),
      matcher_(options.scan_matching),
      sonar_extractor_(options.sonar),
      session_(std::move(filter), options.session),
      sonar_clock_(options.session) {}

void SlamPipeline::reset(SlamSession::ResetCause cause) {
  session_.reset(cause);
  reference_points_.clear();
  submap_.clear();
  sonar_extractor_.reset();
  pending_cones_.clear();
  last_features_ = FeatureSet();
  sonar_clock_.inOrder();
}

FrameResult SlamPipeline::processScan(const RangeScan& scan, const Pose2& odom_pose) {
  last_features_ = extractor_.extract(scan);
  last_features_.stamp = scan.stamp;
  last_features_.scan = std::make_shared<const RangeScan>(scan);
  if (!matcher_.options().enabled) return session_.process(scan.stamp, odom_pose, last_features_);

  // Laser-corrected increment since the last scan the filter used, seeded by odometry.
  std::vector<Eigen::Vector2d> points = scanPointsInBase(scan, matcher_.options().max_range_m);
  MotionInput measured;
  const MotionInput* override_motion = nullptr;
  last_match_ = ScanMatchResult();
  Pose2 chain_delta = Pose2::Zero();
  if (!reference_points_.empty() && session_.trajectory().size() > 0) {
    // The match spans reference scan -> this scan; frames from other sources (features) may
    // have been processed in between, so the filter's increment is the part after the last
    // frame: odometry covers reference -> last frame, the match the whole span.
    const Pose2 odometry_delta = between(reference_odom_pose_, odom_pose);
    // An odometry jump (max_odometry_jump) is not motion to the session, so it does not seed
    // the match either: started from it, a wrong alignment metres off can pass the matcher's
    // checks (a 4 m glitch injected across an ACES corridor did); only a match from rest is
    // taken, as when the match from odometry fails, and if none is accepted the session takes
    // the jump as no motion.
    const ScanMatchResult match = session_.isOdometryJump(odometry_delta)
                                      ? matcher_.matchFromRest(reference_points_, points)
                                      : matcher_.match(reference_points_, points, odometry_delta);
    last_match_ = match;
    chain_delta = match.ok ? match.delta : odometry_delta;
    if (match.ok) {
      const Pose2 reference_to_last = between(reference_odom_pose_, session_.lastOdomPose());
      measured.delta = compose(inverse(reference_to_last), match.delta);
      // A degenerate match carries odometry's value along one direction (degenerate_noise_scale).
      measured.noise_scale = matcher_.noiseScale(match);
      override_motion = &measured;
      ++scans_matched_;
    } else {
      ++scans_unmatched_;
    }
  }
  const FrameResult result = session_.process(scan.stamp, odom_pose, last_features_, override_motion);
  // A jump the filter took as no motion is none for the submap's chain either.
  if (session_.jumpDiscarded()) chain_delta = Pose2::Zero();
  if (usedFrame(result)) {
    if (startedMap(result)) submap_.clear();
    addToSubmap(std::move(points), chain_delta);
    reference_odom_pose_ = odom_pose;
  }
  return result;
}

void SlamPipeline::addToSubmap(std::vector<Eigen::Vector2d> points, const Pose2& chain_delta) {
  const Pose2 pose = submap_.empty() ? Pose2::Zero() : compose(submap_.back().pose, chain_delta);
  submap_.push_back(SubmapScan{pose, std::move(points)});
  while (static_cast<int>(submap_.size()) > matcher_.options().submap_scans) submap_.pop_front();
  // The reference for the next match: every kept scan seen from the newest one. Scans stay
  // contiguous in the list so the matcher's neighbour normals never span two scans' points
  // (it skips neighbours more than 0.5 m apart, and a seam pair counts as one skipped point).
  const Pose2 newest_inverse = inverse(pose);
  reference_points_.clear();
  for (const SubmapScan& scan : submap_) {
    const Pose2 to_newest = compose(newest_inverse, scan.pose);
    const double c = std::cos(to_newest.z()), s = std::sin(to_newest.z());
    for (const Eigen::Vector2d& p : scan.points) {
      reference_points_.emplace_back(c * p.x() - s * p.y() + to_newest.x(),
                                     s * p.x() + c * p.y() + to_newest.y());
    }
  }
}

FrameResult SlamPipeline::processSonar(const std::vector<ConeReading>& readings,
                                       const Pose2& odom_pose, double stamp) {
  // A reading the session will reject must not reach the window first: the extractor clears it
  // on any stamp a second back, so one zero-stamped or stale reading used to wipe it. (Readings
  // a little out of order, from transducers stamped apart, still join the window.)
  if (!std::isfinite(stamp) || stamp <= 0.0) return FrameResult::kRejectedStamp;
  if (!odom_pose.allFinite()) return FrameResult::kRejectedPose;
  bool restarted = false;
  if (session_.lastStamp() != sonar_run_session_stamp_) sonar_clock_.inOrder();  // a frame since
  if (!session_.trajectory().empty() && stamp < session_.lastStamp()) {
    const SessionOptions& o = session_.options();
    const bool far_back = o.reset_on_time_jump_back_s > 0.0 &&
                          session_.lastStamp() - stamp > o.reset_on_time_jump_back_s;
    if (far_back) {
      // Late rings are rejected; a restarted clock (ClockRestartDetector) starts a new map, as
      // the session does for frames far back in a row.
      if (sonar_clock_.runLength() == 0) sonar_run_session_stamp_ = session_.lastStamp();
      if (!sonar_clock_.farBack(stamp)) return FrameResult::kRejectedStamp;
      session_.reset();
      sonar_extractor_.reset();
      pending_cones_.clear();  // the old run's
      restarted = true;
    } else if (sonar_extractor_.wouldClearWindow(stamp)) {
      return FrameResult::kRejectedStamp;  // stale, but not far enough back to be a new clock
    }
  }
  if (!restarted) sonar_clock_.inOrder();
  const long clock_jumps = sonar_extractor_.stats().clock_jumps;
  sonar_extractor_.addReadings(readings, odom_pose, stamp);
  // The extractor cleared its window for stamps that went back (a restarted clock, a second
  // log): the held cone readings were measured in the other run's odometry too. The session
  // decides when the map itself starts over.
  if (sonar_extractor_.stats().clock_jumps != clock_jumps) pending_cones_.clear();
  if (odom_pose.allFinite()) {
    for (const ConeReading& r : readings) pending_cones_.push_back({r, odom_pose});
    if (pending_cones_.size() > kMaxPendingCones) {
      pending_cones_.erase(pending_cones_.begin(),
                           pending_cones_.end() - static_cast<long>(kMaxPendingCones));
    }
  }
  FrameResult result;
  if (session_.trajectory().empty()) {
    // The first frame anchors the map; the window has nothing to extract from yet.
    last_features_ = FeatureSet();
    last_features_.stamp = stamp;
    last_features_.cones = pendingConesInBase(odom_pose);
    result = session_.process(stamp, odom_pose, last_features_);
  } else {
    // The rest of a ring stamped like the frame just processed, or a reading a little late,
    // joins the window; the next later stamp extracts (the session would reject a frame at or
    // before its last stamp, and the features extracted for it would be lost).
    if (stamp <= session_.lastStamp()) return FrameResult::kBuffered;
    if (!sonar_extractor_.extractionDue(odom_pose)) return FrameResult::kBuffered;
    last_features_ = sonar_extractor_.extract(odom_pose, stamp);
    last_features_.cones = pendingConesInBase(odom_pose);
    result = session_.process(stamp, odom_pose, last_features_);
  }
  if (usedFrame(result)) pending_cones_.clear();
  // The session started over here (its own rule, applied to rings): said as its reset.
  if (restarted && result == FrameResult::kFirstFrame) return FrameResult::kReset;
  return result;
}

std::vector<ConeReading> SlamPipeline::pendingConesInBase(const Pose2& odom_pose) const {
  std::vector<ConeReading> cones;
  cones.reserve(pending_cones_.size());
  if (!odom_pose.allFinite()) return cones;
  const Pose2 odom_to_base = inverse(odom_pose);
  for (const PendingCone& p : pending_cones_) {
    ConeReading reading = p.reading;
    // Where the transducer was when it fired, seen from the base at odom_pose.
    reading.sensor_pose = compose(compose(odom_to_base, p.odom_pose), p.reading.sensor_pose);
    cones.push_back(reading);
  }
  return cones;
}

FrameResult SlamPipeline::processFeatures(const FeatureSet& features, const Pose2& odom_pose) {
  last_features_ = features;
  return session_.process(features.stamp, odom_pose, features);
}

}  // namespace core
}  // namespace rbpf_slam

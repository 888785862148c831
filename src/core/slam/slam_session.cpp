#include "rbpf_slam/core/slam/slam_session.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "rbpf_slam/core/filters/anchored_filter.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {

void validate(const SessionOptions& o) {
  requireRange("linear_update", o.linear_update_m, 0.0, 100.0);
  requireRange("angular_update", o.angular_update_rad, 0.0, 10.0);
  requireRange("max_time_gap", o.max_time_gap_s, 0.0, 1e6);
  requireRange("max_odometry_jump", o.max_odometry_jump_m, 0.0, 1e6);
  requireOneOf("gap_action", o.gap_action, {"inflate", "reset"});
  requireRange("gap_noise_inflation", o.gap_noise_inflation, 1.0, 1000.0);
  requireRange("reset_on_time_jump_back", o.reset_on_time_jump_back_s, 0.0, 1e6);
  requireRange("reset_after_frames_back", o.reset_after_frames_back, 1, 1000);
  requireOneOf("filter_origin", o.filter_origin, {"start", "odom"});
}

bool ClockRestartDetector::farBack(double stamp) {
  if (count_ == 0) {
    count_ = 1;
    last_ = min_ = max_ = stamp;
  } else if (stamp != last_) {
    ++count_;
    last_ = stamp;
    min_ = std::min(min_, stamp);
    max_ = std::max(max_, stamp);
  }
  if (span_s_ <= 0.0 || count_ < distinct_ || max_ - min_ < span_s_) return false;
  count_ = 0;
  return true;
}

ClockRestartDetector::Verdict ClockRestartDetector::classify(double stamp, double last) {
  if (!(span_s_ > 0.0 && stamp + span_s_ < last)) {
    inOrder();
    return Verdict::kInOrder;
  }
  return farBack(stamp) ? Verdict::kRestart : Verdict::kLate;
}

SlamSession::SlamSession(std::unique_ptr<SlamFilter> filter, const SessionOptions& options)
    : filter_(std::move(filter)), options_(options) {
  validate(options_);
  if (!filter_) throw std::invalid_argument("SlamSession needs a filter");
  if (options_.filter_origin == "start") {
    filter_ = std::make_unique<AnchoredFilter>(std::move(filter_));
  }
}

bool SlamSession::setPriorMap(const std::vector<LandmarkEstimate>& landmarks) {
  if (!filter_->loadMap(landmarks)) return false;
  prior_map_ = landmarks;
  prior_grid_.reset();
  // No grid left to spread over (defensive: no shipped variant takes both kinds of map).
  start_global_ = given_global_ = configured_global_ = false;
  if (has_previous_) forgetGivenStart();  // a start on the map this one replaces
  return true;
}

bool SlamSession::setPriorGridMap(const GridMapData& grid) {
  if (!filter_->loadGridMap(grid)) return false;
  prior_grid_ = grid;
  prior_map_.reset();
  // A start pose was on the map this one replaces; a global start is on whichever map is loaded.
  if (has_previous_) given_start_.reset();
  return true;
}

void SlamSession::reloadPriorMap() {
  if (prior_map_) filter_->loadMap(*prior_map_);
  if (prior_grid_) filter_->loadGridMap(*prior_grid_);
}

bool SlamSession::setMapping(bool enabled) {
  if (!filter_->setMapping(enabled)) return false;
  mapping_ = enabled;
  return true;
}

bool SlamSession::setPose(const Pose2& pose, const Eigen::Matrix3d& covariance) {
  // Checked here, not only by the filter: before the first frame the pose is only stored, and a
  // covariance the filter refuses then would be dropped without a word at that frame.
  if (!pose.allFinite() || !poseCovarianceUsable(covariance)) return false;
  if (!has_previous_) {
    start_pose_.emplace(pose, covariance);
    given_start_ = start_pose_;  // a restarted run (bag loop, gap reset) starts there again
    start_global_ = given_global_ = false;
    return true;
  }
  if (!filter_->resetPose(pose, covariance)) return false;
  map_to_odom_ = compose(pose, inverse(last_odom_));
  breakFrames();
  return true;
}

bool SlamSession::canLocalizeGlobally(std::string* why) const {
  std::string problem;
  if (!prior_grid_) {
    problem = prior_map_ ? "variant " + filter_->variant() +
                               " localizes on a landmark map; global localization spreads over "
                               "an occupancy grid (grid_pf with map_server's map.yaml)"
                         : "no grid map is loaded (map_file or ~load_map naming map_server's "
                           "map.yaml)";
  } else if (mapping_) {
    problem =
        "mapping is on: global localization needs localization_only (each of thousands of "
        "particles would map its own copy from a random pose)";
  } else if (!filter_->canSpreadOverMap(&problem)) {
    // The filter says why: the variant never spreads, or the map has no free cell.
    if (problem.empty()) problem = "variant " + filter_->variant() + " cannot spread over this map";
  }
  if (why) *why = problem;
  return problem.empty();
}

bool SlamSession::localizeGlobally(std::string* why, GlobalStart kind) {
  std::string problem;
  if (canLocalizeGlobally(&problem) && has_previous_ && !filter_->spreadOverMap()) {
    problem = "variant " + filter_->variant() + " could not spread its particles over the map";
  }
  if (!problem.empty()) {
    if (why) *why = problem;
    return false;
  }
  if (kind == GlobalStart::kConfigured) configured_global_ = true;
  if (!has_previous_) {
    start_pose_.reset();
    given_start_.reset();
    start_global_ = given_global_ = true;
    return true;
  }
  // map -> odom stays: the mean of the spread is no place, the next update says where it is.
  breakFrames();
  return true;
}

bool SlamSession::startsGlobally(std::string* why_not) const {
  if (why_not) why_not->clear();
  return start_global_ && canLocalizeGlobally(why_not);
}

void SlamSession::breakFrames() {
  frames_.clear();
  frames_broken_ = true;
}

void SlamSession::forgetGivenStart() {
  given_start_.reset();
  given_global_ = false;
}

void SlamSession::reset(ResetCause cause) {
  if (cause == ResetCause::kRequested) forgetGivenStart();
  restart();
  odometry_stamps_.clear();  // after a clock jump they would be the old run's
  counted_silence_start_ = -std::numeric_limits<double>::infinity();
}

void SlamSession::restart() {
  filter_->reset(Pose2::Zero());
  reloadPriorMap();
  start_pose_ = given_start_;
  // A start pose given before the run's first frame wins over the configured global start.
  start_global_ = given_global_ || (configured_global_ && !given_start_);
  has_previous_ = false;
  last_stamp_ = 0.0;
  map_to_odom_ = Pose2::Zero();
  trajectory_.clear();
  frames_.clear();
  frames_broken_ = false;
  frames_back_ = 0;
  ++resets_;
}

FrameResult SlamSession::process(double stamp, const Pose2& odom_pose,
                                 const FeatureSet& features, const MotionInput* measured_motion) {
  jump_discarded_ = false;
  if (!std::isfinite(stamp) || stamp <= 0.0) return FrameResult::kRejectedStamp;
  if (!odom_pose.allFinite()) return FrameResult::kRejectedPose;
  bool restarted = false;
  if (has_previous_ && stamp == last_stamp_) return FrameResult::kSkippedSameStamp;
  if (has_previous_ && stamp < last_stamp_) {
    // A large jump back in several frames in a row is a restarted clock (a looping bag):
    // start a new map. One late message (a slow driver) must not wipe the map: it is rejected.
    const bool far_back = options_.reset_on_time_jump_back_s > 0.0 &&
                          last_stamp_ - stamp > options_.reset_on_time_jump_back_s;
    frames_back_ = far_back ? frames_back_ + 1 : 0;
    if (!far_back || frames_back_ < options_.reset_after_frames_back) {
      return FrameResult::kRejectedStamp;
    }
    reset();
    restarted = true;
    // fall through: this frame becomes the first of the new run
  }
  frames_back_ = 0;
  if (!has_previous_) {
    has_previous_ = true;
    last_stamp_ = stamp;
    last_odom_ = odom_pose;
    if (start_pose_) {
      // A given start (initial pose, usually on a prior map): map -> odom puts odom there.
      filter_->reset(start_pose_->first);
      reloadPriorMap();
      filter_->resetPose(start_pose_->first, start_pose_->second);
      map_to_odom_ = compose(start_pose_->first, inverse(odom_pose));
      start_pose_.reset();
    } else {
      // Anchor the map at the first pose: map == odom at start. Asked to localize globally
      // (and still localizing only), the particles are spread over the prior grid map instead,
      // and this frame's update weighs them.
      filter_->reset(odom_pose);
      reloadPriorMap();
      map_to_odom_ = Pose2::Zero();
      if (start_global_ && !mapping_) filter_->spreadOverMap();
    }
    start_global_ = false;
    last_stats_ = filter_->update(features);
    const Pose2 first = filter_->estimate().mean;
    if (first.allFinite()) map_to_odom_ = compose(first, inverse(odom_pose));
    trajectory_.push_back({stamp, first});
    MotionInput none;
    none.stamp = stamp;
    keepFrame(none, features);
    return restarted ? FrameResult::kReset : FrameResult::kFirstFrame;
  }
  const Pose2 delta = between(last_odom_, odom_pose);
  const bool moved = std::hypot(delta.x(), delta.y()) >= options_.linear_update_m ||
                     std::fabs(delta.z()) >= options_.angular_update_rad;
  if (!moved) return FrameResult::kSkippedNoMotion;
  MotionInput motion;
  motion.stamp = stamp;
  motion.dt = stamp - last_stamp_;
  motion.delta = delta;
  const bool measured = measured_motion && measured_motion->delta.allFinite();  // accepted
  if (measured) {
    motion.delta = measured_motion->delta;
    motion.noise_scale = measured_motion->noise_scale;
  }
  // A long silence of the odometry (or, when its stamps are unknown, of the frames) or an
  // odometry jump: the increment is not to be trusted as usual.
  const double limit = options_.max_time_gap_s;
  const OdometryStamps::Silence silence = odometry_stamps_.longestSilence(last_stamp_, stamp);
  const bool stamps_known = silence.length >= 0.0;
  const bool silent = limit > 0.0 && (stamps_known ? silence.length : motion.dt) > limit;
  const bool jump = isOdometryJump(delta);
  // Every frame taken inside one silence of the odometry gets the inflated noise (its
  // increment is interpolated across it), but the silence counts, and resets the map, once.
  bool new_gap = jump || (silent && !stamps_known);
  if (silent && stamps_known) {
    const OdometryStamps::Silence fresh =
        odometry_stamps_.longestSilence(last_stamp_, stamp, counted_silence_start_);
    if (fresh.length > limit) {
      new_gap = true;
      counted_silence_start_ = fresh.start;
    }
  }
  if (new_gap) {
    ++gaps_;
    if (options_.gap_action == "reset") {
      const long gaps = gaps_;
      // On a prior map, or in a frame set by a given start, the new run starts where the robot
      // is: after a time gap where the correction puts the odometry (it may have moved), after
      // an odometry jump where it was (the jump is not to be trusted); less sure by the given
      // start's spread, or rviz's. Otherwise it starts at its odometry coordinates (a new map).
      // Still spread over the map (global localization under way): the robot may be anywhere
      // on it yet, and the new run spreads again rather than start around the cloud's mean.
      const bool still_spread = !mapping_ && filter_->stillSpread();
      std::optional<std::pair<Pose2, Eigen::Matrix3d>> here;
      const PoseEstimate last = filter_->estimate();
      if (!still_spread && (hasPriorMap() || given_start_)) {
        const Pose2 at = jump ? last.mean : compose(map_to_odom_, odom_pose);
        const Eigen::Matrix3d spread =
            last.covariance + (given_start_ ? given_start_->second : defaultStartCovariance());
        if (at.allFinite() && poseCovarianceUsable(spread)) here.emplace(at, spread);
      }
      restart();  // the odometry stamps stay: they are still this run's
      start_pose_ = here;
      if (still_spread) start_global_ = true;
      gaps_ = gaps;
      process(stamp, odom_pose, features);  // the first frame of a new map
      return FrameResult::kReset;
    }
  }
  // A measured (scan-matched) increment that was accepted is kept as it is; odometry alone
  // across a gap gets its noise inflated, and an odometry jump is not taken at all: the robot
  // is where it was (as a gap reset puts it), and map -> odom absorbs the jump. With no motion
  // only the motion model's floor noise is left (its distance terms vanish), times the
  // inflation: what the robot really moved must come from the next scans.
  if ((silent || jump) && !measured) motion.noise_scale = options_.gap_noise_inflation;
  jump_discarded_ = jump && !measured;
  if (jump_discarded_) motion.delta = Pose2::Zero();
  filter_->predict(motion);
  last_stats_ = filter_->update(features);
  last_stamp_ = stamp;
  last_odom_ = odom_pose;
  odometry_stamps_.forgetBefore(stamp);
  const Pose2 map_pose = filter_->estimate().mean;
  if (map_pose.allFinite()) {
    map_to_odom_ = compose(map_pose, inverse(odom_pose));
    trajectory_.push_back({stamp, map_pose});
    keepFrame(motion, features);
  } else {
    // No trajectory point for this update: the kept frames would skip its motion.
    frames_.clear();
    frames_broken_ = true;
  }
  return FrameResult::kUpdated;
}

std::vector<Pose2> SlamSession::estimatedPath(bool* best_particle) const {
  std::vector<Pose2> path = filter_->bestPath();
  const bool best = path.size() == trajectory_.size() && !trajectory_.empty();
  if (best_particle) *best_particle = best;
  if (best) return path;
  path.clear();
  for (const TrajectoryPoint& p : trajectory_) path.push_back(p.pose);
  return path;
}

std::vector<TrajectoryPoint> SlamSession::estimatedTrajectory(bool* best_particle) const {
  const std::vector<Pose2> path = estimatedPath(best_particle);
  std::vector<TrajectoryPoint> out(trajectory_.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = {trajectory_[i].stamp, path[i]};
  return out;
}

void SlamSession::keepFrame(const MotionInput& motion, const FeatureSet& features) {
  if (!options_.keep_frames || frames_broken_) return;
  SessionFrame frame;
  frame.motion = motion;
  frame.features.stamp = features.stamp;
  frame.features.points = features.points;
  frame.features.lines = features.lines;
  frames_.push_back(std::move(frame));
}

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Drives one SlamFilter from odometry poses and feature sets: decides when to update,
// rejects out-of-order input, keeps the trajectory and the map -> odom correction.
// Shared by rbpf_slam_node and offline_slam so both run the same code path.

#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/grid/grid_map_data.h"
#include "rbpf_slam/core/slam/odometry_stamps.h"

namespace rbpf_slam {
namespace core {

struct SessionOptions {
  double linear_update_m = 0.0;     // update only after moving this far (0: every frame)
  double angular_update_rad = 0.0;  // ... or turning this much
  double max_time_gap_s = 30.0;     // odometry silent this long (s) between two frames (the
                                    // stamps given to addOdometryStamp; without any, the time
                                    // between the frames) ...
  double max_odometry_jump_m = 0.0;    // ... or a longer odometry increment (m; 0: unchecked;
                                       // with "inflate" and no measured motion: taken as none)
  std::string gap_action = "inflate";  // ... is a gap: "inflate" the motion noise of that step
                                       // by gap_noise_inflation, or "reset" (a new map)
  double gap_noise_inflation = 5.0;
  double reset_on_time_jump_back_s = 1.0;  // stamps going back more than this ...
  int reset_after_frames_back = 3;  // ... in this many frames in a row: reset (a looping bag);
                                    // fewer are stale messages, rejected
  // Keep every updated frame's motion and features (points and lines, not raw scans) for the
  // smoother that runs after the run (map_smoother.h). Memory grows with the run's length.
  bool keep_frames = false;
  // Where the filter's own coordinates are centred (anchored_filter.h): "start" (the position
  // of the run's first pose, so results do not depend on where the odometry frame begins) or
  // "odom" (the odometry frame's origin). Either way poses and maps are reported in the map
  // frame, which equals the odometry frame at the first frame.
  std::string filter_origin = "start";
};

void validate(const SessionOptions& options);

/// Tells a restarted clock (a bag played again) from late messages, for inputs that arrive as
/// many messages per instant: a sonar ring is one message per transducer, with one stamp or
/// with stamps a few milliseconds apart, so counting messages (or stamps) would take one late
/// ring for a restart. A run of stamps far back, with no input in order in between, is a
/// restarted clock once it holds reset_after_frames_back distinct stamps spanning at least
/// reset_on_time_jump_back_s (the new clock has run on that long); a late ring spans far less.
class ClockRestartDetector {
 public:
  explicit ClockRestartDetector(const SessionOptions& options)
      : span_s_(options.reset_on_time_jump_back_s),
        distinct_(options.reset_after_frames_back) {}
  /// A stamp far back. True when the run is a restarted clock (the run then starts over).
  bool farBack(double stamp);
  /// An input in order (or used by the session): ends the run.
  void inOrder() { count_ = 0; }
  enum class Verdict { kInOrder, kLate, kRestart };
  /// For an input stamped `stamp` after one at `last`: not far back (by the span; also with
  /// the span 0) is kInOrder and ends the run; far back is kRestart when farBack() says so,
  /// else kLate (a late message, to drop).
  Verdict classify(double stamp, double last);
  int runLength() const { return count_; }

 private:
  double span_s_;
  int distinct_;
  int count_ = 0;  // distinct stamps in the run
  double last_ = 0.0, min_ = 0.0, max_ = 0.0;
};

/// What became of a frame. kFirstFrame and kReset both start a map: kReset when the session
/// itself threw the previous one away (stamps far back several times in a row, or an odometry
/// gap with gap_action: reset), which the caller should report and follow (clear what it
/// derived from the old run). kSkippedSameStamp: a frame at exactly the stamp of the last one,
/// i.e. another input of the same instant (the simulator stamps `scan` and `features` alike;
/// `laser_features` stamps its features with their scan's) or the same message again; not
/// used (fusing it would count one scan twice when the features came from it) and not an
/// error. kRejectedStamp: an older (or zero, or non-finite) stamp.
enum class FrameResult {
  kUpdated,
  kSkippedNoMotion,
  kFirstFrame,
  kRejectedStamp,
  kRejectedPose,
  kReset,
  kSkippedSameStamp,
  kBuffered  // sonar readings went to the echo window (invalid ones counted there, not used);
             // a later frame extracts and updates
};

struct TrajectoryPoint {
  double stamp = 0.0;
  Pose2 pose = Pose2::Zero();  // base in map
};

/// A frame the filter was updated with, kept for smoothing (SessionOptions::keep_frames).
struct SessionFrame {
  MotionInput motion;    // the increment from the previous kept frame (zero for the first)
  FeatureSet features;   // points and lines only
};

class SlamSession {
 public:
  SlamSession(std::unique_ptr<SlamFilter> filter, const SessionOptions& options);

  /// Offers one observation frame taken at stamp with the robot at odom_pose (odom frame).
  /// measured_motion, when given, replaces the odometry increment since the last update (e.g.
  /// a laser-corrected one); odom_pose still defines the map -> odom correction.
  FrameResult process(double stamp, const Pose2& odom_pose, const FeatureSet& features,
                      const MotionInput* measured_motion = nullptr);
  /// Records that odometry (odom -> base) was received at stamp: the gap check then measures
  /// how long the odometry was silent between two frames, not how far apart the frames are
  /// (sensors such as a landmark camera report only when they see something).
  void addOdometryStamp(double stamp) { odometry_stamps_.add(stamp); }
  /// The odometry pose of the last frame the filter used.
  const Pose2& lastOdomPose() const { return last_odom_; }
  /// Why a run starts over (reset()).
  enum class ResetCause {
    kClockWentBack,  // a bag played again: the run starts again at the start given before its
                     // first frame (setPose, or spread: localizeGlobally), if any, else spread
                     // when the config asks for it (GlobalStart::kConfigured)
    kRequested       // ~reset: from scratch, at the odometry's coordinates (a start pose or a
                     // global start given before is forgotten), or spread over the prior grid
                     // map when the config asks for it (GlobalStart::kConfigured)
  };
  /// Clears the filter and the history; a prior map and the mapping mode are kept. (A reset for
  /// an odometry gap, gap_action "reset", starts the new run where the robot was when a prior
  /// map or a start pose was given, else at the odometry's coordinates.)
  void reset(ResetCause cause = ResetCause::kClockWentBack);

  /// A map to start from (map frame), e.g. a saved one: given to the filter now and again
  /// after every reset. Returns false when the filter variant cannot take a map. Loaded during a
  /// run, it forgets the start pose given before the run's first frame (it was on the old map).
  /// It ends any global start (there is no grid left to spread over).
  bool setPriorMap(const std::vector<LandmarkEstimate>& landmarks);
  /// The same for an occupancy grid (variants that map cells, grid_pf). Replaces a landmark
  /// prior map and is replaced by one. Throws std::invalid_argument for a grid the filter cannot
  /// hold (nothing changed then). Loaded during a run, it forgets a start pose given before the
  /// first frame but keeps a global start: a restarted run then starts spread over this grid
  /// when one was asked for (the configured one included).
  bool setPriorGridMap(const GridMapData& grid);
  /// Mapping (true) or localization only on the current map (false); false if unsupported.
  bool setMapping(bool enabled);
  bool mapping() const { return mapping_; }
  /// Puts the robot at pose (map frame) with this uncertainty (rviz's 2D Pose Estimate).
  /// Before the first frame, the start of this run and of every restarted one (reset()).
  /// Before the first frame, the first frame starts there instead of at the map origin.
  /// False (nothing changed) for a non-finite pose, a covariance that poseCovarianceUsable()
  /// refuses, or one the filter variant cannot take.
  bool setPose(const Pose2& pose, const Eigen::Matrix3d& covariance);
  /// How long a global start asked for lasts (localizeGlobally).
  enum class GlobalStart {
    kGiven,      // asked (~global_localization, --global-localization): like setPose, forgotten
                 // by ~reset (ResetCause::kRequested)
    kConfigured  // the config's global_localization: every run starts spread, also after
                 // ~reset, unless a start pose is given before its first frame
  };
  /// Global localization on the prior grid map (amcl's global_localization): the robot may be
  /// anywhere on its free cells, with any heading. During a run the particles are spread at
  /// once (map -> odom stays as it was until the next update). Before the first frame, like
  /// setPose, the start of this run and of every restarted one (a start pose given after it
  /// replaces it; a grid map loaded after it keeps it; ~reset forgets a kGiven one), spread at
  /// the first frame if mapping is still off then. False, with the reason in *why, and nothing
  /// changed (checked in this order): without a prior grid map, while mapping (each of
  /// thousands of particles would map its own copy from a random pose: localization only), for
  /// a variant that cannot spread over one, or on a map without a free cell.
  bool localizeGlobally(std::string* why = nullptr, GlobalStart kind = GlobalStart::kGiven);
  /// What global localization needs, for messages that refuse it.
  static constexpr const char* kGlobalLocalizationNeeds =
      "grid_pf on a map_server map with localization_only: true";
  /// Whether localizeGlobally would succeed now (every check but, during a run, the spread
  /// itself); false with its reason in *why.
  bool canLocalizeGlobally(std::string* why = nullptr) const;
  /// Whether the config's global start was taken (localizeGlobally with kConfigured; cleared by
  /// setPriorMap): each run's first frame spreads if mapping is off then, unless a start pose was
  /// given before it (which holds for restarted runs until ~reset).
  bool configuredGlobally() const { return configured_global_; }
  /// Whether this run's first frame, still to come, will spread the particles over the prior
  /// grid map (false once the run has started: ask after reset()). False, with the reason in
  /// *why_not, when a global start is asked for but cannot be done (canLocalizeGlobally's
  /// reason: mapping is on, a grid loaded since without a free cell, ...); *why_not is left
  /// empty when none is asked for.
  bool startsGlobally(std::string* why_not = nullptr) const;

  /// map -> odom so that map -> base equals the filter's estimate at the last update.
  Pose2 mapToOdom() const { return map_to_odom_; }
  const std::vector<TrajectoryPoint>& trajectory() const { return trajectory_; }
  /// One per trajectory point when keep_frames, else empty; emptied (until the next reset) when
  /// the pose is reset during a run or an update gives no finite estimate, either of which
  /// breaks the path the frames would tie together.
  const std::vector<SessionFrame>& frames() const { return frames_; }
  /// The path to report: the filter's best path where it has one per trajectory point
  /// (FastSLAM variants), else the trajectory's poses; *best_particle (when given) says which.
  std::vector<Pose2> estimatedPath(bool* best_particle = nullptr) const;
  /// estimatedPath() with the trajectory's stamps: what the node publishes on ~trajectory.
  std::vector<TrajectoryPoint> estimatedTrajectory(bool* best_particle = nullptr) const;
  bool hasPriorMap() const { return prior_map_.has_value() || prior_grid_.has_value(); }
  /// The occupancy grid given by setPriorGridMap, null without one.
  const GridMapData* priorGridMap() const { return prior_grid_ ? &*prior_grid_ : nullptr; }
  /// What is wrong with pose as a start on the prior grid map (outside it, in a wall:
  /// poseOffMapProblem), or "" (fine, or no grid map).
  std::string offPriorMapProblem(const Pose2& pose) const {
    return prior_grid_ ? poseOffMapProblem(*prior_grid_, pose) : "";
  }
  const UpdateStats& lastStats() const { return last_stats_; }
  const SlamFilter& filter() const { return *filter_; }
  SlamFilter& filter() { return *filter_; }
  double lastStamp() const { return last_stamp_; }
  /// Whether this run has had its first frame (a start pose or spread given now is used at once).
  bool started() const { return has_previous_; }
  long resets() const { return resets_; }
  /// Whether the last process() call took its odometry increment as no motion (an odometry jump,
  /// max_odometry_jump_m, with gap_action "inflate" and no accepted measured motion).
  bool jumpDiscarded() const { return jump_discarded_; }
  const SessionOptions& options() const { return options_; }
  /// Whether an odometry increment between two frames is a jump (longer than
  /// max_odometry_jump_m, when that is set): not motion to the session, nor a scan match's start.
  bool isOdometryJump(const Pose2& increment) const {
    return options_.max_odometry_jump_m > 0.0 &&
           std::hypot(increment.x(), increment.y()) > options_.max_odometry_jump_m;
  }
  /// Gaps met (max_time_gap_s, max_odometry_jump_m): one odometry silence counts once, however
  /// many frames fall inside it.
  long gaps() const { return gaps_; }

 private:
  /// reset() but for what is known about the input (the odometry stamps): a new map after a gap.
  void restart();
  /// Forgets the start given before the first frame (a pose or the global spread).
  void forgetGivenStart();
  /// After the particles were put somewhere else (setPose, localizeGlobally during a run): the
  /// kept frames no longer continue the filter's path.
  void breakFrames();

  std::unique_ptr<SlamFilter> filter_;
  const SessionOptions options_;
  bool has_previous_ = false;
  double last_stamp_ = 0.0;
  Pose2 last_odom_ = Pose2::Zero();
  Pose2 map_to_odom_ = Pose2::Zero();
  std::vector<TrajectoryPoint> trajectory_;
  std::vector<SessionFrame> frames_;
  bool frames_broken_ = false;  // the path broke during this run: no frames are kept
  void keepFrame(const MotionInput& motion, const FeatureSet& features);
  UpdateStats last_stats_;
  long resets_ = 0;
  int frames_back_ = 0;             // consecutive frames far behind last_stamp_
  long gaps_ = 0;                   // gaps met (gaps())
  OdometryStamps odometry_stamps_;  // cleared by reset()
  // Where the last odometry silence counted began (it counts once, whatever frames follow).
  double counted_silence_start_ = -std::numeric_limits<double>::infinity();
  /// Gives the filter the prior map again (after it was reset).
  void reloadPriorMap();
  std::optional<std::vector<LandmarkEstimate>> prior_map_;
  std::optional<GridMapData> prior_grid_;
  std::optional<std::pair<Pose2, Eigen::Matrix3d>> start_pose_;  // for the first frame
  std::optional<std::pair<Pose2, Eigen::Matrix3d>> given_start_;  // given before the first one
  bool start_global_ = false;  // the first frame starts spread over the prior grid map ...
  bool given_global_ = false;  // ... as asked before the first frame (localizeGlobally)
  bool configured_global_ = false;  // ... as configured: kept by ~reset (GlobalStart)
  bool mapping_ = true;
  bool jump_discarded_ = false;  // the last process() took its increment as none (a jump)
};

}  // namespace core
}  // namespace rbpf_slam

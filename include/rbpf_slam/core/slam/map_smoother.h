#pragma once
// Smoothing of a finished run: the best particle's path and its point landmarks re-estimated
// together by nonlinear least squares over every odometry increment and every sighting (a
// batch "full SLAM" pass after the filter, off by default). A particle's path is a sample,
// jittered by the proposal's noise at every step; its map inherits that jitter. The smoother
// re-derives the data association at the filter's path against its final map (the particle's
// own record would hold the draws of association sampling, which fared worse on MRCLAM) and
// removes the jitter.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/filters/observation.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/slam/slam_session.h"

namespace rbpf_slam {
namespace core {

struct SmoothingOptions {
  bool enabled = false;       // smooth the path and map after the run (offline_slam, ~save_map)
  int rounds = 1;             // association then solution, repeated (2: associate again at
                              // the smoothed path; not better on MRCLAM)
  int max_iterations = 30;    // Levenberg-Marquardt iterations per round at most
  double gate_chi2 = 9.21;    // a sighting joins the nearest point landmark within this
                              // Mahalanobis^2 at the round's path (else it is left out); one
                              // with a known id joins the landmark of that id
  double huber_k = 2.0;       // robust kernel on each sighting's normalised residual (0: none)
  int min_sightings = 2;      // landmarks with fewer associated sightings keep the filter's value
  // Choosing among ensemble members (smoothSession): each landmark a member's map adds to the
  // smoothing counts as this many sightings left out. A member that lost its way can explain
  // its sightings by mapping copies of the landmarks; 0 counts the sightings left out alone.
  double member_landmark_cost = 0.0;
  // With > 0, every member whose score (above) is within this many sightings of the best one
  // is a candidate, and the candidate whose smoothed path lies closest to the other members'
  // (the median over them of the RMS distance after rigid alignment) is kept: members that
  // found the same path agree, each one that lost its way is lost differently. 0: the best
  // score alone. Needs three smoothed members or more (else the score alone).
  double member_consensus_margin = 0.0;
  // Copies of a landmark merged after the solution (0: off). A filter that lost its heading in
  // a silence maps the landmarks it meets again as new ones; the smoother, free to bend the path
  // within the odometry's noise, can join them. Two point landmarks that are each smoothed (at
  // least min_sightings sightings), never sighted in one frame, of the same known id or none,
  // and at most merge_max_distance_m apart are a candidate pair. The pair whose merge (one's
  // sightings given to the other, the one sighted more often, which keeps its id; then solved
  // again, to convergence) raises the least-squares cost least is merged while that rise is at
  // most merge_max_cost (per merge, not in total). Each pass solves once per candidate pair.
  // Then the merged map is associated and solved once more at the new path (kept unless it
  // leaves more sightings out). On an ensemble the merges come before the member choice, so a
  // member's copies, once merged, no longer count against it (member_landmark_cost).
  double merge_max_cost = 0.0;
  double merge_max_distance_m = 3.0;
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const SmoothingOptions& options);

/// One filter update as the smoother needs it.
struct SmoothingFrame {
  Pose2 motion = Pose2::Zero();  // odometry increment from the previous frame (its base frame)
  Eigen::Matrix3d motion_covariance = Eigen::Matrix3d::Identity();  // of that increment
  std::vector<Observation> observations;  // point observations are used; lines are not
};

struct SmoothingResult {
  bool ok = false;
  std::string message;         // why not, or a one-line account
  std::vector<Pose2> path;     // the smoothed path (the input one when !ok)
  std::vector<LandmarkEstimate> landmarks;  // points re-estimated; lines and the rest as given
  int sightings_used = 0;      // point observations associated with a landmark
  int sightings_left_out = 0;  // point observations outside every landmark's gate
  int landmarks_smoothed = 0;
  int iterations = 0;          // over every round
  double initial_cost = 0.0;   // sum of squared (robust-weighted) normalised residuals
  double final_cost = 0.0;
  int member = 0;              // smoothSession on an ensemble: the member smoothed
  int landmarks_merged = 0;    // copies merged (SmoothingOptions::merge_max_cost)
};

/// Smooths path (one pose per frame, in the map frame) and the point landmarks (whatever
/// options.enabled says: that switch is for the callers). frames[0]'s motion is ignored: the
/// first pose is held (it anchors the map frame). A landmark keeps its id and its observation
/// count (the filter's; merged copies, SmoothingOptions::merge_max_cost, are removed and their
/// counts added); the covariance is the one given the smoothed path. Non-finite input,
/// sizes that disagree or no usable sighting give ok = false with the input unchanged.
SmoothingResult smoothPathAndMap(const std::vector<Pose2>& path,
                                 const std::vector<SmoothingFrame>& frames,
                                 const std::vector<LandmarkEstimate>& landmarks,
                                 const SmoothingOptions& options);

/// Which of the ensemble members' smoothing results (all ok, paths of equal length) to keep:
/// the fewest sightings left out plus member_landmark_cost per landmark smoothed (then the
/// lowest final cost); with member_consensus_margin > 0 and three results or more, of those
/// scoring within the margin of that best, the one whose path has the smallest median
/// alignedRmsDistance to the other results' paths (medians within 1 mm of the smallest count
/// as equal, and of those the best score is kept). When that rule ran (even with one
/// candidate), *consensus (if given) says so in words for the message, else it is left empty.
/// The results' paths must be finite (smoothPathAndMap's ok results are). Throws
/// std::invalid_argument on no results or paths of different lengths.
size_t chooseMember(const std::vector<SmoothingResult>& smoothed, const SmoothingOptions& options,
                    std::string* consensus = nullptr);

/// The same for a session that kept its frames (SessionOptions::keep_frames): its estimated
/// path, the filter's landmarks, and each frame's odometry noise from options.motion and
/// observation noise from options.measurement. Refused (ok = false) on a prior map or with
/// mapping off, and after a pose reset during the run. On an ensemble (filter().members() > 1)
/// every member's path and map are smoothed and the one with the fewest sightings outside every
/// gate of its map plus member_landmark_cost per landmark smoothed is returned (then the lowest
/// final cost): a member that lost its way mapped copies its own path explains, but the
/// sightings of the stretches before or after do not fit them, or it mapped more copies. With
/// member_consensus_margin > 0 and three smoothed members or more, the member returned is the
/// one among those within the margin of the best score whose smoothed path is closest to the
/// others' (chooseMember).
SmoothingResult smoothSession(const SlamSession& session, const FilterOptions& options,
                              const SmoothingOptions& smoothing);

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Trajectory accuracy against a reference: time association, rigid 2D alignment, absolute
// trajectory error (ATE) and relative pose error (RPE), as in Sturm et al. (IROS 2012)
// restricted to the plane.

#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "rbpf_slam/core/alignment.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/io/trajectory.h"

namespace rbpf_slam {
namespace io {

/// How estimate and reference poses are paired and compared.
struct EvaluationOptions {
  // Largest |t_estimate - t_reference| for a nearest-neighbour match [s].
  double max_dt_s = 0.05;
  // Interpolate the reference linearly between its two poses bracketing each estimate stamp
  // instead of taking the nearest one. Estimates outside the reference's time span (or across
  // a longer gap) still match the nearest reference pose within max_dt_s.
  bool interpolate_reference = false;
  // With interpolation, the largest gap between the two bracketing reference poses [s].
  double max_interpolation_gap_s = std::numeric_limits<double>::infinity();
  // Align the estimate to the reference with the best rigid 2D transform before the ATE.
  bool align = true;
};

/// One estimate pose and the reference pose it is compared with.
struct PosePair {
  double stamp = 0.0;  // s, estimate stamp
  double dt = 0.0;     // s, reference stamp - estimate stamp (0 when interpolated)
  core::Pose2 estimate = core::Pose2::Zero();
  core::Pose2 reference = core::Pose2::Zero();
};

/// Accuracy figures of one estimate against one reference.
struct EvaluationResult {
  std::size_t estimate_poses = 0;
  std::size_t reference_poses = 0;
  std::size_t matched_poses = 0;
  bool aligned = false;
  core::Pose2 alignment = core::Pose2::Zero();  // reference <- estimate (x, y, theta)
  double duration_s = 0.0;                      // time span of the matched poses
  double reference_length_m = 0.0;              // path length of the matched reference poses
  // Absolute trajectory error over the matched poses, after alignment when aligned.
  double ate_rmse_m = 0.0;
  double ate_mean_m = 0.0;
  double ate_median_m = 0.0;
  double ate_max_m = 0.0;
  double rotation_rmse_deg = 0.0;
  double rotation_mean_deg = 0.0;
  double rotation_max_deg = 0.0;
  // Relative pose error between consecutive matched poses (independent of alignment).
  std::size_t rpe_pairs = 0;
  double rpe_translation_mean_m = 0.0;
  double rpe_translation_rmse_m = 0.0;
  double rpe_rotation_mean_deg = 0.0;
  double rpe_rotation_rmse_deg = 0.0;
  // The last matched pose, after alignment when aligned.
  double final_position_error_m = 0.0;
  double final_heading_error_deg = 0.0;
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const EvaluationOptions& options);

/// Pairs estimate poses with the reference by stamp (see EvaluationOptions). Nearest-neighbour
/// matching is one-to-one: a pair is kept when each pose is the other's nearest in time and
/// they are at most max_dt_s apart. With interpolation every estimate inside the reference's
/// time span gets its own interpolated pose. Neither input needs to be sorted; the pairs come
/// out in estimate-stamp order.
std::vector<PosePair> associate(const std::vector<StampedPose>& estimate,
                                const std::vector<StampedPose>& reference,
                                const EvaluationOptions& options);

/// The rigid alignment of two point sets (core/alignment.h), used here for the ATE.
using core::alignRigid2D;

/// Error figures of already associated pairs. Throws std::runtime_error when pairs is empty.
EvaluationResult evaluatePairs(const std::vector<PosePair>& pairs, bool align);

/// Associates, aligns (unless options.align is false) and measures. Throws std::runtime_error
/// when no pose matches, or std::invalid_argument for bad options.
EvaluationResult evaluateTrajectory(const std::vector<StampedPose>& estimate,
                                    const std::vector<StampedPose>& reference,
                                    const EvaluationOptions& options);

/// The result as a pretty-printed JSON object (non-finite numbers as null).
std::string toJson(const EvaluationResult& result);

}  // namespace io
}  // namespace rbpf_slam

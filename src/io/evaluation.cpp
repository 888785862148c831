#include "rbpf_slam/io/evaluation.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/core/statistics.h"
#include "rbpf_slam/io/json_writer.h"

namespace rbpf_slam {
namespace io {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

std::vector<StampedPose> sortedByStamp(std::vector<StampedPose> poses) {
  std::stable_sort(poses.begin(), poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.stamp < b.stamp; });
  return poses;
}

bool stampLess(const StampedPose& pose, double stamp) { return pose.stamp < stamp; }

// Index of the pose nearest to stamp in non-empty poses sorted by stamp; on a tie, the later
// one (the earlier with prefer_earlier); among equal stamps, the first. The one-to-one match
// looks up the reference with one rule and back with the other, so that two streams offset by
// exactly half a period still pair up.
std::size_t nearestIndex(const std::vector<StampedPose>& poses, double stamp,
                         bool prefer_earlier = false) {
  const std::size_t after = static_cast<std::size_t>(
      std::lower_bound(poses.begin(), poses.end(), stamp, stampLess) - poses.begin());
  if (after == poses.size()) return poses.size() - 1;
  const double to_before = after > 0 ? stamp - poses[after - 1].stamp : 0.0;
  const double to_after = poses[after].stamp - stamp;
  if (after > 0 && (to_before < to_after || (prefer_earlier && to_before == to_after))) {
    // Step back to the first of a run of equal stamps (a search: such runs can be long).
    const double before_stamp = poses[after - 1].stamp;
    return static_cast<std::size_t>(
        std::lower_bound(poses.begin(), poses.begin() + after, before_stamp, stampLess) -
        poses.begin());
  }
  return after;
}

// The reference pose at `stamp` on the straight segment between `before` and `after`.
core::Pose2 interpolate(const StampedPose& before, const StampedPose& after, double stamp) {
  const double fraction = (stamp - before.stamp) / (after.stamp - before.stamp);
  const Eigen::Vector2d position =
      before.pose.head<2>() + fraction * (after.pose.head<2>() - before.pose.head<2>());
  const double heading =
      before.pose.z() + fraction * core::wrapAngle(after.pose.z() - before.pose.z());
  return core::Pose2(position.x(), position.y(), core::wrapAngle(heading));
}

double rootMeanSquare(const std::vector<double>& values) {
  double sum = 0.0;
  for (double value : values) sum += value * value;
  return values.empty() ? 0.0 : std::sqrt(sum / values.size());
}

double mean(const std::vector<double>& values) {
  double sum = 0.0;
  for (double value : values) sum += value;
  return values.empty() ? 0.0 : sum / values.size();
}

double maximum(const std::vector<double>& values) {
  return values.empty() ? 0.0 : *std::max_element(values.begin(), values.end());
}

}  // namespace

void validate(const EvaluationOptions& options) {
  if (!(options.max_dt_s >= 0.0)) {
    throw std::invalid_argument("max_dt_s must be >= 0, got " + std::to_string(options.max_dt_s));
  }
  if (!(options.max_interpolation_gap_s > 0.0)) {
    throw std::invalid_argument("max_interpolation_gap_s must be > 0, got " +
                                std::to_string(options.max_interpolation_gap_s));
  }
}

std::vector<PosePair> associate(const std::vector<StampedPose>& estimate,
                                const std::vector<StampedPose>& reference,
                                const EvaluationOptions& options) {
  validate(options);
  const std::vector<StampedPose> sorted_estimate = sortedByStamp(estimate);
  const std::vector<StampedPose> sorted_reference = sortedByStamp(reference);
  std::vector<PosePair> pairs;
  if (sorted_reference.empty()) return pairs;
  for (std::size_t i = 0; i < sorted_estimate.size(); ++i) {
    const StampedPose& query = sorted_estimate[i];
    PosePair pair;
    pair.stamp = query.stamp;
    pair.estimate = query.pose;
    if (options.interpolate_reference) {
      const auto after = std::lower_bound(sorted_reference.begin(), sorted_reference.end(),
                                          query.stamp, stampLess);
      if (after != sorted_reference.end() && after != sorted_reference.begin() &&
          after->stamp != query.stamp &&
          after->stamp - (after - 1)->stamp <= options.max_interpolation_gap_s) {
        pair.reference = interpolate(*(after - 1), *after, query.stamp);
        pairs.push_back(pair);
        continue;
      }
    }
    // Nearest neighbours, one-to-one: keep the pair only when the estimate is also the
    // reference pose's nearest, so a dense estimate is not counted many times per reference.
    const std::size_t j = nearestIndex(sorted_reference, query.stamp);
    const double dt = sorted_reference[j].stamp - query.stamp;
    if (std::abs(dt) > options.max_dt_s) continue;
    if (!options.interpolate_reference &&
        nearestIndex(sorted_estimate, sorted_reference[j].stamp, true) != i) {
      continue;
    }
    pair.dt = dt;
    pair.reference = sorted_reference[j].pose;
    pairs.push_back(pair);
  }
  return pairs;
}

EvaluationResult evaluatePairs(const std::vector<PosePair>& pairs, bool align) {
  if (pairs.empty()) throw std::runtime_error("no matched poses to evaluate");
  EvaluationResult result;
  result.matched_poses = pairs.size();
  result.aligned = align;
  if (align) {
    std::vector<Eigen::Vector2d> source, target;
    source.reserve(pairs.size());
    target.reserve(pairs.size());
    for (const PosePair& pair : pairs) {
      source.push_back(pair.estimate.head<2>());
      target.push_back(pair.reference.head<2>());
    }
    result.alignment = alignRigid2D(source, target);
  }

  std::vector<double> position_errors, heading_errors;
  for (const PosePair& pair : pairs) {
    const core::Pose2 aligned = core::compose(result.alignment, pair.estimate);
    position_errors.push_back((aligned.head<2>() - pair.reference.head<2>()).norm());
    heading_errors.push_back(std::abs(core::wrapAngle(aligned.z() - pair.reference.z())) *
                             kRadToDeg);
  }
  result.ate_rmse_m = rootMeanSquare(position_errors);
  result.ate_mean_m = mean(position_errors);
  result.ate_median_m = core::median(position_errors);
  result.ate_max_m = maximum(position_errors);
  result.rotation_rmse_deg = rootMeanSquare(heading_errors);
  result.rotation_mean_deg = mean(heading_errors);
  result.rotation_max_deg = maximum(heading_errors);
  result.final_position_error_m = position_errors.back();
  result.final_heading_error_deg = heading_errors.back();

  std::vector<double> step_translation_errors, step_rotation_errors;
  for (size_t i = 1; i < pairs.size(); ++i) {
    const core::Pose2 estimated_step = core::between(pairs[i - 1].estimate, pairs[i].estimate);
    const core::Pose2 reference_step = core::between(pairs[i - 1].reference, pairs[i].reference);
    const core::Pose2 error = core::between(reference_step, estimated_step);
    step_translation_errors.push_back(error.head<2>().norm());
    step_rotation_errors.push_back(std::abs(error.z()) * kRadToDeg);
    result.reference_length_m += reference_step.head<2>().norm();
  }
  result.rpe_pairs = step_translation_errors.size();
  result.rpe_translation_mean_m = mean(step_translation_errors);
  result.rpe_translation_rmse_m = rootMeanSquare(step_translation_errors);
  result.rpe_rotation_mean_deg = mean(step_rotation_errors);
  result.rpe_rotation_rmse_deg = rootMeanSquare(step_rotation_errors);
  result.duration_s = pairs.back().stamp - pairs.front().stamp;
  return result;
}

EvaluationResult evaluateTrajectory(const std::vector<StampedPose>& estimate,
                                    const std::vector<StampedPose>& reference,
                                    const EvaluationOptions& options) {
  const std::vector<PosePair> pairs = associate(estimate, reference, options);
  if (pairs.empty()) {
    std::ostringstream message;
    message << "no estimate pose (of " << estimate.size() << ") has a reference pose (of "
            << reference.size() << ") within " << options.max_dt_s << " s";
    throw std::runtime_error(message.str());
  }
  EvaluationResult result = evaluatePairs(pairs, options.align);
  result.estimate_poses = estimate.size();
  result.reference_poses = reference.size();
  return result;
}

std::string toJson(const EvaluationResult& result) {
  const std::string alignment = "{\"x_m\": " + jsonNumber(result.alignment.x()) +
                                ", \"y_m\": " + jsonNumber(result.alignment.y()) +
                                ", \"theta_deg\": " +
                                jsonNumber(result.alignment.z() * kRadToDeg) + "}";
  JsonObjectWriter json;
  json.integer("estimate_poses", result.estimate_poses)
      .integer("reference_poses", result.reference_poses)
      .integer("matched_poses", result.matched_poses)
      .boolean("aligned", result.aligned)
      .raw("alignment", alignment)
      .number("duration_s", result.duration_s)
      .number("reference_length_m", result.reference_length_m)
      .number("ate_rmse_m", result.ate_rmse_m)
      .number("ate_mean_m", result.ate_mean_m)
      .number("ate_median_m", result.ate_median_m)
      .number("ate_max_m", result.ate_max_m)
      .number("rotation_rmse_deg", result.rotation_rmse_deg)
      .number("rotation_mean_deg", result.rotation_mean_deg)
      .number("rotation_max_deg", result.rotation_max_deg)
      .integer("rpe_pairs", result.rpe_pairs)
      .number("rpe_translation_mean_m", result.rpe_translation_mean_m)
      .number("rpe_translation_rmse_m", result.rpe_translation_rmse_m)
      .number("rpe_rotation_mean_deg", result.rpe_rotation_mean_deg)
      .number("rpe_rotation_rmse_deg", result.rpe_rotation_rmse_deg)
      .number("final_position_error_m", result.final_position_error_m)
      .number("final_heading_error_deg", result.final_heading_error_deg);
  return json.str();
}

}  // namespace io
}  // namespace rbpf_slam

// evaluate ESTIMATE.tum REFERENCE.tum [--max-dt S] [--no-align] [--interpolate [--max-gap S]]
// Prints ATE and relative pose errors of a trajectory against a reference as JSON on stdout.
// Exit status: 0 on success, 2 on bad usage, 1 for unreadable files, no matched poses, or one
// matched pose to align (warns on stamps out of order and on few matches).

#include <algorithm>
#include <cmath>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/io/evaluation.h"
#include "rbpf_slam/io/tool_arguments.h"
#include "rbpf_slam/io/trajectory.h"

namespace {

namespace io = rbpf_slam::io;

const char kUsage[] =
    "usage: evaluate ESTIMATE.tum REFERENCE.tum [--max-dt S] [--no-align]\n"
    "                [--interpolate [--max-gap S]]\n"
    "  --max-dt S     largest stamp difference for a match, seconds (default 0.05)\n"
    "  --no-align     compare in the given frames (no rigid 2D alignment)\n"
    "  --interpolate  interpolate the reference between its poses bracketing each estimate\n"
    "  --max-gap S    with --interpolate, largest gap between bracketing poses (default none)\n"
    "Prints the absolute trajectory error (ATE) and relative pose errors as JSON.\n";

struct Arguments {
  std::vector<std::string> positional;
  io::EvaluationOptions options;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments arguments;
  io::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    if (cursor.arg() == "--max-dt") {
      arguments.options.max_dt_s = cursor.number(io::NumberRule::kNonNegative);  // 0: same stamps
    } else if (cursor.arg() == "--no-align") {
      arguments.options.align = false;
    } else if (cursor.arg() == "--interpolate") {
      arguments.options.interpolate_reference = true;
    } else if (cursor.arg() == "--max-gap") {
      arguments.options.max_interpolation_gap_s =
          cursor.number(io::NumberRule::kPositiveOrInfinite);
    } else if (cursor.isOption()) {
      cursor.unknown();
    } else {
      arguments.positional.push_back(cursor.arg());
    }
  }
  if (!arguments.options.interpolate_reference &&
      arguments.options.max_interpolation_gap_s !=
          io::EvaluationOptions().max_interpolation_gap_s) {
    throw std::invalid_argument("--max-gap applies only with --interpolate");
  }
  if (arguments.positional.size() != 2) {
    throw std::invalid_argument("expected ESTIMATE.tum and REFERENCE.tum, got " +
                                std::to_string(arguments.positional.size()) + " file argument(s)");
  }
  return arguments;
}

/// The work once the arguments are understood; the exit status.
int run(const Arguments& arguments) {
  const std::vector<std::string>& positional = arguments.positional;
  const auto estimate = io::readTum(positional[0]);
  const auto reference = io::readTum(positional[1]);
  if (estimate.empty()) throw std::runtime_error(positional[0] + ": no poses");
  if (reference.empty()) throw std::runtime_error(positional[1] + ": no poses");
  // Stamps out of order are sorted by the evaluation, and of poses sharing a stamp one is
  // matched: say so (two runs concatenated, a file written twice).
  for (int k = 0; k < 2; ++k) {
    const auto& poses = k == 0 ? estimate : reference;
    std::size_t not_after = 0, first = 0;
    for (std::size_t i = 1; i < poses.size(); ++i) {
      if (!(poses[i].stamp > poses[i - 1].stamp) && not_after++ == 0) first = i + 1;
    }
    if (not_after > 0) {
      std::cerr << "evaluate: warning: " << positional[k] << ": " << not_after
                << " pose(s) stamped at or before the pose above them (the first is pose "
                << first << "); evaluated in time order\n";
    }
  }
  const auto result = io::evaluateTrajectory(estimate, reference, arguments.options);
  if (arguments.options.align && result.matched_poses < 2) {
    // One pair aligns onto itself whatever the error: an ATE of 0 would say nothing.
    throw std::runtime_error("only " + std::to_string(result.matched_poses) +
                             " matched pose(s): the alignment needs at least 2 (or --no-align)");
  }
  std::cout << io::toJson(result);
  const double figures[] = {result.duration_s,
                            result.reference_length_m,
                            result.ate_rmse_m,
                            result.ate_mean_m,
                            result.ate_median_m,
                            result.ate_max_m,
                            result.rotation_rmse_deg,
                            result.rotation_mean_deg,
                            result.rotation_max_deg,
                            result.rpe_translation_mean_m,
                            result.rpe_translation_rmse_m,
                            result.rpe_rotation_mean_deg,
                            result.rpe_rotation_rmse_deg,
                            result.final_position_error_m,
                            result.final_heading_error_deg};
  for (double figure : figures) {
    if (std::isfinite(figure)) continue;
    // Coordinates near 1e154 m (a diverged run) overflow when squared: null is no figure.
    throw std::runtime_error(
        "the errors overflow (ate_rmse_m " + std::to_string(result.ate_rmse_m) +
        "): the trajectories hold coordinates too large to compare (|x| or |y| above 1e150 m?); "
        "the figures above are not usable");
  }
  // Figures over a few poses say little about the trajectory: say so (the stamps may not line
  // up within --max-dt, e.g. another clock or another rate).
  if (2 * result.matched_poses < std::min(estimate.size(), reference.size())) {
    std::cerr << "evaluate: only " << result.matched_poses << " of " << estimate.size()
              << " estimate poses matched a reference pose (" << reference.size()
              << " poses) within --max-dt " << arguments.options.max_dt_s
              << " s; the figures cover those only\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return io::runTool("evaluate", kUsage, argc, argv, parseArguments, run);
}

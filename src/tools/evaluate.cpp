// evaluate ESTIMATE.tum REFERENCE.tum [--max-dt S] [--no-align] [--interpolate [--max-gap S]]
// Prints ATE and relative pose errors of a trajectory against a reference as JSON on stdout.
// Exit status: 0 on success, 2 on bad usage, unreadable files or no matched poses.

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/io/evaluation.h"
#include "rbpf_slam/io/trajectory.h"

namespace {

constexpr int kUsageError = 2;

const char kUsage[] =
    "usage: evaluate ESTIMATE.tum REFERENCE.tum [--max-dt S] [--no-align]\n"
    "                [--interpolate [--max-gap S]]\n"
    "  --max-dt S     largest stamp difference for a match, seconds (default 0.05)\n"
    "  --no-align     compare in the given frames (no rigid 2D alignment)\n"
    "  --interpolate  interpolate the reference between its poses bracketing each estimate\n"
    "  --max-gap S    with --interpolate, largest gap between bracketing poses (default none)\n"
    "Prints the absolute trajectory error (ATE) and relative pose errors as JSON.\n";

double parsePositiveSeconds(const std::string& flag, const std::string& text, bool allow_zero) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || std::isnan(value) || value < 0.0 ||
      (!allow_zero && value == 0.0)) {
    throw std::invalid_argument(flag + " needs a " + (allow_zero ? "non-negative" : "positive") +
                                " number of seconds, got '" + text + "'");
  }
  return value;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> positional;
  rbpf_slam::io::EvaluationOptions options;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      const auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
        return argv[++i];
      };
      if (arg == "-h" || arg == "--help") {
        std::cout << kUsage;
        return 0;
      } else if (arg == "--max-dt") {
        options.max_dt_s = parsePositiveSeconds(arg, next(), true);
      } else if (arg == "--no-align") {
        options.align = false;
      } else if (arg == "--interpolate") {
        options.interpolate_reference = true;
      } else if (arg == "--max-gap") {
        options.max_interpolation_gap_s = parsePositiveSeconds(arg, next(), false);
      } else if (arg.size() > 1 && arg[0] == '-') {
        throw std::invalid_argument("unknown option " + arg);
      } else {
        positional.push_back(arg);
      }
    }
    if (positional.size() != 2) {
      throw std::invalid_argument("expected ESTIMATE.tum and REFERENCE.tum, got " +
                                  std::to_string(positional.size()) + " file argument(s)");
    }
  } catch (const std::invalid_argument& error) {
    std::cerr << "evaluate: " << error.what() << "\n" << kUsage;
    return kUsageError;
  }

  try {
    const auto estimate = rbpf_slam::io::readTum(positional[0]);
    const auto reference = rbpf_slam::io::readTum(positional[1]);
    if (estimate.empty()) throw std::runtime_error(positional[0] + ": no poses");
    if (reference.empty()) throw std::runtime_error(positional[1] + ": no poses");
    const auto result = rbpf_slam::io::evaluateTrajectory(estimate, reference, options);
    std::cout << rbpf_slam::io::toJson(result);
  } catch (const std::exception& error) {
    std::cerr << "evaluate: " << error.what() << "\n";
    return kUsageError;
  }
  return 0;
}

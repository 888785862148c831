// validate_bag: reports what in a bag would trouble SLAM (backwards or repeated stamps, gaps,
// zero stamps, NaN ranges, frames tf cannot reach, topics that change frame).
//   validate_bag IN.bag [--base-frame F] [--odom-frame F] [--max-gap S]
// Exit status: 0 nothing found, 1 problems found, 2 usage error or unreadable bag.

#include <cstdio>
#include <exception>
#include <string>

#include "rbpf_slam/ros/bag_validation.h"

namespace {

int usage(const std::string& message) {
  std::fprintf(stderr,
               "validate_bag: %s\nusage: validate_bag IN.bag [--base-frame F] [--odom-frame F] "
               "[--max-gap S]\n",
               message.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  rbpf_slam::rosbridge::BagValidationOptions options;
  std::string path;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--base-frame" && has_value) {
      options.base_frame = argv[++i];
    } else if (arg == "--odom-frame" && has_value) {
      options.odom_frame = argv[++i];
    } else if (arg == "--max-gap" && has_value) {
      try {
        options.max_gap_s = std::stod(argv[++i]);
      } catch (const std::exception&) {
        return usage("--max-gap needs a number of seconds");
      }
      if (!(options.max_gap_s > 0.0)) return usage("--max-gap must be > 0");
    } else if (!arg.empty() && arg[0] != '-' && path.empty()) {
      path = arg;
    } else {
      return usage("unknown or incomplete argument '" + arg + "'");
    }
  }
  if (path.empty()) return usage("the bag is required");
  rbpf_slam::rosbridge::BagReport report;
  try {
    report = rbpf_slam::rosbridge::validateBag(path, options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "validate_bag: %s\n", e.what());
    return 2;
  }
  std::printf("%s: %.1f s\n", report.path.c_str(), report.duration_s);
  for (const auto& s : report.streams) {
    std::printf("  %-40s %8ld messages", s.name.c_str(), s.messages);
    if (s.largest_gap_s > 0.0) std::printf(", largest step %.2f s", s.largest_gap_s);
    std::printf("\n");
  }
  for (const auto& note : report.notes) std::printf("note: %s\n", note.c_str());
  for (const auto& problem : report.problems) std::printf("PROBLEM: %s\n", problem.c_str());
  if (report.problems.empty()) std::printf("no problems found\n");
  return report.problems.empty() ? 0 : 1;
}

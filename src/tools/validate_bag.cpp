// validate_bag: reports what in a bag would trouble SLAM (backwards or repeated stamps, gaps,
// zero stamps, NaN ranges, frames tf cannot reach, topics that change frame).
//   validate_bag IN.bag [--base-frame F] [--odom-frame F] [--max-gap S]
// Exit status: 0 nothing found, 1 problems found, 2 usage error or unreadable bag.

#include <cstdio>
#include <exception>
#include <optional>
#include <string>

#include "rbpf_slam/io/tool_arguments.h"
#include "rbpf_slam/ros/bag_validation.h"

namespace {

namespace io = rbpf_slam::io;

const char kUsage[] =
    "usage: validate_bag IN.bag [--base-frame F] [--odom-frame F] [--max-gap S]\n"
    "  --base-frame F  the robot frame tf must reach (default base_link)\n"
    "  --odom-frame F  the odometry frame (default odom)\n"
    "  --max-gap S     a step between two stamps of a stream longer than this (default 2 s) and\n"
    "                  than 5x the stream's median step (the largest left out) is a gap\n"
    "Exit status: 0 nothing found, 1 problems found, 2 bad usage or a bag that cannot be read.\n";

struct Arguments {
  std::string path;
  rbpf_slam::rosbridge::BagValidationOptions options;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments a;
  io::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    if (cursor.arg() == "--base-frame") {
      a.options.base_frame = cursor.value();
    } else if (cursor.arg() == "--odom-frame") {
      a.options.odom_frame = cursor.value();
    } else if (cursor.arg() == "--max-gap") {
      a.options.max_gap_s = cursor.number(io::NumberRule::kPositiveOrInfinite);  // inf: no check
    } else if (!cursor.isOption() && a.path.empty()) {
      a.path = cursor.arg();
    } else {
      throw std::invalid_argument("unknown or extra argument '" + cursor.arg() + "'");
    }
  }
  if (a.path.empty()) throw std::invalid_argument("the bag is required");
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  int exit_status = 0;
  const std::optional<Arguments> parsed =
      io::parseToolArguments("validate_bag", kUsage, argc, argv, parseArguments, &exit_status);
  if (!parsed) return exit_status;
  const std::string& path = parsed->path;
  const rbpf_slam::rosbridge::BagValidationOptions& options = parsed->options;
  rbpf_slam::rosbridge::BagReport report;
  try {
    report = rbpf_slam::rosbridge::validateBag(path, options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "validate_bag: %s\n", e.what());
    return io::kUsageExitStatus;  // documented: 1 means problems found
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

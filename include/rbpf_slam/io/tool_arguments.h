#pragma once
// The command-line preamble the converters share: -h / --help prints the usage, a bad argument
// prints "TOOL: what was wrong" and the usage and ends with the usage exit status.

#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>

namespace rbpf_slam {
namespace io {

/// Exit status of a tool called with bad arguments.
constexpr int kUsageExitStatus = 2;

/// `parse(argc, argv)` throws std::invalid_argument for a bad argument. Returns its result, or
/// nothing with *exit_status set: 0 after printing `usage` for -h / --help (anywhere on the
/// line), kUsageExitStatus after printing the error and `usage` to stderr.
template <typename Parse>
auto parseToolArguments(const std::string& tool, const char* usage, int argc, char** argv,
                        Parse parse, int* exit_status)
    -> std::optional<decltype(parse(argc, argv))> {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      std::cout << usage;
      *exit_status = 0;
      return std::nullopt;
    }
  }
  try {
    return parse(argc, argv);
  } catch (const std::invalid_argument& error) {
    std::cerr << tool << ": " << error.what() << "\n" << usage;
    *exit_status = kUsageExitStatus;
    return std::nullopt;
  }
}

}  // namespace io
}  // namespace rbpf_slam

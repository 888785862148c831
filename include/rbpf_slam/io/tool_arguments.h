#pragma once
// The command line every tool shares: -h / --help prints the usage and exits 0, a bad argument
// prints "TOOL: what was wrong" and the usage and exits 2, a failure while working exits 1.
// An ArgumentCursor walks the arguments, the parse* functions read numbers the same way
// everywhere, besideBag names the files a tool writes next to its bag.

#include <cstdint>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>

namespace rbpf_slam {
namespace io {

/// Exit status of a tool called with bad arguments.
constexpr int kUsageExitStatus = 2;
/// Exit status of a tool that failed while working (an input it cannot read, a write that failed).
constexpr int kFailureExitStatus = 1;

enum class NumberRule {
  kFinite,
  kNonNegative,
  kPositive,
  kPositiveOrInfinite,  // "inf" too: no limit (a tolerance, a gap)
};

/// `text` as a number obeying `rule`; std::invalid_argument naming `flag` otherwise.
double parseNumber(const std::string& flag, const std::string& text,
                   NumberRule rule = NumberRule::kFinite);
/// `text` as a non-negative integer (a seed, a count) of digits only, within 64 bits;
/// std::invalid_argument naming `flag` otherwise.
std::uint64_t parseUnsigned(const std::string& flag, const std::string& text);

/// OUT.bag -> OUT + suffix (the bag's path without ".bag", or the whole path if it has none).
std::string besideBag(const std::string& bag, const std::string& suffix);

/// Walks argv[1..]: `while (cursor.next())`, then arg() is the argument, isOption() tells an
/// option from a positional argument, value() / number() / count() take the option's value
/// (std::invalid_argument "--flag needs a value" at the end of the line), unknown() throws
/// "unknown option --flag".
class ArgumentCursor {
 public:
  ArgumentCursor(int argc, char** argv) : argc_(argc), argv_(argv) {}
  bool next() {
    if (index_ + 1 >= argc_) return false;
    arg_ = argv_[++index_];
    return true;
  }
  const std::string& arg() const { return arg_; }
  bool isOption() const { return arg_.size() > 1 && arg_[0] == '-'; }
  std::string value() {
    if (index_ + 1 >= argc_) throw std::invalid_argument(arg_ + " needs a value");
    return argv_[++index_];
  }
  double number(NumberRule rule = NumberRule::kFinite) { return parseNumber(arg_, value(), rule); }
  std::uint64_t count() { return parseUnsigned(arg_, value()); }
  /// A value of the form key=value (a config override); the whole text.
  std::string keyValue() {
    const std::string text = value();
    if (text.find('=') == std::string::npos || text.front() == '=') {
      throw std::invalid_argument(arg_ + " needs key=value, got '" + text + "'");
    }
    return text;
  }
  [[noreturn]] void unknown() const { throw std::invalid_argument("unknown option " + arg_); }

 private:
  int argc_;
  char** argv_;
  int index_ = 0;
  std::string arg_;
};

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

/// A tool's whole main(): parseToolArguments, then work(arguments), whose result is the exit
/// status; an exception from work prints "TOOL: what went wrong" and exits kFailureExitStatus.
template <typename Parse, typename Work>
int runTool(const std::string& tool, const char* usage, int argc, char** argv, Parse parse,
            Work work) {
  int exit_status = 0;
  const auto parsed = parseToolArguments(tool, usage, argc, argv, parse, &exit_status);
  if (!parsed) return exit_status;
  try {
    return work(*parsed);
  } catch (const std::exception& error) {
    std::cerr << tool << ": " << error.what() << "\n";
    return kFailureExitStatus;
  }
}

}  // namespace io
}  // namespace rbpf_slam

// The command line every tool shares (io/tool_arguments.h), and the check before a file is
// written over (io/output_file.h).

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/tool_arguments.h"

namespace rbpf_slam {
namespace io {
namespace {

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ToolArguments, NumbersFollowTheirRule) {
  EXPECT_DOUBLE_EQ(parseNumber("--x", "-2.5"), -2.5);
  EXPECT_DOUBLE_EQ(parseNumber("--x", "0", NumberRule::kNonNegative), 0.0);
  EXPECT_DOUBLE_EQ(parseNumber("--x", "1e-3", NumberRule::kPositive), 1e-3);
  EXPECT_EQ(errorOf([] { parseNumber("--x", "0", NumberRule::kPositive); }),
            "--x needs a positive number, got '0'");
  EXPECT_EQ(errorOf([] { parseNumber("--x", "-1", NumberRule::kNonNegative); }),
            "--x needs a non-negative number, got '-1'");
  for (const char* bad : {"", "1.5m", "nan", "inf", "abc"}) {
    EXPECT_EQ(errorOf([&] { parseNumber("--x", bad); }),
              std::string("--x needs a number, got '") + bad + "'")
        << bad;
  }
  EXPECT_TRUE(std::isinf(parseNumber("--gap", "inf", NumberRule::kPositiveOrInfinite)));
  EXPECT_DOUBLE_EQ(parseNumber("--gap", "2", NumberRule::kPositiveOrInfinite), 2.0);
  for (const char* bad : {"0", "-inf", "nan", "x"}) {
    EXPECT_NE(errorOf([&] { parseNumber("--gap", bad, NumberRule::kPositiveOrInfinite); }), "")
        << bad;
  }
  EXPECT_EQ(parseUnsigned("--seed", "42"), 42u);
  EXPECT_EQ(parseUnsigned("--seed", "18446744073709551615"), 18446744073709551615u);
  for (const char* bad : {"", "-1", " -1", "+1", "4.2", "7x", "18446744073709551616"}) {
    EXPECT_NE(errorOf([&] { parseUnsigned("--seed", bad); }), "") << bad;
  }
}

/// A missing path or a regular file may be written; a directory or a pipe is named and refused.
TEST(OutputFile, OnlyMissingOrRegularFilesAreReplaceable) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rbpf_output_file_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "a_directory");
  std::ofstream(dir / "regular") << "x";
  if (mkfifo((dir / "a_pipe").c_str(), 0600) != 0) {
    std::filesystem::remove_all(dir);
    FAIL() << "mkfifo " << (dir / "a_pipe").string() << " failed";
  }
  EXPECT_NO_THROW(requireReplaceableFile((dir / "missing").string()));
  EXPECT_NO_THROW(requireReplaceableFile((dir / "regular").string()));
  const auto message = [](const std::filesystem::path& path) {
    try {
      requireReplaceableFile(path.string());
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(message(dir / "a_directory"),
            (dir / "a_directory").string() +
                ": exists and is a directory (not a regular file); not written over");
  EXPECT_EQ(message(dir / "a_pipe"),
            (dir / "a_pipe").string() +
                ": exists and is a pipe (not a regular file); not written over");
  std::filesystem::remove_all(dir);
}

TEST(ToolArguments, BesideBag) {
  EXPECT_EQ(besideBag("out/run.bag", ".ref.tum"), "out/run.ref.tum");
  EXPECT_EQ(besideBag("run", ".ref.tum"), "run.ref.tum");
  EXPECT_EQ(besideBag(".bag", ".x"), ".bag.x");  // a name that is only the extension
}

TEST(ToolArguments, CursorWalksOptionsValuesAndPositionals) {
  std::vector<std::string> words = {"tool", "in.bag", "--dt", "0.5", "-v", "--seed"};
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(&w[0]);
  ArgumentCursor cursor(static_cast<int>(argv.size()), argv.data());
  ASSERT_TRUE(cursor.next());
  EXPECT_EQ(cursor.arg(), "in.bag");
  EXPECT_FALSE(cursor.isOption());
  ASSERT_TRUE(cursor.next());
  EXPECT_TRUE(cursor.isOption());
  EXPECT_DOUBLE_EQ(cursor.number(NumberRule::kPositive), 0.5);
  EXPECT_EQ(cursor.arg(), "--dt");  // still the option whose value was taken
  ASSERT_TRUE(cursor.next());
  EXPECT_EQ(cursor.arg(), "-v");
  EXPECT_EQ(errorOf([&] { cursor.unknown(); }), "unknown option -v");
  ASSERT_TRUE(cursor.next());
  EXPECT_EQ(errorOf([&] { cursor.count(); }), "--seed needs a value");
  EXPECT_FALSE(cursor.next());

  std::vector<std::string> sets = {"tool", "--set", "a.b=1", "--set", "=1", "--set", "c"};
  argv.clear();
  for (std::string& w : sets) argv.push_back(&w[0]);
  ArgumentCursor overrides(static_cast<int>(argv.size()), argv.data());
  ASSERT_TRUE(overrides.next());
  EXPECT_EQ(overrides.keyValue(), "a.b=1");
  ASSERT_TRUE(overrides.next());
  EXPECT_EQ(errorOf([&] { overrides.keyValue(); }), "--set needs key=value, got '=1'");
  ASSERT_TRUE(overrides.next());
  EXPECT_EQ(errorOf([&] { overrides.keyValue(); }), "--set needs key=value, got 'c'");
  EXPECT_FALSE(cursor.next());
}

TEST(ToolArguments, HelpAndBadArgumentsEndWithTheirStatus) {
  std::vector<std::string> words = {"tool", "--bogus"};
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(&w[0]);
  const auto parse = [](int argc, char** argv) {
    ArgumentCursor cursor(argc, argv);
    while (cursor.next()) cursor.unknown();
    return 1;
  };
  int status = -1;
  EXPECT_FALSE(parseToolArguments("tool", "usage\n", 2, argv.data(), parse, &status));
  EXPECT_EQ(status, kUsageExitStatus);
  words.push_back("-h");
  argv.clear();
  for (std::string& w : words) argv.push_back(&w[0]);
  EXPECT_FALSE(parseToolArguments("tool", "usage\n", 3, argv.data(), parse, &status));
  EXPECT_EQ(status, 0);
  EXPECT_EQ(parseToolArguments("tool", "usage\n", 1, argv.data(), parse, &status), 1);
}

}  // namespace
}  // namespace io
}  // namespace rbpf_slam

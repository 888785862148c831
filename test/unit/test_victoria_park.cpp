// Victoria Park text log: parsing, the pose chain, range-bearing conversion, and malformed
// lines reported with their line number.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/io/victoria_park.h"

namespace rbpf_slam {
namespace io {
namespace {

const char kLog[] =
    "ODOMETRY 0 1 1.0 0 0 0.0001 0 0 4e-06 0 4e-06\n"
    "\n"
    "# a comment\n"
    "ODOMETRY 1 3 1.0 0 1.5707963267948966 0.0001 0 0 4e-06 0 4e-06\r\n"
    "LANDMARK 3 2 10 0 0.4 0 0.4\n"
    "ODOMETRY 3 4 2.0 0 0 0.0001 0 0 4e-06 0 4e-06\n"
    "LANDMARK 9 2 5 5 0.4 0 0.4\n";

std::string errorOf(const std::string& text) {
  std::istringstream in(text);
  try {
    parseVictoriaPark(in, "vp.txt");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(VictoriaPark, ParsesTheChainAndTheSightings) {
  std::istringstream in(kLog);
  const VictoriaParkLog log = parseVictoriaPark(in, "vp.txt");
  ASSERT_EQ(log.odometry.size(), 3u);
  ASSERT_EQ(log.landmarks.size(), 2u);
  EXPECT_EQ(log.odometry[1].from, 1);
  EXPECT_EQ(log.odometry[1].to, 3);
  EXPECT_EQ(log.odometry[1].line, 4u);
  EXPECT_DOUBLE_EQ(log.odometry[0].covariance(0, 0), 1e-4);
  EXPECT_DOUBLE_EQ(log.odometry[0].covariance(2, 2), 4e-6);
  EXPECT_EQ(log.landmarks[0].tree, 2);
  EXPECT_EQ(log.landmarks[0].pose, 3);
  std::size_t orphans = 0;
  const auto poses = victoriaParkPoses(log, &orphans);
  ASSERT_EQ(poses.size(), 4u);
  EXPECT_EQ(orphans, 1u);  // pose 9 is not on the chain
  EXPECT_EQ(poses[2].index, 3);
  ASSERT_EQ(poses[2].landmarks.size(), 1u);
  EXPECT_NEAR(poses[2].odometry.x(), 2.0, 1e-12);
  EXPECT_NEAR(poses[2].odometry.z(), M_PI / 2, 1e-12);
  EXPECT_NEAR(poses[3].odometry.x(), 2.0, 1e-12);  // turned left, then 2 m along +y
  EXPECT_NEAR(poses[3].odometry.y(), 2.0, 1e-12);
  double range = 0, bearing = 0;
  Eigen::Matrix2d c;
  toRangeBearing(poses[2].landmarks[0], &range, &bearing, &c);
  EXPECT_NEAR(range, 10.0, 1e-12);
  EXPECT_NEAR(bearing, 0.0, 1e-12);
  EXPECT_NEAR(c(0, 0), 0.4, 1e-12);          // along the beam: the x variance
  EXPECT_NEAR(c(1, 1), 0.4 / 100.0, 1e-12);  // across: y variance / range^2
}

TEST(VictoriaPark, MalformedLinesNameTheLine) {
  EXPECT_NE(errorOf("ODOMETRY 0 1 1 0 0 1 0 0 1 0\n").find("vp.txt:1:"), std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK 4 x 1 1 0.4 0 0.4\n").find("vp.txt:8:"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK 4 1 1 nan 0.4 0 0.4\n").find("not finite"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK 4 1 1 1e 0.4 0 0.4\n").find("vp.txt:8:"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "GPS 1 2\n").find("unknown record 'GPS'"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK 4 1 1 1 0.4 0\n").find("vp.txt:8: LANDMARK"),
            std::string::npos);
  // A gap in the chain.
  const std::string gap = errorOf(std::string(kLog) + "ODOMETRY 7 8 1 0 0 1 0 0 1 0 1\n");
  EXPECT_NE(gap.find("vp.txt:8:"), std::string::npos) << gap;
  EXPECT_NE(gap.find("does not continue from pose 4"), std::string::npos) << gap;
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK -4 1 1 1 0.4 0 0.4\n").find("vp.txt:8:"),
            std::string::npos);
  EXPECT_NE(errorOf("# nothing\n").find("no ODOMETRY"), std::string::npos);
  // An index beyond a long: named as such (it was clamped and reported as a broken chain).
  const std::string huge =
      errorOf(std::string(kLog) + "ODOMETRY 4 99999999999999999999 1 0 0 1 0 0 1 0 1\n");
  EXPECT_NE(huge.find("'99999999999999999999' is not a non-negative integer index"),
            std::string::npos)
      << huge;
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK 4 1 0 0 0.4 0 0.4\n").find("zero range"),
            std::string::npos);
  // Finite but corrupt: they became inf poses and covariances in the bag (exit 0).
  EXPECT_NE(errorOf(std::string(kLog) + "ODOMETRY 4 5 1e308 0 0 0.0001 0 0 4e-06 0 4e-06\n")
                .find("vp.txt:8: ODOMETRY step (1e308, 0, 0) is implausible"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "ODOMETRY 4 5 1 0 0 -0.0001 0 0 4e-06 0 4e-06\n")
                .find("vp.txt:8: ODOMETRY covariance is not positive semi-definite"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK 4 1 1e200 1e200 0.4 0 0.4\n").find("implausible"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK 4 1 1e-160 0 0.4 0 0.4\n").find("implausible"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kLog) + "LANDMARK 4 1 3 4 -0.4 0 0.4\n")
                .find("vp.txt:8: LANDMARK covariance is not positive definite"),
            std::string::npos);
}

TEST(VictoriaPark, TheShippedFileParses) {
  // The shared data as test/scripts/lib/shared_data.sh finds it.
  std::string path;
  const char* shared = std::getenv("RBPF_SHARED_DATA");
  for (const std::string dir :
       {std::string(shared ? shared : ""), std::string(RBPF_SOURCE_DIR) + "/../shared/data",
        std::string("/work/shared/data")}) {
    if (!dir.empty() && std::ifstream(dir + "/victoria_park/victoria_park.txt")) {
      path = dir + "/victoria_park/victoria_park.txt";
      break;
    }
  }
  if (path.empty()) GTEST_SKIP() << "no shared data with victoria_park/victoria_park.txt";
  const VictoriaParkLog log = loadVictoriaPark(path);
  EXPECT_EQ(log.odometry.size(), 6968u);
  EXPECT_EQ(log.landmarks.size(), 3640u);
  std::size_t orphans = 0;
  EXPECT_EQ(victoriaParkPoses(log, &orphans).size(), 6969u);
  EXPECT_EQ(orphans, 0u);
}

}  // namespace
}  // namespace io
}  // namespace rbpf_slam

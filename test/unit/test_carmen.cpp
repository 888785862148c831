// Tests of the CARMEN log reader and of the odometry and reference derived from a corrected log.

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/io/carmen.h"

namespace rbpf_slam {
namespace io {
namespace {

// A small corrected log: the laser sits 0.1 m ahead of the robot, turned by 0.05 rad.
const char kLog[] =
    "# message formats defined: PARAM SYNC ODOM FLASER\n"
    "PARAM robot_frontlaser_offset 0.1 nohost 0\n"
    "ODOM 0 0 0 0 0 0 0.5 host 0.5\n"
    "FLASER 3 1.0 2.5 81.83 1.1 2.0 0.35 1.0 2.0 0.3 1.0 host 1.0\n"
    "ODOM 1 2 0.3 0 0 0 0 host 0\n"
    "NEFF 15\n"
    "ODOM 1.2 2 0.3 0.1 0.2 0 1.25 host 1.25\n"
    "ODOM 1.2 two 0.3 0.1 0.2 0 1.3 host 1.3\n"
    "\n"
    "FLASER 3 1.0 2.5 host\n"
    "ODOM 1.3 2 nan 0 0 0 1.4 host 1.4\r\n"
    "SYNC 1\n"
    "FLASER 2 4.0 5.0 1.6 2.1 0.45 1.5 2.1 0.4 2.0 host 2.0\r\n";

CarmenLog parse(const std::string& text) {
  std::istringstream in(text);
  return parseCarmenLog(in);
}

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + "/" + name;
}

TEST(CarmenParse, ReadsScansOdometryAndParams) {
  const CarmenLog log = parse(kLog);
  ASSERT_EQ(log.lasers.size(), 2u);
  ASSERT_EQ(log.odometry.size(), 3u);
  EXPECT_EQ(log.params.at("robot_frontlaser_offset"), "0.1");

  const CarmenLaser& first = log.lasers[0];
  EXPECT_DOUBLE_EQ(first.stamp, 1.0);
  ASSERT_EQ(first.ranges.size(), 3u);
  EXPECT_DOUBLE_EQ(first.ranges[1], 2.5);
  EXPECT_DOUBLE_EQ(first.ranges[2], 81.83);
  EXPECT_TRUE(first.laser_pose.isApprox(core::Pose2(1.1, 2.0, 0.35)));
  EXPECT_TRUE(first.robot_pose.isApprox(core::Pose2(1.0, 2.0, 0.3)));
  EXPECT_EQ(first.line, 4u);
  EXPECT_EQ(log.lasers[1].ranges.size(), 2u);
  EXPECT_DOUBLE_EQ(log.lasers[1].stamp, 2.0);  // despite the trailing \r

  EXPECT_DOUBLE_EQ(log.odometry[0].stamp, 0.5);
  EXPECT_EQ(log.odometry[0].lasers_before, 0u);
  EXPECT_EQ(log.odometry[1].lasers_before, 1u);
  EXPECT_DOUBLE_EQ(log.odometry[1].stamp, 0.0);
  EXPECT_TRUE(log.odometry[2].pose.isApprox(core::Pose2(1.2, 2.0, 0.3)));
  EXPECT_DOUBLE_EQ(log.odometry[2].translational_velocity, 0.1);
  EXPECT_DOUBLE_EQ(log.odometry[2].rotational_velocity, 0.2);
  EXPECT_EQ(log.odometry[2].line, 7u);
}

TEST(CarmenParse, CountsUnknownAndMalformedLines) {
  const CarmenLog log = parse(kLog);
  EXPECT_EQ(log.unknown_messages.at("NEFF"), 1u);
  EXPECT_EQ(log.unknown_messages.at("SYNC"), 1u);
  EXPECT_EQ(log.unknown_messages.size(), 2u);
  ASSERT_EQ(log.malformed_lines, 3u);  // a word in ODOM, a short FLASER, a NaN in ODOM
  ASSERT_EQ(log.malformed_examples.size(), 3u);
  EXPECT_EQ(log.malformed_examples[0].rfind("line 8:", 0), 0u) << log.malformed_examples[0];
  EXPECT_NE(log.malformed_examples[0].find("two"), std::string::npos);
  EXPECT_EQ(log.malformed_examples[1].rfind("line 10:", 0), 0u) << log.malformed_examples[1];
  EXPECT_EQ(log.malformed_examples[2].rfind("line 11:", 0), 0u) << log.malformed_examples[2];
}

/// Finite but absurd numbers are corrupt lines (they overflowed the odometry and ros::Time).
TEST(CarmenParse, ImplausibleValuesAreMalformedLines) {
  const CarmenLog far = parse("ODOM 1e300 2 0.3 0 0 0 1.0 host 1.0\n");
  EXPECT_EQ(far.malformed_lines, 1u);
  EXPECT_TRUE(far.odometry.empty());
  ASSERT_EQ(far.malformed_examples.size(), 1u);
  EXPECT_NE(far.malformed_examples[0].find("beyond 1e6 m"), std::string::npos)
      << far.malformed_examples[0];
  EXPECT_EQ(parse("ODOM 1 2 0.3 5e3 0 0 1.0 host 1.0\n").malformed_lines, 1u);      // speed
  EXPECT_EQ(parse("ODOM 1 2 0.3 0 0 0 -1262305000 host 0\n").malformed_lines, 1u);  // stamp
  EXPECT_EQ(parse("FLASER 2 4.0 5.0 1.6 2.1 0.45 1.5 2.1 0.4 1e12 host 2.0\n").malformed_lines, 1u);
  EXPECT_EQ(parse("ODOM 1 2 0.3 0.4 0.2 0 1.0 host 1.0\n").malformed_lines, 0u);
}

TEST(CarmenParse, RejectsBadBeamCounts) {
  EXPECT_EQ(parse("FLASER -1 1 2 3 4 5 6 7\n").malformed_lines, 1u);
  EXPECT_EQ(parse("FLASER 1.5 1 2 3 4 5 6 7 8\n").malformed_lines, 1u);
  EXPECT_EQ(parse("FLASER 2 1 2 3 4 5 6 7 8\n").malformed_lines, 1u);  // one field short
  const CarmenLog ok = parse("FLASER 2 1 2 3 4 5 6 7 8 9\n");
  EXPECT_EQ(ok.malformed_lines, 0u);
  EXPECT_EQ(ok.lasers.size(), 1u);
}

/// Two records joined by a lost newline are one malformed line, not a record whose tail is
/// dropped unseen; old Mac line ends (a lone \r) end lines as \n does.
TEST(CarmenParse, JoinedRecordsAndLoneCarriageReturns) {
  const CarmenLog joined = parse(
      "ODOM 0 0 0 0 0 0 0.5 host 0.5 FLASER 2 4.0 5.0 1.6 2.1 0.45 1.5 2.1 0.4 2.0 host 2.0\n"
      "FLASER 2 4.0 5.0 1.6 2.1 0.45 1.5 2.1 0.4 2.0 host 2.0 ODOM 0 0 0 0 0 0 2.5 host 2.5\n"
      "ODOM 0 0 0 0 0 0 3.5 host 3.5\n");
  EXPECT_EQ(joined.odometry.size(), 1u);
  EXPECT_TRUE(joined.lasers.empty());
  ASSERT_EQ(joined.malformed_examples.size(), 2u);
  EXPECT_EQ(joined.malformed_examples[0].rfind("line 1: ODOM with 23 fields, at most 10", 0), 0u)
      << joined.malformed_examples[0];
  EXPECT_EQ(joined.malformed_examples[1].rfind(
                "line 2: FLASER with 2 beams and 23 fields, at most 13", 0),
            0u)
      << joined.malformed_examples[1];
  EXPECT_NE(joined.malformed_examples[1].find("two records on one line"), std::string::npos);

  const CarmenLog mac = parse(
      "ODOM 0 0 0 0 0 0 0.5 host 0.5\rODOM 0 0 0 0 0 0 0.6\r"
      "FLASER 2 4.0 5.0 1.6 2.1 0.45 1.5 2.1 0.4 2.0 host 2.0\rODOM bad\r");
  EXPECT_EQ(mac.odometry.size(), 2u);
  ASSERT_EQ(mac.lasers.size(), 1u);
  EXPECT_EQ(mac.lasers[0].line, 3u);
  ASSERT_EQ(mac.malformed_examples.size(), 1u);
  EXPECT_EQ(mac.malformed_examples[0].rfind("line 4:", 0), 0u) << mac.malformed_examples[0];
  // CR CR LF ends one line, as grep -n counts it.
  const CarmenLog doubled = parse("ODOM 0 0 0 0 0 0 0.5 host 0.5\r\r\nODOM bad\r\r\n");
  ASSERT_EQ(doubled.malformed_examples.size(), 1u);
  EXPECT_EQ(doubled.malformed_examples[0].rfind("line 2:", 0), 0u)
      << doubled.malformed_examples[0];
}

/// A NUL byte (a file damaged in a crash) makes its line malformed, named, and the lines after
/// it keep their numbers.
TEST(CarmenRead, NulBytesAreNamedAndKeepLineNumbers) {
  const std::string path = tempPath("rbpf_slam_nul.log");
  const std::string text = std::string("ODOM 0 0 0 0 0 0 0.5 host 0.5\n") +
                           std::string(10, '\0') +
                           "FLASER 2 4.0 5.0 1.6 2.1 0.45 1.5 2.1 0.4 2.0 host 2.0\n"
                           "ODOM 0 0 0 0 0 0 2.5 host 2.5\n"
                           "ODOM bad\n" +
                           std::string(5, '\0');
  {
    std::ofstream out(path, std::ios::binary);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  const CarmenLog log = readCarmenLog(path);
  EXPECT_EQ(log.odometry.size(), 2u);
  EXPECT_TRUE(log.lasers.empty());
  ASSERT_EQ(log.malformed_examples.size(), 3u);
  EXPECT_EQ(log.malformed_examples[0].rfind("line 2: a NUL byte", 0), 0u)
      << log.malformed_examples[0];
  EXPECT_EQ(log.malformed_examples[1].rfind("line 4:", 0), 0u) << log.malformed_examples[1];
  EXPECT_EQ(log.malformed_examples[2].rfind("line 5: a NUL byte", 0), 0u)
      << log.malformed_examples[2];
  std::remove(path.c_str());
}

TEST(CarmenRead, GzipAndPlainFilesGiveTheSameLog) {
  const std::string plain = tempPath("rbpf_slam_test.log");
  const std::string compressed = tempPath("rbpf_slam_test.log.gz");
  // One FLASER line longer than the reader's 64 KiB buffer.
  std::string long_line = "FLASER 20000";
  for (int i = 0; i < 20000; ++i) long_line += " 1.25";
  long_line += " 0 0 0 0 0 0 3.5 host 3.5\n";
  const std::string text = std::string(kLog) + long_line;
  {
    std::ofstream out(plain);
    out << text;
  }
  gzFile file = gzopen(compressed.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  ASSERT_EQ(gzwrite(file, text.data(), static_cast<unsigned>(text.size())),
            static_cast<int>(text.size()));
  gzclose(file);

  for (const std::string& path : {plain, compressed}) {
    const CarmenLog log = readCarmenLog(path);
    ASSERT_EQ(log.lasers.size(), 3u) << path;
    EXPECT_EQ(log.lasers[2].ranges.size(), 20000u) << path;
    EXPECT_DOUBLE_EQ(log.lasers[2].ranges.back(), 1.25) << path;
    EXPECT_DOUBLE_EQ(log.lasers[2].stamp, 3.5) << path;
    EXPECT_EQ(log.odometry.size(), 3u) << path;
    EXPECT_EQ(log.malformed_lines, 3u) << path;
  }
  std::remove(plain.c_str());
  std::remove(compressed.c_str());
}

TEST(CarmenRead, MissingFileNamesThePath) {
  const std::string path = tempPath("rbpf_slam_no_such.log.gz");
  try {
    readCarmenLog(path);
    FAIL() << "no error for a missing file";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << error.what();
  }
}

TEST(CarmenLaserGeometry, FollowsCarmenConventions) {
  EXPECT_DOUBLE_EQ(flaserGeometry(180).angle_increment_rad, M_PI / 180.0);
  EXPECT_DOUBLE_EQ(flaserGeometry(181).angle_increment_rad, M_PI / 180.0);
  EXPECT_DOUBLE_EQ(flaserGeometry(361).angle_increment_rad, M_PI / 360.0);
  EXPECT_DOUBLE_EQ(flaserGeometry(91).angle_increment_rad, M_PI / 90.0);
  EXPECT_DOUBLE_EQ(flaserGeometry(180).angle_min_rad, -M_PI / 2.0);
}

TEST(CarmenLaserGeometry, RangesFollowRep117) {
  EXPECT_TRUE(std::isinf(toRep117Range(81.83, 50.0)));
  EXPECT_GT(toRep117Range(81.83, 50.0), 0.0);
  EXPECT_TRUE(std::isinf(toRep117Range(50.0, 50.0)));
  EXPECT_TRUE(std::isnan(toRep117Range(0.0, 50.0)));
  EXPECT_TRUE(std::isnan(toRep117Range(-1.0, 50.0)));
  EXPECT_DOUBLE_EQ(toRep117Range(3.2, 50.0), 3.2);
}

CarmenLaser makeLaser(double stamp, const core::Pose2& pose, std::size_t line) {
  CarmenLaser laser;
  laser.stamp = stamp;
  laser.robot_pose = pose;
  laser.laser_pose = pose;
  laser.line = line;
  return laser;
}

CarmenOdometry makeOdometry(double stamp, double x, std::size_t lasers_before, std::size_t line) {
  CarmenOdometry odometry;
  odometry.stamp = stamp;
  odometry.pose = core::Pose2(x, 0.0, 0.0);
  odometry.lasers_before = lasers_before;
  odometry.line = line;
  return odometry;
}

TEST(CorrectedMotion, KeepsScanPosesAndOrderedOdometryBetweenThem) {
  CarmenLog log;
  log.odometry.push_back(makeOdometry(0.5, 0.1, 0, 1));
  log.odometry.push_back(makeOdometry(1.0, 0.2, 0, 2));  // the next scan's stamp: dropped
  log.lasers.push_back(makeLaser(1.0, core::Pose2(0.15, 0.0, 0.1), 3));
  log.odometry.push_back(makeOdometry(0.0, 0.15, 1, 4));  // unset clock: dropped
  log.odometry.push_back(makeOdometry(1.2, 0.3, 1, 5));
  log.odometry.push_back(makeOdometry(1.7, 0.35, 1, 6));  // jittered: dropped, not the rest
  log.odometry.push_back(makeOdometry(1.3, 0.4, 1, 7));
  log.odometry.push_back(makeOdometry(1.05, 0.5, 1, 8));  // jittered: dropped
  log.odometry.push_back(makeOdometry(1.5, 0.6, 1, 9));
  log.odometry.push_back(makeOdometry(0.9, 0.7, 1, 10));  // before the last scan: dropped
  log.lasers.push_back(makeLaser(2.0, core::Pose2(0.7, 0.1, 0.2), 11));
  log.odometry.push_back(makeOdometry(2.5, 0.8, 2, 12));

  CorrectedMotionStats stats;
  const std::vector<StampedPose> motion = correctedMotion(log, &stats);
  const std::vector<double> expected_stamps = {0.5, 1.0, 1.2, 1.3, 1.5, 2.0, 2.5};
  ASSERT_EQ(motion.size(), expected_stamps.size());
  for (size_t i = 0; i < motion.size(); ++i) {
    EXPECT_DOUBLE_EQ(motion[i].stamp, expected_stamps[i]) << i;
  }
  EXPECT_TRUE(motion[1].pose.isApprox(log.lasers[0].robot_pose));
  EXPECT_TRUE(motion[5].pose.isApprox(log.lasers[1].robot_pose));
  EXPECT_DOUBLE_EQ(motion[4].pose.x(), 0.6);
  EXPECT_EQ(stats.odometry_used, 5u);
  EXPECT_EQ(stats.odometry_dropped, 5u);
  EXPECT_EQ(stats.duplicate_stamps, 0u);
  EXPECT_EQ(stats.scans_out_of_order, 0u);
}

TEST(CorrectedMotion, SortsScansLoggedOutOfOrder) {
  CarmenLog log;
  log.lasers.push_back(makeLaser(10.0, core::Pose2(1.0, 0.0, 0.0), 1));
  log.lasers.push_back(makeLaser(9.5, core::Pose2(2.0, 0.0, 0.0), 2));
  log.odometry.push_back(makeOdometry(9.8, 2.1, 2, 3));  // before the first scan's 10 s
  log.odometry.push_back(makeOdometry(10.5, 2.2, 2, 4));
  log.lasers.push_back(makeLaser(11.0, core::Pose2(3.0, 0.0, 0.0), 5));
  log.lasers.push_back(makeLaser(11.0, core::Pose2(4.0, 0.0, 0.0), 6));  // same stamp

  CorrectedMotionStats stats;
  const std::vector<StampedPose> motion = correctedMotion(log, &stats);
  ASSERT_EQ(motion.size(), 4u);
  EXPECT_DOUBLE_EQ(motion[0].stamp, 9.5);
  EXPECT_DOUBLE_EQ(motion[0].pose.x(), 2.0);
  EXPECT_DOUBLE_EQ(motion[1].stamp, 10.0);
  EXPECT_DOUBLE_EQ(motion[2].pose.x(), 2.2);
  EXPECT_DOUBLE_EQ(motion[3].pose.x(), 3.0);  // the first of two equal stamps
  EXPECT_EQ(stats.duplicate_stamps, 1u);
  EXPECT_EQ(stats.odometry_dropped, 1u);
  EXPECT_EQ(stats.scans_out_of_order, 1u);  // line 2's 9.5 s after line 1's 10 s
  EXPECT_EQ(stats.first_out_of_order_line, 2u);
  EXPECT_DOUBLE_EQ(stats.first_out_of_order_stamp, 9.5);
  EXPECT_EQ(stats.latest_before_line, 1u);
  EXPECT_DOUBLE_EQ(stats.latest_before_stamp, 10.0);

  const std::vector<StampedPose> scans = scanPoses(log);
  ASSERT_EQ(scans.size(), 4u);
  EXPECT_DOUBLE_EQ(scans[0].stamp, 9.5);
  EXPECT_DOUBLE_EQ(scans[1].stamp, 10.0);
  EXPECT_DOUBLE_EQ(scans[2].pose.x(), 3.0);
  EXPECT_DOUBLE_EQ(scans[3].pose.x(), 4.0);
}

// A path that drives 1 m forward and turns 0.1 rad at every step.
std::vector<StampedPose> makeTruth(int steps) {
  std::vector<StampedPose> truth = {{0.0, core::Pose2(5.0, -2.0, 0.3)}};
  for (int i = 1; i <= steps; ++i) {
    truth.push_back({0.2 * i, core::compose(truth.back().pose, core::Pose2(1.0, 0.0, 0.1))});
  }
  return truth;
}

TEST(SimulateOdometry, NoiseFreeReproducesTheTruth) {
  OdometryNoiseOptions options;
  options.noise_per_unit = 0.0;
  options.scale_bias = 0.0;
  const std::vector<StampedPose> truth = makeTruth(50);
  const std::vector<StampedPose> odometry = simulateOdometry(truth, options);
  ASSERT_EQ(odometry.size(), truth.size());
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_DOUBLE_EQ(odometry[i].stamp, truth[i].stamp);
    EXPECT_NEAR((odometry[i].pose - truth[i].pose).norm(), 0.0, 1e-9) << i;
  }
}

TEST(SimulateOdometry, BiasScalesEveryIncrement) {
  OdometryNoiseOptions options;
  options.noise_per_unit = 0.0;
  options.scale_bias = 0.02;
  const std::vector<StampedPose> truth = makeTruth(30);
  const std::vector<StampedPose> odometry = simulateOdometry(truth, options);
  for (size_t i = 1; i < odometry.size(); ++i) {
    const core::Pose2 step = core::between(odometry[i - 1].pose, odometry[i].pose);
    EXPECT_NEAR(step.x(), 1.02, 1e-12);
    EXPECT_NEAR(step.y(), 0.0, 1e-12);
    EXPECT_NEAR(step.z(), 0.102, 1e-12);
  }
}

TEST(SimulateOdometry, NoiseIsProportionalAndSeeded) {
  OdometryNoiseOptions options;  // 3 % noise, 2 % bias, seed 1
  const std::vector<StampedPose> truth = makeTruth(20000);
  const std::vector<StampedPose> odometry = simulateOdometry(truth, options);
  double sum_x = 0.0, sum_x2 = 0.0, sum_y2 = 0.0, sum_theta2 = 0.0;
  const double n = static_cast<double>(odometry.size() - 1);
  for (size_t i = 1; i < odometry.size(); ++i) {
    const core::Pose2 step = core::between(odometry[i - 1].pose, odometry[i].pose);
    sum_x += step.x();
    sum_x2 += (step.x() - 1.02) * (step.x() - 1.02);
    sum_y2 += step.y() * step.y();
    sum_theta2 += (step.z() - 0.102) * (step.z() - 0.102);
  }
  EXPECT_NEAR(sum_x / n, 1.02, 0.002);
  EXPECT_NEAR(std::sqrt(sum_x2 / n), 0.03, 0.0015);  // 3 % of 1 m
  EXPECT_NEAR(std::sqrt(sum_y2 / n), 0.03, 0.0015);
  EXPECT_NEAR(std::sqrt(sum_theta2 / n), 0.003, 0.00015);  // 3 % of 0.1 rad

  const std::vector<StampedPose> again = simulateOdometry(truth, options);
  EXPECT_TRUE(again.back().pose.isApprox(odometry.back().pose));
  options.seed = 2;
  const std::vector<StampedPose> other = simulateOdometry(truth, options);
  EXPECT_GT((other.back().pose - odometry.back().pose).head<2>().norm(), 1e-3);
}

TEST(SimulateOdometry, StandingStillDoesNotDrift) {
  std::vector<StampedPose> truth(100, StampedPose{0.0, core::Pose2(1.0, 2.0, 3.0)});
  for (size_t i = 0; i < truth.size(); ++i) truth[i].stamp = static_cast<double>(i);
  const std::vector<StampedPose> odometry = simulateOdometry(truth, OdometryNoiseOptions());
  EXPECT_TRUE(odometry.back().pose.isApprox(truth.back().pose));
}

TEST(SimulateOdometry, ValidatesOptions) {
  OdometryNoiseOptions options;
  options.noise_per_unit = -0.1;
  EXPECT_THROW(validate(options), std::invalid_argument);
  options = OdometryNoiseOptions();
  options.scale_bias = -1.0;
  EXPECT_THROW(validate(options), std::invalid_argument);
  options.scale_bias = std::nan("");
  EXPECT_THROW(validate(options), std::invalid_argument);
  EXPECT_NO_THROW(validate(OdometryNoiseOptions()));
}

}  // namespace
}  // namespace io
}  // namespace rbpf_slam

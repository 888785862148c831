// Tests of TUM trajectory I/O and of trajectory evaluation (association, alignment, ATE, RPE).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/core/statistics.h"
#include "rbpf_slam/io/evaluation.h"
#include "rbpf_slam/io/json_writer.h"
#include "rbpf_slam/io/number_text.h"
#include "rbpf_slam/io/trajectory.h"

namespace rbpf_slam {
namespace io {
namespace {

// A curvy trajectory with 1 s between poses.
std::vector<StampedPose> makeTrajectory(int count) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < count; ++i) {
    const double t = static_cast<double>(i);
    poses.push_back({100.0 + t, core::Pose2(0.5 * t + std::sin(0.3 * t), 2.0 * std::cos(0.2 * t),
                                            core::wrapAngle(0.25 * t))});
  }
  return poses;
}

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + "/" + name;
}

TEST(AlignRigid2D, RecoversKnownTransform) {
  const core::Pose2 truth(3.0, -1.5, 0.7);
  std::vector<Eigen::Vector2d> source, target;
  for (const StampedPose& pose : makeTrajectory(20)) {
    source.push_back(pose.pose.head<2>());
    target.push_back(core::transformPoint(truth, pose.pose.head<2>()));
  }
  const core::Pose2 estimated = alignRigid2D(source, target);
  EXPECT_NEAR(estimated.x(), truth.x(), 1e-9);
  EXPECT_NEAR(estimated.y(), truth.y(), 1e-9);
  EXPECT_NEAR(estimated.z(), truth.z(), 1e-9);
}

TEST(AlignRigid2D, RejectsMismatchedSizes) {
  EXPECT_THROW(alignRigid2D({Eigen::Vector2d::Zero()}, {}), std::invalid_argument);
  EXPECT_THROW(alignRigid2D({}, {}), std::invalid_argument);
}

TEST(AlignedRmsDistance, IsZeroForAMovedCopyAndTheSpreadLeftAfterAlignment) {
  const std::vector<StampedPose> reference = makeTrajectory(30);
  const core::Pose2 offset(1.5, -3.0, 2.2);
  std::vector<core::Pose2> a, b;
  for (const StampedPose& pose : reference) {
    b.push_back(pose.pose);
    a.push_back(core::compose(offset, pose.pose));
  }
  EXPECT_NEAR(core::alignedRmsDistance(a, b), 0.0, 1e-9);
  // Two poses 1 m apart against 3 m apart: centred and aligned, each is 1 m off.
  const std::vector<core::Pose2> short_pair{{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}};
  const std::vector<core::Pose2> long_pair{{5.0, 5.0, 1.0}, {5.0, 8.0, 1.0}};
  EXPECT_NEAR(core::alignedRmsDistance(short_pair, long_pair), 1.0, 1e-9);
  EXPECT_NEAR(core::alignedRmsDistance(long_pair, short_pair), 1.0, 1e-9);
  EXPECT_THROW(core::alignedRmsDistance(short_pair, {}), std::invalid_argument);
  EXPECT_THROW(core::alignedRmsDistance({}, {}), std::invalid_argument);
}

// Each path's median distance to the others, by hand: two poses 1 m apart, a moved copy of them
// (0 m from the first) and two poses 3 m apart (1 m from both): medians 0.5, 0.5 and 1.
TEST(AlignedRmsDistance, MedianDistancesToOthersByHand) {
  const std::vector<core::Pose2> short_pair{{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}};
  const std::vector<core::Pose2> moved{{2.0, 1.0, 0.5}, {2.0, 2.0, 0.5}};
  const std::vector<core::Pose2> long_pair{{5.0, 5.0, 1.0}, {5.0, 8.0, 1.0}};
  const std::vector<double> d = core::medianDistancesToOthers({short_pair, moved, long_pair});
  ASSERT_EQ(d.size(), 3u);
  EXPECT_NEAR(d[0], 0.5, 1e-9);
  EXPECT_NEAR(d[1], 0.5, 1e-9);
  EXPECT_NEAR(d[2], 1.0, 1e-9);
  EXPECT_THROW(core::medianDistancesToOthers({short_pair}), std::invalid_argument);
  EXPECT_THROW(core::medianDistancesToOthers({short_pair, {}}), std::invalid_argument);
}

// Exactly max_poses poses of a longer path, at floor(i (n - 1) / (max - 1)): the first and the
// last among them; a path no longer than max_poses whole.
TEST(AlignedRmsDistance, EvenlySpacedPosesKeepTheEndsAndTheCount) {
  std::vector<core::Pose2> path;
  for (int i = 0; i < 10; ++i) path.emplace_back(i, 0.0, 0.0);
  const auto xs = [](const std::vector<core::Pose2>& p) {
    std::vector<double> x;
    for (const core::Pose2& q : p) x.push_back(q.x());
    return x;
  };
  EXPECT_EQ(xs(core::evenlySpacedPoses(path, 10)), xs(path));
  EXPECT_EQ(xs(core::evenlySpacedPoses(path, 50)), xs(path));
  EXPECT_EQ(xs(core::evenlySpacedPoses(path, 9)), (std::vector<double>{0, 1, 2, 3, 4, 5, 6, 7, 9}));
  EXPECT_EQ(xs(core::evenlySpacedPoses(path, 5)), (std::vector<double>{0, 2, 4, 6, 9}));
  EXPECT_EQ(xs(core::evenlySpacedPoses(path, 4)), (std::vector<double>{0, 3, 6, 9}));
  EXPECT_EQ(xs(core::evenlySpacedPoses(path, 3)), (std::vector<double>{0, 4, 9}));
  EXPECT_EQ(xs(core::evenlySpacedPoses(path, 2)), (std::vector<double>{0, 9}));
  EXPECT_EQ(xs(core::evenlySpacedPoses(path, 1)), (std::vector<double>{9}));
  EXPECT_TRUE(core::evenlySpacedPoses({}, 3).empty());
  EXPECT_THROW(core::evenlySpacedPoses(path, 0), std::invalid_argument);
}

TEST(Evaluate, AlignedTransformedCopyHasZeroError) {
  const std::vector<StampedPose> reference = makeTrajectory(30);
  const core::Pose2 offset(-4.0, 2.5, -2.0);  // a different map frame
  std::vector<StampedPose> estimate;
  for (const StampedPose& pose : reference) {
    estimate.push_back({pose.stamp, core::compose(offset, pose.pose)});
  }
  const EvaluationResult aligned = evaluateTrajectory(estimate, reference, EvaluationOptions());
  EXPECT_EQ(aligned.matched_poses, 30u);
  EXPECT_NEAR(aligned.ate_rmse_m, 0.0, 1e-9);
  EXPECT_NEAR(aligned.ate_max_m, 0.0, 1e-9);
  EXPECT_NEAR(aligned.rotation_rmse_deg, 0.0, 1e-7);
  EXPECT_NEAR(aligned.final_position_error_m, 0.0, 1e-9);
  EXPECT_NEAR(aligned.final_heading_error_deg, 0.0, 1e-7);
  EXPECT_NEAR(aligned.rpe_translation_rmse_m, 0.0, 1e-9);
  // The alignment is the inverse of the applied offset.
  const core::Pose2 expected = core::inverse(offset);
  EXPECT_NEAR(aligned.alignment.x(), expected.x(), 1e-9);
  EXPECT_NEAR(aligned.alignment.y(), expected.y(), 1e-9);
  EXPECT_NEAR(aligned.alignment.z(), expected.z(), 1e-9);

  EvaluationOptions no_align;
  no_align.align = false;
  const EvaluationResult unaligned = evaluateTrajectory(estimate, reference, no_align);
  EXPECT_GT(unaligned.ate_rmse_m, 1.0);
  EXPECT_NEAR(unaligned.rotation_mean_deg, 2.0 * 180.0 / M_PI, 1e-7);
  // Relative errors do not depend on the frame.
  EXPECT_NEAR(unaligned.rpe_translation_rmse_m, 0.0, 1e-9);
  EXPECT_NEAR(unaligned.rpe_rotation_rmse_deg, 0.0, 1e-7);
}

TEST(Evaluate, ConstantOffsetWithoutAlignment) {
  const std::vector<StampedPose> reference = makeTrajectory(10);
  std::vector<StampedPose> estimate = reference;
  for (size_t i = 0; i < estimate.size(); ++i) {
    // 0.1 m off, alternately along x and along -y; heading off by 1 degree on even poses.
    if (i % 2 == 0) {
      estimate[i].pose.x() += 0.1;
      estimate[i].pose.z() += M_PI / 180.0;
    } else {
      estimate[i].pose.y() -= 0.1;
    }
  }
  EvaluationOptions options;
  options.align = false;
  const EvaluationResult result = evaluateTrajectory(estimate, reference, options);
  EXPECT_FALSE(result.aligned);
  EXPECT_EQ(result.matched_poses, 10u);
  EXPECT_NEAR(result.ate_rmse_m, 0.1, 1e-12);
  EXPECT_NEAR(result.ate_mean_m, 0.1, 1e-12);
  EXPECT_NEAR(result.ate_median_m, 0.1, 1e-12);
  EXPECT_NEAR(result.ate_max_m, 0.1, 1e-12);
  EXPECT_NEAR(result.rotation_rmse_deg, std::sqrt(0.5), 1e-9);  // sqrt(5 * 1^2 / 10)
  EXPECT_NEAR(result.rotation_mean_deg, 0.5, 1e-9);
  EXPECT_NEAR(result.final_position_error_m, 0.1, 1e-12);
  EXPECT_NEAR(result.final_heading_error_deg, 0.0, 1e-9);
  EXPECT_EQ(result.rpe_pairs, 9u);
  EXPECT_GT(result.rpe_translation_mean_m, 0.0);
  EXPECT_NEAR(result.duration_s, 9.0, 1e-12);
}

TEST(Evaluate, AteStatisticsOfUnequalErrors) {
  const std::vector<StampedPose> reference = makeTrajectory(4);
  std::vector<StampedPose> estimate = reference;
  const double offsets[] = {0.0, 0.1, 0.2, 0.5};
  for (size_t i = 0; i < 4; ++i) estimate[i].pose.x() += offsets[i];
  EvaluationOptions options;
  options.align = false;
  const EvaluationResult result = evaluateTrajectory(estimate, reference, options);
  EXPECT_NEAR(result.ate_rmse_m, std::sqrt((0.01 + 0.04 + 0.25) / 4.0), 1e-12);
  EXPECT_NEAR(result.ate_mean_m, 0.2, 1e-12);
  EXPECT_NEAR(result.ate_median_m, 0.15, 1e-12);
  EXPECT_NEAR(result.ate_max_m, 0.5, 1e-12);
  EXPECT_NEAR(result.final_position_error_m, 0.5, 1e-12);
}

TEST(Associate, NearestWithinToleranceAndUnsortedInput) {
  const std::vector<StampedPose> reference = makeTrajectory(5);  // stamps 100..104
  std::vector<StampedPose> estimate = {
      {102.03, reference[2].pose},  // 0.03 s late: matches 102
      {100.99, reference[1].pose},  // 0.01 s early: matches 101
      {103.5, reference[3].pose},   // half-way: no match at 0.05 s
      {99.96, reference[0].pose},   // 0.04 s before the first: matches 100
      {104.2, reference[4].pose},   // 0.2 s after the last: no match
  };
  const std::vector<PosePair> pairs = associate(estimate, reference, EvaluationOptions());
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_DOUBLE_EQ(pairs[0].stamp, 99.96);
  EXPECT_NEAR(pairs[0].dt, 0.04, 1e-9);
  EXPECT_DOUBLE_EQ(pairs[1].stamp, 100.99);
  EXPECT_NEAR(pairs[1].dt, 0.01, 1e-9);
  EXPECT_TRUE(pairs[1].reference.isApprox(reference[1].pose));
  EXPECT_NEAR(pairs[2].dt, -0.03, 1e-9);
  EXPECT_TRUE(pairs[2].reference.isApprox(reference[2].pose));

  EvaluationOptions wide;
  wide.max_dt_s = 0.25;
  EXPECT_EQ(associate(estimate, reference, wide).size(), 4u);
}

TEST(Associate, DenseEstimateMatchesEachReferenceOnce) {
  const std::vector<StampedPose> reference = makeTrajectory(3);  // stamps 100, 101, 102
  std::vector<StampedPose> estimate;
  for (int k = -5; k <= 205; ++k) {  // every 10 ms from 99.95 to 102.05
    estimate.push_back({100.0 + 0.01 * k, core::Pose2::Zero()});
  }
  estimate.push_back({101.0, core::Pose2::Ones()});  // a second pose at 101: not used
  const std::vector<PosePair> pairs = associate(estimate, reference, EvaluationOptions());
  ASSERT_EQ(pairs.size(), 3u);
  for (size_t i = 0; i < pairs.size(); ++i) {
    EXPECT_NEAR(pairs[i].dt, 0.0, 1e-9) << i;
    EXPECT_TRUE(pairs[i].reference.isApprox(reference[i].pose)) << i;
    EXPECT_TRUE(pairs[i].estimate.isZero()) << i;
  }
}

// Two streams of the same period offset by exactly half of it: every estimate pose is equally
// near two reference poses. Looking up with one tie rule and back with the same one matched
// almost nothing (1 of 6 with an ATE of 0); each estimate pose must pair with one reference pose.
TEST(Associate, StreamsHalfAPeriodApartPairUp) {
  std::vector<StampedPose> estimate, reference;
  for (int k = 0; k < 6; ++k) {
    estimate.push_back({100.0 + 0.5 * k, core::Pose2(k, 0.0, 0.0)});
    reference.push_back({100.25 + 0.5 * k, core::Pose2(k + 0.5, 0.0, 0.0)});
  }
  EvaluationOptions options;
  options.max_dt_s = 0.3;
  const std::vector<PosePair> pairs = associate(estimate, reference, options);
  ASSERT_EQ(pairs.size(), 6u);
  for (size_t i = 0; i < pairs.size(); ++i) {
    EXPECT_NEAR(pairs[i].dt, 0.25, 1e-9) << i;  // each with the reference pose after it
    EXPECT_DOUBLE_EQ(pairs[i].reference.x(), pairs[i].estimate.x() + 0.5) << i;
  }
}

TEST(Associate, ShiftedClockMatchesOnlyWithLargerTolerance) {
  const std::vector<StampedPose> reference = makeTrajectory(10);
  std::vector<StampedPose> estimate = reference;
  for (StampedPose& pose : estimate) pose.stamp += 0.08;
  EXPECT_THROW(evaluateTrajectory(estimate, reference, EvaluationOptions()), std::runtime_error);
  EvaluationOptions options;
  options.max_dt_s = 0.1;
  const EvaluationResult result = evaluateTrajectory(estimate, reference, options);
  EXPECT_EQ(result.matched_poses, 10u);
  EXPECT_NEAR(result.ate_rmse_m, 0.0, 1e-9);
}

TEST(Associate, InterpolatesReference) {
  std::vector<StampedPose> reference = {{10.0, core::Pose2(0.0, 0.0, 3.0)},
                                        {12.0, core::Pose2(2.0, 4.0, -3.0)}};
  const std::vector<StampedPose> estimate = {
      {10.5, core::Pose2::Zero()}, {12.0, core::Pose2::Zero()}, {12.04, core::Pose2::Zero()}};
  EvaluationOptions options;
  options.interpolate_reference = true;
  std::vector<PosePair> pairs = associate(estimate, reference, options);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_NEAR(pairs[0].reference.x(), 0.5, 1e-12);
  EXPECT_NEAR(pairs[0].reference.y(), 1.0, 1e-12);
  // Heading goes the short way round through pi: 3 + 0.25 * (2 pi - 6).
  EXPECT_NEAR(pairs[0].reference.z(), core::wrapAngle(3.0 + 0.25 * (2.0 * M_PI - 6.0)), 1e-12);
  EXPECT_TRUE(pairs[1].reference.isApprox(reference[1].pose));
  EXPECT_TRUE(pairs[2].reference.isApprox(reference[1].pose));  // past the end, within max_dt

  options.max_interpolation_gap_s = 1.0;  // the 2 s gap is now too long: nearest only
  pairs = associate(estimate, reference, options);
  EXPECT_EQ(pairs.size(), 2u);
}

TEST(Associate, RejectsNegativeTolerance) {
  EvaluationOptions options;
  options.max_dt_s = -1.0;
  EXPECT_THROW(associate(makeTrajectory(2), makeTrajectory(2), options), std::invalid_argument);
  options = EvaluationOptions();
  options.max_interpolation_gap_s = 0.0;
  EXPECT_THROW(validate(options), std::invalid_argument);
  EXPECT_NO_THROW(validate(EvaluationOptions()));
}

TEST(Tum, RoundTripKeepsStampsAndPoses) {
  std::vector<StampedPose> poses = makeTrajectory(25);
  poses[3].pose.z() = M_PI - 1e-7;
  poses[4].pose.z() = -M_PI + 1e-7;
  poses[5].stamp = 1262304032.906800031;
  const std::string path = tempPath("rbpf_slam_roundtrip.tum");
  writeTum(path, poses);
  const std::vector<StampedPose> read = readTum(path);
  ASSERT_EQ(read.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(read[i].stamp, poses[i].stamp, 1e-6) << i;
    EXPECT_NEAR(read[i].pose.x(), poses[i].pose.x(), 1e-9) << i;
    EXPECT_NEAR(read[i].pose.y(), poses[i].pose.y(), 1e-9) << i;
    EXPECT_NEAR(core::wrapAngle(read[i].pose.z() - poses[i].pose.z()), 0.0, 1e-9) << i;
  }
  std::remove(path.c_str());
}

/// A huge coordinate (corrupt input) is written whole: the line used to be cut at 256 bytes
/// and the file could not be read back.
TEST(Tum, HugeCoordinatesAreWrittenWhole) {
  std::vector<StampedPose> poses = makeTrajectory(3);
  poses[1].pose.x() = 4e228;
  std::ostringstream out;
  writeTum(out, poses);
  std::istringstream in(out.str());
  const std::vector<StampedPose> read = readTum(in, "memory");
  ASSERT_EQ(read.size(), 3u);
  EXPECT_NEAR(read[1].pose.x() / 4e228, 1.0, 1e-12);
  EXPECT_NEAR(read[2].pose.y(), poses[2].pose.y(), 1e-9);
}

TEST(Tum, ReadsCommentsBlankLinesAndFullQuaternions) {
  // A 90 degree yaw, then an unnormalised identity quaternion.
  std::istringstream in(
      "# t x y z qx qy qz qw\n"
      "\n"
      "  1.5 1 2 0.3 0 0 0.7071067811865476 0.7071067811865476\n"
      "   \t\r\n"
      "2.5 3 4 0 0 0 0 2\r\n");
  const std::vector<StampedPose> poses = readTum(in, "memory");
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_DOUBLE_EQ(poses[0].stamp, 1.5);
  EXPECT_NEAR(poses[0].pose.z(), M_PI / 2.0, 1e-12);
  EXPECT_NEAR(poses[1].pose.x(), 3.0, 1e-12);
  EXPECT_NEAR(poses[1].pose.z(), 0.0, 1e-12);  // unnormalised identity quaternion
  EXPECT_NEAR(yawFromQuaternion(0.0, 0.0, std::sin(-1.0), std::cos(-1.0)), -2.0, 1e-12);
}

void expectReadError(const std::string& text, const std::string& expected_fragment) {
  const std::string path = tempPath("rbpf_slam_bad.tum");
  {
    std::ofstream out(path);
    out << text;
  }
  try {
    readTum(path);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(expected_fragment), std::string::npos)
        << "message '" << error.what() << "' lacks '" << expected_fragment << "'";
  }
  std::remove(path.c_str());
}

TEST(Tum, MalformedLinesNameFileAndLine) {
  const std::string good = "1 0 0 0 0 0 0 1\n";
  const std::string where = tempPath("rbpf_slam_bad.tum");
  expectReadError("# header\n" + good + "2 0 0 0 0 0 1\n", where + ":3:");
  expectReadError(good + good + good + "3 0 0 0 0 0 0 x1\n", where + ":4:");
  expectReadError(good + "3 0 0 0 0 0 0 1 9\n", where + ":2:");
  expectReadError(good + "3 nan 0 0 0 0 0 1\n", where + ":2: non-finite");
  expectReadError(good + "3 0 0 0 0 0 0 inf\n", where + ":2: non-finite");
  expectReadError("3 0 0 0 0 0 0 0\n", where + ":1:");  // zero quaternion
  expectReadError(good + "3 1e400 0 0 0 0 0 1\n", where + ":2: non-finite value: '1e400'");
}

// strtod reports ERANGE for an underflow too: a subnormal was refused as "not a number".
TEST(Tum, SubnormalValuesAreNumbers) {
  std::istringstream in("1 1e-320 -4.9e-324 0 0 0 0 1\n2 1e-400 0 0 0 0 0 1\n");
  const std::vector<StampedPose> poses = readTum(in, "memory");
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].pose.x(), 1e-320);
  EXPECT_EQ(poses[0].pose.y(), -4.9e-324);
  EXPECT_EQ(poses[1].pose.x(), 0.0);  // below the smallest subnormal: the nearest double
  double value = 0.0;
  EXPECT_EQ(parseNumberText("1e-320", &value), NumberText::kFinite);
  EXPECT_EQ(parseNumberText("-1e400", &value), NumberText::kNotFinite);
  EXPECT_EQ(parseNumberText("nan", &value), NumberText::kNotFinite);
  EXPECT_EQ(parseNumberText("1.5x", &value), NumberText::kNotNumber);
  EXPECT_EQ(parseNumberText("", &value), NumberText::kNotNumber);
}

TEST(Tum, MissingFileNamesThePath) {
  const std::string path = tempPath("rbpf_slam_does_not_exist.tum");
  try {
    readTum(path);
    FAIL() << "no error for a missing file";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos);
  }
}

TEST(Json, HoldsEveryFigure) {
  EvaluationResult result;
  result.matched_poses = 7;
  result.ate_rmse_m = 0.125;
  result.final_heading_error_deg = std::nan("");
  const std::string json = toJson(result);
  EXPECT_NE(json.find("\"matched_poses\": 7"), std::string::npos) << json;
  EXPECT_NE(json.find("\"ate_rmse_m\": 0.125"), std::string::npos) << json;
  EXPECT_NE(json.find("\"final_heading_error_deg\": null"), std::string::npos) << json;
  EXPECT_NE(json.find("\"rpe_rotation_rmse_deg\""), std::string::npos) << json;
  EXPECT_EQ(json.front(), '{');
  EXPECT_EQ(json[json.size() - 2], '}');
}

TEST(Median, OddEvenUnsortedAndEmpty) {
  EXPECT_EQ(core::median({3.0}), 3.0);
  EXPECT_EQ(core::median({5.0, 1.0, 4.0}), 4.0);
  EXPECT_EQ(core::median({4.0, 1.0, 9.0, 2.0}), 3.0);  // (2 + 4) / 2
  EXPECT_EQ(core::median({2.0, 2.0, 7.0, 1.0, 2.0, 8.0}), 2.0);
  EXPECT_TRUE(std::isnan(core::median({})));
}

TEST(Json, StringsAreEscaped) {
  EXPECT_EQ(jsonString("plain"), "\"plain\"");
  EXPECT_EQ(jsonString("a \"quoted\" C:\\path"), "\"a \\\"quoted\\\" C:\\\\path\"");
  EXPECT_EQ(jsonString("two\nlines\tand\x01"), "\"two\\nlines\\tand\\u0001\"");
  EXPECT_EQ(jsonString("\b\f\x1f"), "\"\\u0008\\u000c\\u001f\"");
  EXPECT_EQ(jsonString("1.5 \xc2\xb0 \x7f"), "\"1.5 \xc2\xb0 \x7f\"");  // UTF-8 and DEL pass
}

TEST(Json, NonFiniteNumbersAreNull) {
  EXPECT_EQ(jsonNumber(0.125), "0.125");
  EXPECT_EQ(jsonNumber(-3e-12), "-3e-12");
  EXPECT_EQ(jsonNumber(std::nan("")), "null");
  EXPECT_EQ(jsonNumber(INFINITY), "null");
  EXPECT_EQ(jsonNumber(-INFINITY), "null");
  EXPECT_EQ(jsonNumber(1.0 / 3.0), "0.333333333");
  EXPECT_EQ(jsonNumber(123456789012.0), "1.23456789e+11");
}

TEST(Json, ObjectOneFieldPerLine) {
  JsonObjectWriter json;
  json.string("smoothing", "kept member 3 \"best\"\n(of 8)")
      .integer("frames", 12)
      .boolean("smoothed", true)
      .number("hinf_theta", std::nan(""))
      .raw("alignment", "{\"x_m\": 1}")
      .unsignedInteger("seed", 18446744073709551615ull);
  EXPECT_EQ(json.str(),
            "{\n"
            "  \"smoothing\": \"kept member 3 \\\"best\\\"\\n(of 8)\",\n"
            "  \"frames\": 12,\n"
            "  \"smoothed\": true,\n"
            "  \"hinf_theta\": null,\n"
            "  \"alignment\": {\"x_m\": 1},\n"
            "  \"seed\": 18446744073709551615\n"
            "}\n");
  EXPECT_EQ(JsonObjectWriter().str(), "{}\n");
}

}  // namespace
}  // namespace io
}  // namespace rbpf_slam

// The feature intake every landmark filter shares (core/filters/observation.h): which features
// are usable, the noise a feature is given, and the prepared observations.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "rbpf_slam/core/filters/observation.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

LineFeature line(double rho, double theta) {
  LineFeature l;
  l.rho = rho;
  l.theta = theta;
  l.start = Eigen::Vector2d(rho, -1.0);
  l.end = Eigen::Vector2d(rho, 1.0);
  l.covariance = Eigen::Vector2d(0.01, 0.001).asDiagonal();
  return l;
}

PointFeature point(double range, double bearing, int id = -1) {
  PointFeature p;
  p.range = range;
  p.bearing = bearing;
  p.covariance = Eigen::Vector2d(0.04, 0.0004).asDiagonal();
  p.id = id;
  return p;
}

FeatureSet mixedFeatures() {
  FeatureSet f;
  f.lines = {line(2.0, 0.0), line(kNaN, 0.0), line(-1.5, 0.3)};
  f.lines[1].start.x() = 0.0;
  LineFeature no_extent = line(1.0, 0.0);
  no_extent.end.y() = std::numeric_limits<double>::infinity();
  f.lines.push_back(no_extent);
  f.points = {point(3.0, 4.0, 7), point(0.0, 0.1), point(2.0, kNaN), point(1.0, -0.2)};
  return f;
}

TEST(Observation, UnusableFeaturesAreLeftOutAndCounted) {
  EXPECT_TRUE(usableLine(line(2.0, 0.0)));
  EXPECT_FALSE(usableLine(line(kNaN, 0.0)));
  EXPECT_TRUE(usablePoint(point(1.0, 0.0)));
  EXPECT_FALSE(usablePoint(point(0.0, 0.0)));  // no range: not in front of the sensor
  EXPECT_FALSE(usablePoint(point(-1.0, 0.0)));
  EXPECT_FALSE(usablePoint(point(1.0, kNaN)));

  FilterOptions options;
  options.use_lines = true;
  options.use_points = true;
  int rejected = -1;
  const std::vector<Observation> all = prepareObservations(mixedFeatures(), options, &rejected);
  EXPECT_EQ(rejected, 4);  // a NaN line, a line without extent, a zero range, a NaN bearing
  ASSERT_EQ(all.size(), 4u);
  EXPECT_EQ(all[0].type, LandmarkType::kLine);
  EXPECT_EQ(all[1].type, LandmarkType::kLine);
  EXPECT_EQ(all[2].type, LandmarkType::kPoint);
  // Lines in normal form (rho >= 0), points' bearings wrapped, known ids kept.
  EXPECT_NEAR(all[1].z.x(), 1.5, 1e-12);
  EXPECT_NEAR(all[1].z.y(), 0.3 - M_PI, 1e-12);
  EXPECT_NEAR(all[2].z.y(), 4.0 - 2.0 * M_PI, 1e-12);
  EXPECT_EQ(all[2].known_id, 7);
  EXPECT_EQ(all[3].known_id, -1);
  EXPECT_EQ(all[0].end, Eigen::Vector2d(2.0, 1.0));

  // A type the filter does not map is neither used nor counted as rejected.
  options.use_lines = false;
  const std::vector<Observation> points = prepareObservations(mixedFeatures(), options, &rejected);
  EXPECT_EQ(rejected, 2);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0].type, LandmarkType::kPoint);
}

TEST(Observation, ForEachUsableFeatureVisitsInOrder) {
  std::vector<double> seen;
  int rejected = -1;
  forEachUsableFeature(
      mixedFeatures(), true, true, &rejected, [&](const LineFeature& l) { seen.push_back(l.rho); },
      [&](const PointFeature& p) { seen.push_back(100.0 + p.range); });
  EXPECT_EQ(rejected, 4);
  EXPECT_EQ(seen, (std::vector<double>{2.0, -1.5, 103.0, 101.0}));
}

TEST(Observation, NoiseIsTheFeatureCovarianceInflatedPlusTheFloors) {
  MeasurementOptions m;
  m.use_feature_covariance = true;
  m.covariance_inflation = 2.0;
  Eigen::Matrix2d given;
  given << 0.04, 0.001, 0.003, 0.01;  // not symmetric: its symmetric part is used
  const Eigen::Matrix2d noise = observationNoise(given, 0.1, 0.2, m);
  EXPECT_NEAR(noise(0, 0), 2.0 * 0.04 + 0.01, 1e-12);
  EXPECT_NEAR(noise(1, 1), 2.0 * 0.01 + 0.04, 1e-12);
  EXPECT_NEAR(noise(0, 1), 2.0 * 0.002, 1e-12);
  EXPECT_NEAR(noise(1, 0), 2.0 * 0.002, 1e-12);

  const Eigen::Matrix2d floors = Eigen::Vector2d(0.1 * 0.1, 0.2 * 0.2).asDiagonal();
  // A covariance that is not positive definite, or not finite, gives the floors alone.
  Eigen::Matrix2d singular;
  singular << 1.0, 1.0, 1.0, 1.0;
  EXPECT_EQ(observationNoise(singular, 0.1, 0.2, m), floors);
  given(0, 0) = kNaN;
  EXPECT_EQ(observationNoise(given, 0.1, 0.2, m), floors);
  // ... and so does use_feature_covariance: false.
  m.use_feature_covariance = false;
  EXPECT_EQ(observationNoise(Eigen::Matrix2d::Identity(), 0.1, 0.2, m), floors);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

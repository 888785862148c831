// Sonar feature extraction: option checks, bad readings, and accuracy against simulated echoes
// of worlds with known walls, corners and posts (the acceptance bounds: lines within
// 0.1 m / 3 deg, points within 0.15 m, false features under 10% of all features).

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "rbpf_slam/core/features/sonar_feature_extractor.h"
#include "rbpf_slam/core/sim/simulator.h"
#include "rbpf_slam/io/world_yaml.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kLineRhoTolerance = 0.1;
constexpr double kLineThetaTolerance = 3.0 * M_PI / 180.0;
constexpr double kPointTolerance = 0.15;

ConeReading reading(double range, const Pose2& mount, double max_range = 5.0) {
  ConeReading r;
  r.range = range;
  r.min_range = 0.1;
  r.max_range = max_range;
  r.field_of_view = 30.0 * M_PI / 180.0;
  r.sensor_pose = mount;
  return r;
}

TEST(SonarExtractorOptions, ValidateNamesTheField) {
  EXPECT_NO_THROW(validate(SonarExtractorOptions()));
  SonarExtractorOptions o;
  o.min_line_echoes = 2;
  try {
    validate(o);
    FAIL() << "accepted min_line_echoes = 2";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sonar_features.min_line_echoes = 2"), std::string::npos)
        << e.what();
  }
  o = SonarExtractorOptions();
  o.sigma_range_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(validate(o), std::invalid_argument);
  o = SonarExtractorOptions();
  o.max_range_m = 0.1;  // not above min_range_m
  EXPECT_THROW(SonarFeatureExtractor{o}, std::invalid_argument);
}

TEST(SonarFeatureExtractor, RejectsBadAndEmptyReadings) {
  SonarFeatureExtractor extractor{SonarExtractorOptions()};
  const Pose2 mount(0.2, 0.0, 0.0);
  std::vector<ConeReading> ring = {
      reading(std::numeric_limits<double>::quiet_NaN(), mount),
      reading(std::numeric_limits<double>::infinity(), mount),
      reading(5.0, mount),   // the sensor's maximum: no echo
      reading(0.05, mount),  // below the minimum range
      reading(2.0, Pose2(0.2, 0.0, std::numeric_limits<double>::quiet_NaN())),
      reading(2.0, mount),  // the only good one
  };
  ring[4].sensor_pose.z() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(extractor.addReadings(ring, Pose2::Zero(), 1.0), 1);
  EXPECT_EQ(extractor.stats().invalid, 3);
  EXPECT_EQ(extractor.stats().no_echo, 1);
  EXPECT_EQ(extractor.stats().too_close, 1);
  EXPECT_EQ(extractor.echoes().size(), 1u);
  EXPECT_EQ(extractor.addReadings({}, Pose2::Zero(), 1.1), 0);
  EXPECT_EQ(extractor.addReadings({reading(2.0, mount)}, Pose2(0, 0, NAN), 1.2), 0);
  const FeatureSet none = extractor.extract(Pose2::Zero(), 1.2);
  EXPECT_TRUE(none.lines.empty());
  EXPECT_TRUE(none.points.empty());
}

// With no maximum range configured or given, one echo at 3 km sized the vote grids by its
// range (17 GB; at 1e5 m std::bad_alloc): echoes beyond 100 m are broken values, not kept.
TEST(SonarFeatureExtractor, AnEchoBeyondAnySonarsReachIsNotKept) {
  SonarExtractorOptions options;
  options.max_range_m = 0.0;
  SonarFeatureExtractor extractor{options};
  const Pose2 mount(0.2, 0.0, 0.0);
  ConeReading far = reading(3000.0, mount);
  far.max_range = std::numeric_limits<double>::infinity();
  ConeReading near = reading(2.0, mount);
  near.max_range = std::numeric_limits<double>::infinity();
  EXPECT_EQ(extractor.addReadings({far, near}, Pose2::Zero(), 1.0), 1);
  EXPECT_EQ(extractor.stats().invalid, 1);
  ConeReading far_mount = reading(2.0, Pose2(5000.0, 0.0, 0.0));
  EXPECT_EQ(extractor.addReadings({far_mount}, Pose2::Zero(), 1.1), 0);
  EXPECT_EQ(extractor.stats().invalid, 2);
}

TEST(SonarFeatureExtractor, StandingStillGivesNoFeatureHowEverManyEchoes) {
  // Forty identical echoes from one pose: the reflector could be anywhere on the arc.
  SonarFeatureExtractor extractor{SonarExtractorOptions()};
  const Pose2 mount(0.2, 0.0, 0.0);
  for (int i = 0; i < 40; ++i) extractor.addReadings({reading(2.0, mount)}, Pose2::Zero(), 0.1 * i);
  const FeatureSet features = extractor.extract(Pose2::Zero(), 4.0);
  EXPECT_TRUE(features.lines.empty());
  EXPECT_TRUE(features.points.empty());
  EXPECT_EQ(extractor.echoes().size(), 40u);
}

TEST(SonarFeatureExtractor, WindowKeepsOnlyRecentTravel) {
  SonarExtractorOptions o;
  o.window_distance_m = 1.0;
  SonarFeatureExtractor extractor(o);
  const Pose2 mount(0.0, 0.2, M_PI_2);
  for (int i = 0; i <= 30; ++i)
    extractor.addReadings({reading(1.0, mount)}, Pose2(0.1 * i, 0, 0), i);
  // Travel 3 m; the window spans 1 m of it: 11 readings (0.1 m apart, both ends included).
  EXPECT_EQ(extractor.echoes().size(), 11u);
  EXPECT_TRUE(extractor.extractionDue(Pose2(3.0, 0, 0)));  // never extracted
  extractor.extract(Pose2(3.0, 0, 0), 30.0);
  EXPECT_FALSE(extractor.extractionDue(Pose2(3.1, 0, 0.1)));
  EXPECT_TRUE(extractor.extractionDue(Pose2(3.31, 0, 0)));
  EXPECT_TRUE(extractor.extractionDue(Pose2(3.0, 0, 0.35)));
}

TEST(SonarFeatureExtractor, AReadingALittleLateJoinsTheWindowWithoutAddingTravel) {
  // Two transducers stamped apart and published out of order: after each reading, one from
  // 10 ms earlier, placed by the odometry at its own stamp (0.1 m back). The distance the
  // window spans is the robot's, not the back and forth between the two.
  SonarExtractorOptions o;
  o.window_distance_m = 1.0;
  SonarFeatureExtractor extractor(o);
  const Pose2 left(0.0, 0.2, M_PI_2), right(0.0, -0.2, -M_PI_2);
  for (int i = 0; i <= 30; ++i) {
    extractor.addReadings({reading(1.0, left)}, Pose2(0.1 * i, 0, 0), i);
    if (i > 0) extractor.addReadings({reading(1.0, right)}, Pose2(0.1 * i - 0.1, 0, 0), i - 0.01);
  }
  // 1 m of travel: 11 readings of each transducer (the late one of step 20 was taken at 1.9 m).
  EXPECT_EQ(extractor.echoes().size(), 22u);
  EXPECT_EQ(extractor.stats().clock_jumps, 0);
  // "A little" is measured from the newest echo: a chain of readings each 0.4 s older than the
  // one before does not walk the window back.
  EXPECT_FALSE(extractor.wouldClearWindow(29.6));
  EXPECT_EQ(extractor.addReadings({reading(1.0, left)}, Pose2(2.5, 0, 0), 29.6), 1);
  EXPECT_FALSE(extractor.wouldClearWindow(29.2));
  EXPECT_EQ(extractor.addReadings({reading(1.0, left)}, Pose2(2.0, 0, 0), 29.2), 1);
  EXPECT_TRUE(extractor.wouldClearWindow(28.8));
}

TEST(SonarFeatureExtractor, StampsGoingBackClearTheWindowButKeepTheCounters) {
  // A second log or a restarted driver: the held echoes were placed with another run's
  // odometry and must go; the counters of the extractor's life stay.
  SonarExtractorOptions o;
  o.window_distance_m = 10.0;
  SonarFeatureExtractor extractor(o);
  const Pose2 mount(0.0, 0.2, M_PI_2);
  for (int i = 0; i < 10; ++i) {
    extractor.addReadings({reading(1.0, mount)}, Pose2(0.1 * i, 0, 0), 100.0 + i);
  }
  ASSERT_EQ(extractor.echoes().size(), 10u);
  extractor.addReadings({reading(1.0, mount)}, Pose2(5.0, 3.0, 0), 100.5);  // 8.5 s back
  EXPECT_EQ(extractor.echoes().size(), 1u);
  EXPECT_EQ(extractor.stats().clock_jumps, 1);
  EXPECT_EQ(extractor.stats().readings, 11);
  extractor.addReadings({reading(1.0, mount)}, Pose2(5.0, 3.1, 0), 100.2);  // within a second
  EXPECT_EQ(extractor.echoes().size(), 2u);
  EXPECT_EQ(extractor.stats().clock_jumps, 1);
}

TEST(SonarFeatureExtractor, MountsThatKeepMovingStayBounded) {
  // A panning sonar (or a jittery tf): every reading from a new mounting pose. The transducer
  // list stops growing; every echo still names a transducer within it.
  SonarFeatureExtractor extractor{SonarExtractorOptions()};
  for (int i = 0; i < 1000; ++i) {
    const Pose2 mount(0.0, 0.2, -M_PI + 0.006 * i);
    extractor.addReadings({reading(2.0, mount)}, Pose2(0.01 * i, 0, 0), 1.0 + 0.1 * i);
  }
  ASSERT_FALSE(extractor.echoes().empty());
  for (const SonarEcho& e : extractor.echoes()) EXPECT_LT(e.transducer, 128);
  extractor.extract(Pose2(10.0, 0, 0), 101.0);  // the cross-talk check over them runs
}

TEST(SonarFeatureExtractor, SpacingSkipsRepeatedEchoesOfAStandingTransducer) {
  SonarExtractorOptions o;
  o.min_echo_spacing_m = 0.05;
  SonarFeatureExtractor extractor(o);
  const Pose2 mount(0.0, 0.2, M_PI_2);
  for (int i = 0; i < 10; ++i) extractor.addReadings({reading(1.0, mount)}, Pose2::Zero(), i);
  EXPECT_EQ(extractor.echoes().size(), 1u);
  EXPECT_EQ(extractor.stats().decimated, 9);
  extractor.addReadings({reading(1.0, mount)}, Pose2(0.06, 0, 0), 10);    // moved: kept
  extractor.addReadings({reading(1.2, mount)}, Pose2(0.07, 0, 0), 11);    // new range: kept
  extractor.addReadings({reading(1.2, mount)}, Pose2(0.07, 0, 0.1), 12);  // turned: kept
  EXPECT_EQ(extractor.echoes().size(), 4u);
}

/// A wall at y = 1.5 parallel to a 1.5 m drive along x; a side sonar at 90 deg, noise-free.
FeatureSet wallBesideAStraightDrive(const SonarExtractorOptions& options) {
  SonarFeatureExtractor extractor{options};
  const Pose2 mount(0.0, 0.2, M_PI_2);
  Pose2 pose(0, 0, 0);
  for (int i = 0; i < 16; ++i) {
    pose = Pose2(0.1 * i, 0.0, 0.0);
    extractor.addReadings({reading(1.3, mount)}, pose, 0.25 * i);
  }
  return extractor.extract(pose, 4.0);
}

TEST(SonarFeatureExtractor, WallBesideAStraightDriveIsOneLine) {
  const FeatureSet f = wallBesideAStraightDrive(SonarExtractorOptions());
  ASSERT_EQ(f.lines.size(), 1u);
  EXPECT_NEAR(f.lines[0].rho, 1.5, 1e-3);
  EXPECT_NEAR(f.lines[0].theta, M_PI_2, 1e-3);
  EXPECT_TRUE(f.points.empty());
  // The extent covers the reflection points, behind the robot (x from -1.5 to 0).
  EXPECT_NEAR(std::min(f.lines[0].start.x(), f.lines[0].end.x()), -1.5, 1e-6);
  EXPECT_NEAR(std::max(f.lines[0].start.x(), f.lines[0].end.x()), 0.0, 1e-6);
  // Covariance floored at the seed's 0.2 m / 5 deg.
  EXPECT_NEAR(f.lines[0].covariance(0, 0), 0.04, 1e-9);
  EXPECT_NEAR(f.lines[0].covariance(1, 1), std::pow(0.0873, 2), 1e-9);
}

// line_theta_per_length_m: the direction of a 1.5 m line is trusted to no better than k / 1.5 m.
TEST(SonarFeatureExtractor, LineDirectionFloorShrinksWithTheLinesLength) {
  SonarExtractorOptions options;
  options.line_sigma_theta_rad = 0.01;
  options.line_theta_per_length_m = 0.3;
  const FeatureSet f = wallBesideAStraightDrive(options);
  ASSERT_EQ(f.lines.size(), 1u);
  EXPECT_NEAR(f.lines[0].covariance(1, 1), std::pow(0.3 / 1.5, 2), 1e-9);
  options.line_theta_per_length_m = -0.1;
  EXPECT_THROW(validate(options), std::invalid_argument);
}

TEST(SonarFeatureExtractor, PostPassedByIsTriangulated) {
  // A pole at (1.0, 1.2), heard by a Pioneer-like front-left quarter ring (10, 30, 50, 90 deg)
  // while driving past along x; noise-free echoes, nothing else in the world.
  SonarFeatureExtractor extractor{SonarExtractorOptions()};
  std::vector<Pose2> ring;
  for (double degrees : {10.0, 30.0, 50.0, 90.0}) {
    const double a = degrees * M_PI / 180.0;
    ring.emplace_back(0.2 * std::cos(a), 0.2 * std::sin(a), a);
  }
  const Eigen::Vector2d pole(1.0, 1.2);
  Pose2 pose;
  int heard = 0;
  for (int i = 0; i < 30; ++i) {
    pose = Pose2(-1.0 + 0.075 * i, 0.0, 0.0);
    std::vector<ConeReading> readings;
    for (const Pose2& mount : ring) {
      const Eigen::Vector2d d = pole - (pose.head<2>() + mount.head<2>());
      const bool inside = std::abs(wrapAngle(std::atan2(d.y(), d.x()) - mount.z())) < M_PI / 12;
      readings.push_back(reading(inside ? d.norm() : 5.0, mount));
      heard += inside ? 1 : 0;
    }
    extractor.addReadings(readings, pose, 0.25 * i);
  }
  ASSERT_GE(heard, 12);
  const FeatureSet f = extractor.extract(pose, 8.0);
  ASSERT_EQ(f.points.size(), 1u);
  const Eigen::Vector2d p =
      pose.head<2>() + f.points[0].range * Eigen::Vector2d(std::cos(f.points[0].bearing),
                                                           std::sin(f.points[0].bearing));
  EXPECT_NEAR(p.x(), pole.x(), 0.01);
  EXPECT_NEAR(p.y(), pole.y(), 0.01);
  EXPECT_TRUE(f.lines.empty());
  EXPECT_NEAR(f.points[0].covariance(0, 0), 0.15 * 0.15, 1e-9);  // the seed's floor
}

TEST(SonarFeatureExtractor, CloudPointsGoToTheTransducerWhoseAxisTheyLieOn) {
  const std::vector<Pose2> ring = {Pose2(0.1, 0.1, M_PI_2), Pose2(0.15, 0.0, 0.0)};
  int unmatched = -1;
  const std::vector<ConeReading> r =
      coneReadingsFromCloud({Eigen::Vector2d(1.15, 0.0), Eigen::Vector2d(0.1, 2.1),
                             Eigen::Vector2d(-3, -3), Eigen::Vector2d(NAN, 0)},
                            ring, 0.5, 0.1, 5.0, 7.0, 0.05, &unmatched);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(unmatched, 2);
  EXPECT_NEAR(r[0].range, 1.0, 1e-9);
  EXPECT_EQ(r[0].sensor_pose, ring[1]);
  EXPECT_NEAR(r[1].range, 2.0, 1e-9);
  EXPECT_EQ(r[1].sensor_pose, ring[0]);
  EXPECT_DOUBLE_EQ(r[1].stamp, 7.0);
}

// ------------------------------------------------------------------------------------------
// Simulated worlds.

struct Truth {
  std::vector<sim::Segment> segments;
  std::vector<Eigen::Vector2d> corners;  // vertices
  std::vector<sim::Circle> posts;        // a sonar hears a post's near surface
};

Truth truthOf(const sim::Simulator& simulator) {
  Truth truth;
  for (size_t i = 0; i < simulator.objects().size(); ++i) {
    for (const sim::Segment& s : sim::objectSegments(simulator.objects()[i], i)) {
      truth.segments.push_back(s);
      truth.corners.push_back(s.a);
      truth.corners.push_back(s.b);
    }
  }
  for (const sim::Landmark& l : simulator.landmarks()) {
    if (l.radius_m > 0.0) truth.posts.push_back({l.position, l.radius_m});
  }
  return truth;
}

/// Index of a true segment the line lies on, compared in the base frame at true_pose (range
/// and bearing of the wall as the robot sees it), or -1.
int matchLine(const Truth& truth, const Pose2& true_pose, const LineFeature& line) {
  const Pose2 to_base = inverse(true_pose);
  const Eigen::Vector2d mid = 0.5 * (line.start + line.end);
  for (size_t i = 0; i < truth.segments.size(); ++i) {
    const Eigen::Vector2d a = transformPoint(to_base, truth.segments[i].a);
    const Eigen::Vector2d b = transformPoint(to_base, truth.segments[i].b);
    const Eigen::Vector2d dir = (b - a).normalized();
    double true_rho = a.dot(Eigen::Vector2d(-dir.y(), dir.x()));
    double true_theta = std::atan2(dir.x(), -dir.y());
    normalizeLine(true_rho, true_theta);
    if (std::abs(line.rho - true_rho) > kLineRhoTolerance ||
        std::abs(wrapAngle(line.theta - true_theta)) > kLineThetaTolerance) {
      continue;
    }
    if (sim::distanceToSegment(mid, a, b) > 0.5) continue;  // another wall on that line
    return static_cast<int>(i);
  }
  return -1;
}

bool matchPoint(const Truth& truth, const Pose2& true_pose, const PointFeature& point) {
  const Eigen::Vector2d p = transformPoint(
      true_pose, point.range * Eigen::Vector2d(std::cos(point.bearing), std::sin(point.bearing)));
  for (const Eigen::Vector2d& c : truth.corners) {
    if ((p - c).norm() <= kPointTolerance) return true;
  }
  for (const sim::Circle& post : truth.posts) {
    if (std::abs((p - post.center).norm() - post.radius_m) <= kPointTolerance) return true;
  }
  return false;
}

struct Score {
  int lines = 0, false_lines = 0, points = 0, false_points = 0, extractions = 0;
  std::set<int> walls_seen;
  int total() const { return lines + points; }
  int falses() const { return false_lines + false_points; }
};

/// Drives the world (changes removed) and extracts on odometry, scoring against the truth.
Score runWorld(const std::string& world_file, std::uint64_t seed) {
  sim::World world = io::loadWorld(std::string(RBPF_SOURCE_DIR) + "/worlds/" + world_file);
  world.changes.clear();
  sim::SimulatorOptions sim_options;
  sim_options.seed = seed;
  sim::Simulator simulator(world, sim_options);
  const Truth truth = truthOf(simulator);
  SonarFeatureExtractor extractor{SonarExtractorOptions()};
  Score score;
  sim::SimEvent event;
  while (simulator.next(&event)) {
    if (event.type != sim::SimEventType::kSonar) continue;
    std::vector<ConeReading> ring;
    for (const auto& t : event.cones) ring.push_back(t.reading);
    extractor.addReadings(ring, event.odom_pose, event.stamp);
    if (!extractor.extractionDue(event.odom_pose)) continue;
    const FeatureSet f = extractor.extract(event.odom_pose, event.stamp);
    ++score.extractions;
    for (const LineFeature& line : f.lines) {
      ++score.lines;
      const int wall = matchLine(truth, event.true_pose, line);
      if (wall < 0)
        ++score.false_lines;
      else
        score.walls_seen.insert(wall);
    }
    for (const PointFeature& point : f.points) {
      ++score.points;
      if (!matchPoint(truth, event.true_pose, point)) ++score.false_points;
    }
  }
  return score;
}

void expectAccurate(const Score& s, int min_lines, int min_points, int min_walls) {
  SCOPED_TRACE(::testing::Message()
               << s.lines << " lines (" << s.false_lines << " false), " << s.points << " points ("
               << s.false_points << " false), " << s.walls_seen.size() << " walls seen, "
               << s.extractions << " extractions");
  EXPECT_GE(s.lines, min_lines);
  EXPECT_GE(s.points, min_points);
  EXPECT_GE(static_cast<int>(s.walls_seen.size()), min_walls);
  EXPECT_LT(s.falses(), 0.1 * s.total());
}

TEST(SonarFeatureExtractorSimulated, LeeSonarRoom) {
  for (std::uint64_t seed : {1u, 2u}) {
    SCOPED_TRACE(seed);
    expectAccurate(runWorld("lee_sonar_room.yaml", seed), 200, 100, 10);
  }
}

TEST(SonarFeatureExtractorSimulated, TestSmallFrontRing) {
  for (std::uint64_t seed : {1u, 2u}) {
    SCOPED_TRACE(seed);
    expectAccurate(runWorld("test_small.yaml", seed), 100, 5, 5);
  }
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

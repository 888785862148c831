// Tests of the ROS-free simulator: geometry, sensor models, driving, odometry, changes,
// validation and determinism.

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/sim/ray_caster.h"
#include "rbpf_slam/core/sim/sensor_models.h"
#include "rbpf_slam/core/sim/simulator.h"

namespace rbpf_slam {
namespace core {
namespace sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

/// A 10 m x 8 m room with a box and two posts, a square route and every sensor on.
World roomWorld() {
  World world;
  world.name = "room";
  world.laps = 2;
  world.robot.speed_mps = 1.0;
  world.robot.control_rate_hz = 20.0;
  world.odometry.translation_noise_m_per_m = 0.03;
  world.odometry.rotation_noise_rad_per_rad = 0.03;
  WorldObject walls;
  walls.name = "walls";
  walls.points = {{0, 0}, {10, 0}, {10, 8}, {0, 8}, {0, 0}};
  WorldObject box;
  box.name = "box";
  box.shape = ShapeType::kPolygon;
  box.points = {{4, 3}, {6, 3}, {6, 5}, {4, 5}};
  box.closed = true;
  world.objects = {walls, box};
  world.landmarks = {{0, {3.0, 2.5}, 0.1}, {1, {7.0, 6.0}, 0.1}};
  world.waypoints = {{1.5, 1.5}, {8.5, 1.5}, {8.5, 6.5}, {1.5, 6.5}};
  world.sensors.laser.enabled = true;
  world.sensors.sonar.enabled = true;
  world.sensors.range_bearing.enabled = true;
  world.sensors.range_bearing.known_ids = true;
  world.sensors.infrared.enabled = true;
  return world;
}

/// A straight wall along x = 5 from y = -50 to 50, nothing else.
RayCaster wallAtXFive() { return RayCaster({{{5.0, -50.0}, {5.0, 50.0}, 0}}, {}); }

void expectSameEvents(const std::vector<SimEvent>& a, const std::vector<SimEvent>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].type, b[i].type) << i;
    ASSERT_EQ(a[i].stamp, b[i].stamp) << i;
    ASSERT_EQ(a[i].true_pose, b[i].true_pose) << i;
    ASSERT_EQ(a[i].odom_pose, b[i].odom_pose) << i;
    ASSERT_EQ(static_cast<bool>(a[i].scan), static_cast<bool>(b[i].scan)) << i;
    if (a[i].scan) ASSERT_EQ(a[i].scan->ranges, b[i].scan->ranges) << i;
    ASSERT_EQ(a[i].cones.size(), b[i].cones.size()) << i;
    for (size_t k = 0; k < a[i].cones.size(); ++k) {
      ASSERT_EQ(a[i].cones[k].reading.range, b[i].cones[k].reading.range) << i;
    }
    ASSERT_EQ(a[i].features.points.size(), b[i].features.points.size()) << i;
    for (size_t k = 0; k < a[i].features.points.size(); ++k) {
      ASSERT_EQ(a[i].features.points[k].range, b[i].features.points[k].range) << i;
      ASSERT_EQ(a[i].features.points[k].bearing, b[i].features.points[k].bearing) << i;
    }
  }
}

TEST(Simulator, SameSeedGivesIdenticalStreams) {
  SimulatorOptions options;
  options.seed = 7;
  const auto first = Simulator(roomWorld(), options).run();
  const auto second = Simulator(roomWorld(), options).run();
  ASSERT_GT(first.size(), 100u);
  expectSameEvents(first, second);

  options.seed = 8;
  const auto other = Simulator(roomWorld(), options).run();
  ASSERT_FALSE(other.empty());
  EXPECT_NE(first.back().odom_pose, other.back().odom_pose);
}

TEST(Simulator, EventsAreTimeOrderedAndSensorsKeepTheirRates) {
  World world = roomWorld();
  world.sensors.laser.rate_hz = 5.0;
  world.sensors.sonar.rate_hz = 4.0;
  Simulator simulator(world, SimulatorOptions());
  const auto events = simulator.run();
  ASSERT_TRUE(simulator.routeCompleted());
  int lasers = 0, sonars = 0;
  for (size_t i = 1; i < events.size(); ++i) ASSERT_GE(events[i].stamp, events[i - 1].stamp);
  for (const SimEvent& e : events) {
    lasers += e.type == SimEventType::kLaser;
    sonars += e.type == SimEventType::kSonar;
  }
  const double duration = events.back().stamp;
  EXPECT_NEAR(lasers, duration * 5.0, 2.0);
  EXPECT_NEAR(sonars, duration * 4.0, 2.0);
}

TEST(RayCaster, HitsAKnownWallAtTheKnownRange) {
  const RayCaster caster = wallAtXFive();
  const RayHit straight = caster.cast({0, 0}, 0.0, 10.0);
  EXPECT_NEAR(straight.range_m, 5.0, 1e-12);
  EXPECT_NEAR(straight.incidence_rad, 0.0, 1e-9);
  const RayHit oblique = caster.cast({0, 0}, 30 * kDeg, 10.0);
  EXPECT_NEAR(oblique.range_m, 5.0 / std::cos(30 * kDeg), 1e-12);
  EXPECT_NEAR(oblique.incidence_rad, 30 * kDeg, 1e-9);
  EXPECT_FALSE(caster.cast({0, 0}, M_PI, 10.0).hit());  // facing away
  EXPECT_FALSE(caster.cast({0, 0}, 0.0, 4.9).hit());    // out of reach
}

TEST(RayCaster, HitsAPostOnItsNearSide) {
  const RayCaster caster({}, {{{3.0, 0.0}, 0.5}});
  EXPECT_NEAR(caster.cast({0, 0}, 0.0, 10.0).range_m, 2.5, 1e-12);
  EXPECT_FALSE(caster.cast({0, 0}, 20 * kDeg, 10.0).hit());
}

TEST(SensorModels, NoiseFreeLaserScanMeasuresTheWall) {
  LaserConfig laser;
  laser.max_range_m = 8.0;
  laser.mount_x_m = 0.5;  // the sensor is 0.5 m ahead of the base
  const RangeScan scan = simulateLaserScan(laser, wallAtXFive(), Pose2(1.0, 0.0, 0.0), nullptr);
  ASSERT_EQ(scan.ranges.size(), 181u);
  EXPECT_NEAR(scan.ranges[90], 3.5, 1e-6);                         // straight ahead
  EXPECT_NEAR(scan.ranges[120], 3.5 / std::cos(30 * kDeg), 1e-5);  // 30 deg left
  EXPECT_TRUE(std::isinf(scan.ranges[0]));                         // parallel to the wall
}

TEST(SensorModels, SonarLosesTheEchoBeyondTheCriticalAngle) {
  RingSensorConfig sonar;
  sonar.cone_deg = 30.0;
  sonar.corner_echoes = false;
  // Facing the wall 45 deg off its normal: the cone's rays meet it at 30 to 60 deg incidence.
  const Pose2 pose(3.0, 0.0, 45 * kDeg);
  sonar.critical_angle_deg = 20.0;
  EXPECT_EQ(simulateConeRange(sonar, wallAtXFive(), pose, nullptr), sonar.max_range_m);
  sonar.critical_angle_deg = 40.0;
  // The nearest ray that still echoes is the one closest to the normal (30 deg incidence).
  EXPECT_NEAR(simulateConeRange(sonar, wallAtXFive(), pose, nullptr), 2.0 / std::cos(30 * kDeg),
              1e-9);
  // Head-on, a 20 deg critical angle is enough.
  sonar.critical_angle_deg = 20.0;
  EXPECT_NEAR(simulateConeRange(sonar, wallAtXFive(), Pose2(3.0, 0.0, 0.0), nullptr), 2.0, 1e-9);
}

TEST(SensorModels, SonarHearsCornersAtAnyIncidence) {
  RingSensorConfig sonar;
  sonar.critical_angle_deg = 10.0;
  const RayCaster corner({{{5.0, 0.0}, {5.0, 10.0}, 0}, {{5.0, 0.0}, {15.0, 0.0}, 0}}, {});
  const Pose2 pose(2.0, 3.0, -45 * kDeg);  // looking into the corner at (5, 0)
  EXPECT_NEAR(simulateConeRange(sonar, corner, pose, nullptr), 3.0 * std::sqrt(2.0), 1e-9);
  sonar.corner_echoes = false;
  EXPECT_EQ(simulateConeRange(sonar, corner, pose, nullptr), sonar.max_range_m);
}

TEST(SensorModels, InfraredSeesOnlyANearbyWall) {
  const RingSensorConfig infrared = defaultInfraredConfig();
  EXPECT_NEAR(simulateConeRange(infrared, wallAtXFive(), Pose2(4.96, 0.0, 0.0), nullptr), 0.04,
              1e-9);
  EXPECT_EQ(simulateConeRange(infrared, wallAtXFive(), Pose2(4.9, 0.0, 0.0), nullptr),
            infrared.max_range_m);  // 10 cm away: out of reach
  EXPECT_EQ(simulateConeRange(infrared, wallAtXFive(), Pose2(4.96, 0.0, M_PI), nullptr),
            infrared.max_range_m);  // facing away
}

TEST(SensorModels, LandmarkSensorRespectsFieldOfViewRangeAndOcclusion) {
  RangeBearingConfig sensor;
  sensor.max_range_m = 20.0;
  sensor.fov_deg = 180.0;
  sensor.known_ids = true;
  const std::vector<Landmark> landmarks = {
      {0, {5.0, 0.0}, 0.0},                                  // ahead: seen
      {1, {-5.0, 0.0}, 0.0},                                 // behind: not seen
      {2, {std::cos(89 * kDeg), std::sin(89 * kDeg)}, 0.0},  // 89 deg left: seen
      {3, {std::cos(91 * kDeg), std::sin(91 * kDeg)}, 0.0},  // 91 deg left: not seen
      {4, {25.0, 0.0}, 0.0},                                 // too far
      {5, {19.0, -1.0}, 0.0}};                               // in range
  const FeatureSet seen = observeLandmarks(sensor, landmarks, RayCaster(), Pose2::Zero(), nullptr);
  ASSERT_EQ(seen.points.size(), 3u);
  EXPECT_EQ(seen.points[0].id, 0);
  EXPECT_NEAR(seen.points[0].range, 5.0, 1e-12);
  EXPECT_NEAR(seen.points[0].bearing, 0.0, 1e-12);
  EXPECT_EQ(seen.points[1].id, 2);
  EXPECT_NEAR(seen.points[1].bearing, 89 * kDeg, 1e-12);
  EXPECT_EQ(seen.points[2].id, 5);

  // The wall at x = 5 hides everything beyond it, unless occlusion is off.
  const Landmark behind_wall{6, {8.0, 0.0}, 0.0};
  EXPECT_TRUE(observeLandmarks(sensor, {behind_wall}, wallAtXFive(), Pose2::Zero(), nullptr)
                  .points.empty());
  sensor.occlusion = false;
  EXPECT_EQ(
      observeLandmarks(sensor, {behind_wall}, wallAtXFive(), Pose2::Zero(), nullptr).points.size(),
      1u);
  sensor.known_ids = false;
  EXPECT_EQ(
      observeLandmarks(sensor, {landmarks[0]}, RayCaster(), Pose2::Zero(), nullptr).points[0].id,
      -1);
}

TEST(Simulator, NoiseFreeOdometryEqualsGroundTruth) {
  World world = roomWorld();
  world.odometry = OdometryConfig();
  int checked = 0;
  for (const SimEvent& e : Simulator(world, SimulatorOptions()).run()) {
    if (e.type != SimEventType::kOdometry) continue;
    ASSERT_NEAR((e.odom_pose - e.true_pose).head<2>().norm(), 0.0, 1e-9) << e.stamp;
    ASSERT_NEAR(wrapAngle(e.odom_pose.z() - e.true_pose.z()), 0.0, 1e-9) << e.stamp;
    ++checked;
  }
  EXPECT_GT(checked, 100);

  // With noise and bias the odometry drifts away.
  world.odometry.translation_noise_m_per_m = 0.03;
  world.odometry.translation_scale_bias = 0.05;
  const SimEvent last = Simulator(world, SimulatorOptions()).run().back();
  EXPECT_GT((last.odom_pose - last.true_pose).head<2>().norm(), 0.05);
}

TEST(Simulator, DrivesTheRouteForTheGivenLapsAndReturnsToTheStart) {
  World world = roomWorld();
  Simulator simulator(world, SimulatorOptions());
  const auto events = simulator.run();
  EXPECT_TRUE(simulator.routeCompleted());
  EXPECT_EQ(simulator.lapsCompleted(), 2);
  const double lap_length_m = 2 * 7.0 + 2 * 5.0;
  EXPECT_GT(events.back().stamp, 2 * lap_length_m / world.robot.speed_mps * 0.9);
  EXPECT_LT(events.back().stamp, 2 * lap_length_m / world.robot.speed_mps * 1.3);
  EXPECT_LT((events.back().true_pose.head<2>() - world.waypoints[0]).norm(),
            world.robot.waypoint_tolerance_m + 1e-9);

  SimulatorOptions short_run;
  short_run.max_duration_s = 10.0;
  Simulator stopped(world, short_run);
  EXPECT_NEAR(stopped.run().back().stamp, 10.0, 1e-9);
  EXPECT_FALSE(stopped.routeCompleted());
}

TEST(Simulator, CarLikeRobotNeverExceedsItsSteeringLimit) {
  World world = roomWorld();
  world.robot.drive = DriveType::kBicycle;
  world.robot.wheelbase_m = 0.5;
  world.robot.max_steering_deg = 30.0;
  world.robot.lookahead_m = 1.0;
  world.robot.waypoint_tolerance_m = 0.5;
  Simulator simulator(world, SimulatorOptions());
  for (const SimEvent& e : simulator.run()) {
    const double limit = e.true_speed_mps * std::tan(30 * kDeg) / world.robot.wheelbase_m;
    ASSERT_LE(std::abs(e.true_turn_rate_radps), limit + 1e-9) << e.stamp;
  }
  EXPECT_TRUE(simulator.routeCompleted());
}

TEST(Simulator, ChangesApplyAfterTheFirstLap) {
  World world = roomWorld();
  world.odometry = OdometryConfig();
  world.sensors.range_bearing.range_noise_m = 0.0;
  world.sensors.range_bearing.bearing_noise_deg = 0.0;
  WorldChange change;
  change.after_lap = 1;
  change.landmarks = {{1, {7.5, 5.5}, false}};
  change.objects.push_back({"box", {}, {0.5, 0.0}, 0.0, false});
  world.changes = {change};

  Simulator simulator(world, SimulatorOptions());
  double change_stamp = -1.0;
  int seen_before = 0, seen_after = 0;
  for (const SimEvent& e : simulator.run()) {
    if (e.type == SimEventType::kWorldChange) {
      change_stamp = e.stamp;
      EXPECT_EQ(e.laps_completed, 1);
      ASSERT_EQ(e.change.landmarks.size(), 1u);
      EXPECT_EQ(e.change.landmarks[0].before, Eigen::Vector2d(7.0, 6.0));
      ASSERT_EQ(e.change.objects.size(), 1u);
      EXPECT_EQ(e.change.objects[0].after[0], Eigen::Vector2d(4.5, 3.0));
    }
    if (e.type != SimEventType::kRangeBearing) continue;
    for (const PointFeature& p : e.features.points) {
      if (p.id != 1) continue;
      const Eigen::Vector2d seen = transformPoint(
          e.true_pose,
          Eigen::Vector2d(p.range * std::cos(p.bearing), p.range * std::sin(p.bearing)));
      const bool after = change_stamp >= 0.0;
      const Eigen::Vector2d expected = after ? Eigen::Vector2d(7.5, 5.5) : Eigen::Vector2d(7, 6);
      ASSERT_NEAR((seen - expected).norm(), 0.0, 1e-9) << e.stamp;
      ++(after ? seen_after : seen_before);
    }
  }
  EXPECT_GT(change_stamp, 0.0);
  EXPECT_GT(seen_before, 0);
  EXPECT_GT(seen_after, 0);
  ASSERT_EQ(simulator.appliedChanges().size(), 1u);
  EXPECT_EQ(simulator.landmarks()[1].position, Eigen::Vector2d(7.5, 5.5));
}

TEST(Simulator, RandomDisplacementMovesBetweenMinAndMaxLandmarks) {
  World world = roomWorld();
  for (int id = 2; id < 12; ++id) world.landmarks.push_back({id, {2.0 + 0.5 * id, 7.5}, 0.0});
  WorldChange change;
  change.after_lap = 1;
  change.random_landmarks.count_min = 3;
  change.random_landmarks.count_max = 6;
  change.random_landmarks.sigma_m = 0.2;
  world.changes = {change};
  for (std::uint64_t seed = 0; seed < 5; ++seed) {
    SimulatorOptions options;
    options.seed = seed;
    Simulator simulator(world, options);
    simulator.run();
    ASSERT_EQ(simulator.appliedChanges().size(), 1u);
    const auto& moved = simulator.appliedChanges()[0].landmarks;
    EXPECT_GE(moved.size(), 3u);
    EXPECT_LE(moved.size(), 6u);
    for (const LandmarkChange& m : moved) EXPECT_GT((m.after - m.before).norm(), 0.0);
  }
}

TEST(Validate, AcceptsTheRoomAndRejectsNegativeNoise) {
  EXPECT_NO_THROW(validate(roomWorld()));
  World world = roomWorld();
  world.sensors.laser.range_noise_m = -1.0;
  try {
    validate(world);
    FAIL() << "negative noise accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("sensors.laser.range_noise_m = -1"), std::string::npos)
        << error.what();
  }
  world = roomWorld();
  world.odometry.translation_noise_m_per_m = -0.1;
  EXPECT_THROW(validate(world), std::invalid_argument);
}

TEST(Validate, RejectsAnUnclosedPolygon) {
  World world = roomWorld();
  world.objects[1].closed = false;  // first point != last point and no flag
  try {
    validate(world);
    FAIL() << "unclosed polygon accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("objects[1].polygon ('box') is not closed"),
              std::string::npos)
        << error.what();
  }
  world.objects[1].points.push_back(world.objects[1].points.front());  // closed by repetition
  EXPECT_NO_THROW(validate(world));
}

TEST(Validate, RejectsWaypointsInsideWallsAndOtherMistakes) {
  World world = roomWorld();
  world.waypoints[1] = {5.0, 4.0};  // inside the box
  try {
    validate(world);
    FAIL() << "waypoint inside a polygon accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("waypoints[1]"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("box"), std::string::npos) << error.what();
  }
  world = roomWorld();
  world.waypoints[1] = {9.9, 1.5};  // 0.1 m from the wall, robot radius 0.2 m
  EXPECT_THROW(validate(world), std::invalid_argument);
  world = roomWorld();
  world.laps = 0;
  EXPECT_THROW(validate(world), std::invalid_argument);
  world = roomWorld();
  world.changes.push_back(WorldChange());  // no trigger, no content
  EXPECT_THROW(validate(world), std::invalid_argument);
  world = roomWorld();
  world.waypoints = {{1.5, 1.5}, {1.5, 6.5}, {8.5, 6.5}, {8.5, 1.5}, {5.0, 1.5}, {5.0, 6.5}};
  EXPECT_THROW(validate(world), std::invalid_argument);  // the route crosses the box
  EXPECT_THROW(Simulator(world, SimulatorOptions()), std::invalid_argument);
}

// Wall time is measured by `simulate` and the benchmarks, not asserted here.
TEST(Simulator, ThirtyMinutesOfFourHertzSonarKeepTheRate) {
  World world = roomWorld();
  world.robot.speed_mps = 0.2;
  world.laps = 100;
  world.sensors.laser.enabled = false;
  world.sensors.infrared.enabled = false;
  world.sensors.sonar.rate_hz = 4.0;
  SimulatorOptions options;
  options.max_duration_s = 1800.0;
  Simulator simulator(world, options);
  SimEvent event;
  long sonar_readings = 0;
  while (simulator.next(&event)) sonar_readings += event.cones.size();
  EXPECT_NEAR(sonar_readings, (1800 * 4 + 1) * 12, 1e-9);
  EXPECT_NEAR(simulator.time(), 1800.0, 1e-6);
}

}  // namespace
}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

// Tests of the world YAML loader: every shipped world loads, and each kind of mistake is
// rejected with a message naming the file and the field.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "rbpf_slam/core/sim/simulator.h"
#include "rbpf_slam/io/world_yaml.h"

namespace rbpf_slam {
namespace io {
namespace {

namespace fs = std::filesystem;
using core::sim::World;

const char kMinimalWorld[] = R"(name: minimal
laps: 1
robot:
  radius_m: 0.2
objects:
  - name: walls
    polyline: [[0, 0], [6, 0], [6, 4], [0, 4], [0, 0]]
  - name: crate
    polygon: [[2.5, 1.5], [3.5, 1.5], [3.5, 2.5], [2.5, 2.5], [2.5, 1.5]]
waypoints: [[1, 1], [5, 1], [5, 3], [1, 3]]
sensors:
  laser:
    range_noise_m: 0.01
)";

/// The test's temporary directory, removed when the test program exits.
struct TemporaryDirectory {
  fs::path path =
      fs::temp_directory_path() / ("rbpf_slam_test_world_yaml_" + std::to_string(getpid()));
  ~TemporaryDirectory() {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
};

/// Writes text to a fresh file in the test's temporary directory and returns its path.
std::string writeWorld(const std::string& name, const std::string& text) {
  static const TemporaryDirectory directory;
  const fs::path& dir = directory.path;
  fs::create_directories(dir);
  const fs::path path = dir / name;
  std::ofstream(path) << text;
  return path.string();
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// The message of the WorldFileError that loading path throws ("" if it loads).
std::string loadError(const std::string& path) {
  try {
    loadWorld(path);
  } catch (const WorldFileError& error) {
    return error.what();
  }
  return "";
}

void expectContains(const std::string& message, const std::string& part) {
  EXPECT_NE(message.find(part), std::string::npos) << "'" << message << "' lacks '" << part << "'";
}

TEST(WorldYaml, EveryShippedWorldLoadsAndValidates) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(fs::path(RBPF_SOURCE_DIR) / "worlds")) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    const World world = loadWorld(entry.path().string());
    EXPECT_EQ(world.name, entry.path().stem().string());
    EXPECT_NO_THROW(core::sim::validate(world));
    names.push_back(world.name);
  }
  for (const char* expected : {"lee_sim_a", "lee_sim_b", "lee_sim_b_static", "lee_sonar_room",
                               "havangi_car", "yatim_epuck", "laser_office", "test_small"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
}

TEST(WorldYaml, ShippedWorldsHaveThePapersParameters) {
  const std::string dir = std::string(RBPF_SOURCE_DIR) + "/worlds/";
  const World a = loadWorld(dir + "lee_sim_a.yaml");
  EXPECT_EQ(a.landmarks.size(), 19u);
  EXPECT_EQ(a.laps, 3);
  EXPECT_DOUBLE_EQ(a.odometry.translation_noise_m_per_m, 0.03);
  EXPECT_TRUE(a.sensors.range_bearing.enabled);
  EXPECT_DOUBLE_EQ(a.sensors.range_bearing.max_range_m, 20.0);
  EXPECT_DOUBLE_EQ(a.sensors.range_bearing.range_noise_m, 0.2);
  EXPECT_DOUBLE_EQ(a.sensors.range_bearing.bearing_noise_deg, 2.0);
  ASSERT_EQ(a.changes.size(), 1u);
  EXPECT_EQ(a.changes[0].after_lap, 1);
  EXPECT_EQ(a.changes[0].landmarks.size(), 3u);

  const World b = loadWorld(dir + "lee_sim_b.yaml");
  EXPECT_EQ(b.landmarks.size(), 25u);
  ASSERT_EQ(b.changes.size(), 1u);
  EXPECT_EQ(b.changes[0].random_landmarks.count_min, 7);
  EXPECT_EQ(b.changes[0].random_landmarks.count_max, 18);
  EXPECT_DOUBLE_EQ(b.changes[0].random_landmarks.sigma_m, 0.2);
  EXPECT_TRUE(loadWorld(dir + "lee_sim_b_static.yaml").changes.empty());

  const World room = loadWorld(dir + "lee_sonar_room.yaml");
  EXPECT_TRUE(room.sensors.sonar.enabled);
  EXPECT_EQ(core::sim::ringPoses(room.sensors.sonar).size(), 12u);
  EXPECT_DOUBLE_EQ(room.sensors.sonar.rate_hz, 4.0);
  EXPECT_DOUBLE_EQ(room.robot.speed_mps, 0.1);
  EXPECT_EQ(room.laps, 2);

  const World car = loadWorld(dir + "havangi_car.yaml");
  EXPECT_EQ(car.robot.drive, core::sim::DriveType::kBicycle);
  EXPECT_DOUBLE_EQ(car.robot.wheelbase_m, 4.0);
  EXPECT_DOUBLE_EQ(car.robot.control_rate_hz, 40.0);
  EXPECT_DOUBLE_EQ(car.sensors.range_bearing.rate_hz, 5.0);
  EXPECT_DOUBLE_EQ(car.sensors.range_bearing.bearing_noise_deg, 0.1);

  const World epuck = loadWorld(dir + "yatim_epuck.yaml");
  EXPECT_TRUE(epuck.sensors.infrared.enabled);
  EXPECT_EQ(core::sim::ringPoses(epuck.sensors.infrared).size(), 8u);
  EXPECT_FALSE(epuck.sensors.sonar.enabled);
}

TEST(WorldYaml, ShippedLeeSimulationARelocatesItsRightmostLandmarksAfterLapOne) {
  core::sim::Simulator simulator(loadWorld(std::string(RBPF_SOURCE_DIR) + "/worlds/lee_sim_a.yaml"),
                                 core::sim::SimulatorOptions());
  simulator.run();
  EXPECT_TRUE(simulator.routeCompleted());
  ASSERT_EQ(simulator.appliedChanges().size(), 1u);
  const auto& change = simulator.appliedChanges()[0];
  EXPECT_EQ(change.laps_completed, 1);
  ASSERT_EQ(change.landmarks.size(), 3u);
  double rightmost_untouched = 0.0;
  for (const auto& landmark : simulator.world().landmarks) {
    bool moved = false;
    for (const auto& m : change.landmarks) moved = moved || m.id == landmark.id;
    if (!moved) rightmost_untouched = std::max(rightmost_untouched, landmark.position.x());
  }
  for (const auto& m : change.landmarks) EXPECT_GT(m.before.x(), rightmost_untouched);
}

TEST(WorldYaml, MinimalWorldLoadsWithDefaults) {
  const World world = loadWorld(writeWorld("minimal.yaml", kMinimalWorld));
  EXPECT_EQ(world.objects.size(), 2u);
  EXPECT_EQ(world.objects[1].shape, core::sim::ShapeType::kPolygon);
  EXPECT_TRUE(world.sensors.laser.enabled);  // its section is present
  EXPECT_FALSE(world.sensors.sonar.enabled);
  EXPECT_DOUBLE_EQ(world.sensors.laser.range_noise_m, 0.01);
  EXPECT_DOUBLE_EQ(world.sensors.laser.fov_deg, 180.0);
}

TEST(WorldYaml, RejectsAnUnknownKeyNamingFileAndField) {
  const std::string top = writeWorld("unknown_top.yaml", std::string(kMinimalWorld) + "lapz: 2\n");
  expectContains(loadError(top), top + ": lapz is not a known key");
  const std::string nested =
      writeWorld("unknown_nested.yaml", replaced(kMinimalWorld, "range_noise_m", "range_noize_m"));
  const std::string message = loadError(nested);
  expectContains(message, nested + ":");
  expectContains(message, "sensors.laser.range_noize_m is not a known key");
}

/// A repeated key used to be resolved to its first value without a word ("laps: 0" after
/// "laps: 2" ran two laps); a key that is not a plain name gave "bad conversion".
TEST(WorldYaml, RejectsRepeatedAndNonScalarKeys) {
  const std::string twice =
      writeWorld("twice.yaml", std::string(kMinimalWorld) + "laps: 2\nlaps: 0\n");
  expectContains(loadError(twice), twice + ": laps appears more than once");
  const std::string odd = writeWorld("odd_key.yaml", std::string(kMinimalWorld) + "[1, 2]: 3\n");
  expectContains(loadError(odd), odd + ": top level: a key that is not a plain name");
}

TEST(WorldYaml, RejectsNegativeNoiseNamingFileAndField) {
  const std::string path = writeWorld(
      "negative_noise.yaml", replaced(kMinimalWorld, "range_noise_m: 0.01", "range_noise_m: -1"));
  expectContains(loadError(path),
                 path + ": sensors.laser.range_noise_m = -1 is out of range [0, 100]");
}

/// In range but absurd: a beam every 1e-9 deg ran out of memory ("vector::_M_default_append")
/// and a 1 GHz control loop simulated for hours.
TEST(WorldYaml, RejectsAbsurdBeamCountsAndControlRates) {
  const std::string beams =
      writeWorld("beams.yaml", replaced(kMinimalWorld, "range_noise_m: 0.01",
                                        "range_noise_m: 0.01\n    resolution_deg: 1.0e-9"));
  expectContains(loadError(beams), beams + ": sensors.laser.resolution_deg = ");
  expectContains(loadError(beams), "beams a scan (at most 100000)");
  const std::string rate = writeWorld(
      "rate.yaml",
      replaced(kMinimalWorld, "radius_m: 0.2", "radius_m: 0.2\n  control_rate_hz: 1.0e9"));
  expectContains(loadError(rate), rate + ": robot.control_rate_hz = ");
  // Each within its limit, together 2000 kHz x 100000 beams: 120 GB of bag for 30 s.
  const std::string flood = writeWorld(
      "flood.yaml", replaced(replaced(kMinimalWorld, "range_noise_m: 0.01",
                                      "range_noise_m: 0.01\n    rate_hz: 2000\n    "
                                      "resolution_deg: 0.0036"),
                             "radius_m: 0.2", "radius_m: 0.2\n  control_rate_hz: 10000"));
  expectContains(loadError(flood), "beams a second (at most 1000000)");
  const std::string fast = writeWorld(
      "fast.yaml", replaced(kMinimalWorld, "radius_m: 0.2", "radius_m: 0.2\n  speed_mps: 1.0e300"));
  expectContains(loadError(fast), fast + ": robot.speed_mps = ");
  // A range above 3.4e38 became inf in the bag's float range_max; the filters refuse > 1 km.
  const std::string far =
      writeWorld("far.yaml", replaced(kMinimalWorld, "range_noise_m: 0.01",
                                      "range_noise_m: 0.01\n    max_range_m: 1.0e39"));
  expectContains(loadError(far), far + ": sensors.laser.max_range_m = ");
}

TEST(WorldYaml, RejectsAnUnclosedPolygonNamingFileAndField) {
  const std::string path = writeWorld(
      "unclosed.yaml", replaced(kMinimalWorld, ", [2.5, 2.5], [2.5, 1.5]]", ", [2.5, 2.5]]"));
  const std::string message = loadError(path);
  expectContains(message, path + ": objects[1].polygon ('crate') is not closed");
  // The same points with closed: true are accepted.
  const std::string flagged =
      writeWorld("flagged.yaml",
                 replaced(replaced(kMinimalWorld, ", [2.5, 2.5], [2.5, 1.5]]", ", [2.5, 2.5]]"),
                          "waypoints:", "    closed: true\nwaypoints:"));
  EXPECT_EQ(loadError(flagged), "");
}

TEST(WorldYaml, RejectsAWaypointInsideAWallNamingFileAndField) {
  const std::string in_polygon =
      writeWorld("in_polygon.yaml", replaced(kMinimalWorld, "[5, 3], [1, 3]]", "[3, 2], [1, 3]]"));
  std::string message = loadError(in_polygon);
  expectContains(message, in_polygon + ": waypoints[2] = (3, 2) is inside object 'crate'");
  const std::string near_wall =
      writeWorld("near_wall.yaml", replaced(kMinimalWorld, "[[1, 1], [5, 1]", "[[1, 1], [5.9, 1]"));
  message = loadError(near_wall);
  expectContains(message, near_wall +
                              ": waypoints[1] = (5.9, 1) is inside the wall of object "
                              "'walls'");
}

TEST(WorldYaml, RejectsWrongTypesEnumsSyntaxAndMissingFiles) {
  const std::string not_number =
      writeWorld("not_number.yaml", replaced(kMinimalWorld, "radius_m: 0.2", "radius_m: wide"));
  expectContains(loadError(not_number), not_number + ": robot.radius_m = wide is not a number");
  const std::string bad_enum =
      writeWorld("bad_enum.yaml", replaced(kMinimalWorld, "radius_m: 0.2", "drive: tank"));
  expectContains(loadError(bad_enum), bad_enum + ": robot.drive = 'tank' is not one of");
  const std::string bad_point = writeWorld(
      "bad_point.yaml", replaced(kMinimalWorld, "[[1, 1], [5, 1]", "[[1, 1], [5, 1, 0]"));
  expectContains(loadError(bad_point), bad_point + ": waypoints[1] = [5, 1, 0] is not [x, y]");
  const std::string syntax = writeWorld("syntax.yaml", "laps: [1, 2\n");
  expectContains(loadError(syntax), syntax + ":");
  expectContains(loadError(syntax), "YAML syntax error");
  expectContains(loadError("/nonexistent/world.yaml"), "/nonexistent/world.yaml: cannot be opened");
}

/// The minimal world with these changes appended (a "changes:" list, indented by two spaces).
std::string withChanges(const std::string& changes) {
  return std::string(kMinimalWorld) + "changes:\n" + changes;
}

/// An infinite noise passed the [0, inf] checks and filled /odom with NaN.
TEST(WorldYaml, RejectsInfiniteNoise) {
  const std::string path = writeWorld(
      "inf_noise.yaml", replaced(kMinimalWorld, "range_noise_m: 0.01", "range_noise_m: .inf"));
  expectContains(loadError(path),
                 path + ": sensors.laser.range_noise_m = inf is out of range [0, 100]");
}

/// A hair's ray spacing hung the run; 1e-300 overflowed the ray count and lost most echoes.
TEST(WorldYaml, RejectsAbsurdSonarRayCounts) {
  for (const char* spacing : {"1.0e-5", "1.0e-300"}) {
    const std::string path =
        writeWorld("rays.yaml", replaced(kMinimalWorld, "sensors:\n",
                                         std::string("sensors:\n  sonar:\n    ray_spacing_deg: ") +
                                             spacing + "\n"));
    expectContains(loadError(path), path + ": sensors.sonar.ray_spacing_deg = ");
    expectContains(loadError(path), "rays a reading over sensors.sonar.cone_deg");
  }
}

TEST(WorldYaml, RejectsZeroLengthWallsAndFlatPolygons) {
  const std::string wall = writeWorld(
      "zero_wall.yaml", replaced(kMinimalWorld, "[[0, 0], [6, 0], [6, 4]", "[[0, 0], [6, 0], [6, 0], [6, 4]"));
  expectContains(loadError(wall), wall + ": objects[0].polyline ('walls')[2] = (6, 0) repeats the "
                                         "point before it (a wall of zero length)");
  const std::string flat = writeWorld(
      "flat.yaml", replaced(kMinimalWorld, "[[2.5, 1.5], [3.5, 1.5], [3.5, 2.5], [2.5, 2.5], [2.5, 1.5]]",
                            "[[2.5, 1.5], [3.0, 1.5], [3.5, 1.5], [2.5, 1.5]]"));
  expectContains(loadError(flat), flat + ": objects[1].polygon ('crate') encloses no area");
}

/// yaml-cpp reads 010 as octal 8 (laps: 010 drove 8 laps) and 0x10 as 16; an empty enum value
/// fell back to the default.
TEST(WorldYaml, RejectsOctalIntegersEmptyEnumsEmptyAnglesAndDirectories) {
  for (const char* laps : {"010", "0x10", "1.5"}) {
    const std::string path =
        writeWorld("laps.yaml", replaced(kMinimalWorld, "laps: 1", std::string("laps: ") + laps));
    expectContains(loadError(path), path + ": laps = " + laps + " is not an integer");
  }
  const std::string drive =
      writeWorld("empty_drive.yaml", replaced(kMinimalWorld, "radius_m: 0.2", "radius_m: 0.2\n  drive: ''"));
  expectContains(loadError(drive), drive + ": robot.drive = '' is not one of: diff_drive, bicycle");
  const std::string angles = writeWorld(
      "angles.yaml", replaced(kMinimalWorld, "sensors:\n", "sensors:\n  infrared:\n    angles_deg: []\n"));
  expectContains(loadError(angles), angles + ": sensors.infrared.angles_deg is empty");
  const std::string directory = fs::path(writeWorld("any.yaml", kMinimalWorld)).parent_path().string();
  expectContains(loadError(directory), directory + ": is a directory, not a world file");
}

TEST(WorldYaml, RejectsObjectMovesThatIgnoreOrLackFields) {
  const std::string both = writeWorld("both.yaml", withChanges(
      "  - at_time_s: 5\n    objects:\n      - {name: crate, points: [[2, 2], [3, 2], [3, 3], [2, 2]], "
      "translate_m: [0, 0.1]}\n"));
  expectContains(loadError(both), both + ": changes[0].objects[0].points replaces the outline: it "
                                         "excludes translate_m and rotate_deg");
  const std::string removed = writeWorld("remove_and_move.yaml", withChanges(
      "  - at_time_s: 5\n    objects:\n      - {name: crate, remove: true, rotate_deg: 10}\n"));
  expectContains(loadError(removed), removed + ": changes[0].objects[0].remove: true excludes");
  const std::string nothing = writeWorld("nothing.yaml", withChanges(
      "  - at_time_s: 5\n    objects:\n      - {name: crate}\n"));
  expectContains(loadError(nothing), nothing + ": changes[0].objects[0]: 'crate' changes nothing");
  const std::string no_points = writeWorld("no_points.yaml", withChanges(
      "  - at_time_s: 5\n    objects:\n      - {name: crate, points: []}\n"));
  expectContains(loadError(no_points), no_points + ": changes[0].objects[0].points is empty");
  const std::string twice = writeWorld("twice.yaml", withChanges(
      "  - at_time_s: 5\n    objects:\n      - {name: crate, remove: true}\n"
      "      - {name: crate, translate_m: [0, 0.1]}\n"));
  expectContains(loadError(twice), twice + ": changes[0].objects[1]: object 'crate' was removed "
                                           "earlier in this change");
}

/// Changes used to be checked one at a time against the world as it starts: a move after a
/// removal was dropped silently, and moves that add up onto the route were accepted.
TEST(WorldYaml, ReplaysChangesInTheOrderTheyHappen) {
  // Listed out of order: the removal at 5 s happens before the move at 10 s.
  const std::string after_removal = writeWorld("after_removal.yaml", withChanges(
      "  - at_time_s: 10\n    objects:\n      - {name: crate, translate_m: [0, 0.1]}\n"
      "  - at_time_s: 5\n    objects:\n      - {name: crate, remove: true}\n"));
  expectContains(loadError(after_removal),
                 after_removal + ": changes[0].objects[0]: object 'crate' was removed by "
                                 "changes[1], which happens before this one");
  // Two moves of 0.3 m each are fine alone; together they put the crate on the route at y = 3.
  const std::string one = "    objects:\n      - {name: crate, translate_m: [0, 0.3]}\n";
  EXPECT_EQ(loadError(writeWorld("one_move.yaml", withChanges("  - at_time_s: 5\n" + one))), "");
  const std::string adding_up = writeWorld(
      "adding_up.yaml", withChanges("  - at_time_s: 5\n" + one + "  - at_time_s: 10\n" + one));
  expectContains(loadError(adding_up),
                 adding_up + ": after changes[1]: waypoints: the route from waypoints[2] to "
                             "waypoints[3] crosses object 'crate'");
  // A landmark post moved onto a waypoint.
  const std::string post = writeWorld("post.yaml",
      replaced(withChanges("  - at_time_s: 5\n    landmarks:\n      - {id: 7, x_m: 5, y_m: 3}\n"),
               "waypoints:", "landmarks:\n  - {id: 7, x_m: 2, y_m: 2.0, radius_m: 0.1}\nwaypoints:"));
  expectContains(loadError(post), post + ": after changes[0]: waypoints[2] = (5, 3) is inside "
                                         "landmark 7");
  // One object changed after a lap and at a time: the order depends on the robot's speed.
  const std::string mixed = writeWorld("mixed.yaml",
      replaced(withChanges("  - after_lap: 1\n" + one + "  - at_time_s: 5\n" + one), "laps: 1",
               "laps: 2"));
  expectContains(loadError(mixed), mixed + ": changes[1] and changes[0] both change object "
                                           "'crate', one after a lap and one at a time");
  // A random displacement may draw any landmark (here every one): a time change of one of them
  // conflicts with it too.
  const std::string random = writeWorld("random.yaml",
      replaced(replaced(withChanges("  - after_lap: 1\n    random_landmarks: {count: 1, sigma_m: 0.1}\n"
                                    "  - at_time_s: 5\n    landmarks:\n      - {id: 7, x_m: 2, y_m: 2.2}\n"),
                        "waypoints:", "landmarks:\n  - {id: 7, x_m: 2, y_m: 2.0}\nwaypoints:"),
               "laps: 1", "laps: 2"));
  expectContains(loadError(random), random + ": changes[1] and changes[0] both change landmark 7");
}

// Two changes due at one control step (20 Hz: 5.02 s and 5.05 s both at 5.05 s) are applied in
// the order they were due, as validate() replays them: the move at 5.02 s, then the new outline
// at 5.05 s. In list order the outline would have been moved.
TEST(WorldYaml, ChangesDueAtOneStepApplyInTheOrderTheyWereDue) {
  const std::string path = writeWorld("due.yaml", withChanges(
      "  - at_time_s: 5.05\n    objects:\n"
      "      - {name: crate, points: [[2, 1.5], [3, 1.5], [3, 2.5], [2, 2.5], [2, 1.5]]}\n"
      "  - at_time_s: 5.02\n    objects:\n      - {name: crate, translate_m: [0, 0.1]}\n"));
  core::sim::SimulatorOptions options;
  options.max_duration_s = 6.0;
  core::sim::Simulator simulator(loadWorld(path), options);
  simulator.run();
  ASSERT_EQ(simulator.appliedChanges().size(), 2u);
  EXPECT_EQ(simulator.appliedChanges()[0].change_index, 1);
  EXPECT_EQ(simulator.appliedChanges()[1].change_index, 0);
  const auto crate = std::find_if(simulator.objects().begin(), simulator.objects().end(),
                                  [](const core::sim::WorldObject& o) { return o.name == "crate"; });
  ASSERT_NE(crate, simulator.objects().end());
  EXPECT_EQ(crate->points.front(), Eigen::Vector2d(2, 1.5));
}

}  // namespace
}  // namespace io
}  // namespace rbpf_slam

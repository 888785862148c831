#include "rbpf_slam/core/sim/world.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/core/plausibility.h"

namespace rbpf_slam {
namespace core {
namespace sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string point(const Eigen::Vector2d& p) {
  return "(" + number(p.x()) + ", " + number(p.y()) + ")";
}

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

/// Checks lo <= value <= hi (or strict where open); NaN always fails.
void checkRange(const std::string& field, double value, double lo, double hi, bool lo_open = false,
                bool hi_open = false) {
  const bool above = lo_open ? value > lo : value >= lo;
  const bool below = hi_open ? value < hi : value <= hi;
  if (above && below) return;
  fail(field + " = " + number(value) + " is out of range " + (lo_open ? "(" : "[") + number(lo) +
       ", " + number(hi) + (hi_open || std::isinf(hi) ? ")" : "]"));
}

/// 0 <= value < inf: an infinite noise or size is as broken as a negative one.
void nonNegative(const std::string& field, double value) {
  checkRange(field, value, 0.0, kInf, false, true);
}
void positive(const std::string& field, double value) {
  checkRange(field, value, 0.0, kInf, true, true);
}

void finitePoint(const std::string& field, const Eigen::Vector2d& p) {
  if (!p.allFinite()) fail(field + " = " + point(p) + " is not a finite point");
}

std::string objectField(const WorldObject& object, int index) {
  return "objects[" + std::to_string(index) + "]." +
         (object.shape == ShapeType::kPolygon ? "polygon" : "polyline") + " ('" + object.name +
         "')";
}

void checkObjectShape(const WorldObject& object, const std::string& field) {
  for (size_t i = 0; i < object.points.size(); ++i) {
    finitePoint(field + "[" + std::to_string(i) + "]", object.points[i]);
  }
  if (object.points.size() < 2) fail(field + " needs at least 2 points");
  for (size_t i = 0; i + 1 < object.points.size(); ++i) {
    if (object.points[i] == object.points[i + 1]) {
      fail(field + "[" + std::to_string(i + 1) + "] = " + point(object.points[i + 1]) +
           " repeats the point before it (a wall of zero length)");
    }
  }
  if (object.shape == ShapeType::kPolygon) {
    if (!isClosed(object)) {
      fail(field + " is not closed: the first point " + point(object.points.front()) +
           " differs from the last " + point(object.points.back()) +
           "; repeat the first point or set closed: true");
    }
    const size_t distinct =
        object.points.size() - (object.points.front() == object.points.back() ? 1 : 0);
    if (distinct < 3) fail(field + " needs at least 3 distinct points");
    double twice_area = 0.0;  // shoelace
    for (size_t i = 0; i < distinct; ++i) {
      const Eigen::Vector2d& a = object.points[i];
      const Eigen::Vector2d& b = object.points[(i + 1) % distinct];
      twice_area += a.x() * b.y() - b.x() * a.y();
    }
    if (!(std::abs(twice_area) > 1e-12)) {
      fail(field + " encloses no area (its points are collinear or fold back on themselves)");
    }
  }
}

void checkRobot(const RobotConfig& robot) {
  nonNegative("robot.radius_m", robot.radius_m);
  positive("robot.wheelbase_m", robot.wheelbase_m);
  // A mobile robot, indoor or a car: 100 m/s is far beyond either (1e300 went through walls).
  checkRange("robot.speed_mps", robot.speed_mps, 0.0, 100.0, true);
  positive("robot.max_turn_rate_deg_s", robot.max_turn_rate_deg_s);
  checkRange("robot.max_steering_deg", robot.max_steering_deg, 0.0, 90.0, true, true);
  nonNegative("robot.max_steering_rate_deg_s", robot.max_steering_rate_deg_s);
  // 10 kHz is far above any robot's control loop; more only makes a run take hours.
  checkRange("robot.control_rate_hz", robot.control_rate_hz, 0.0, 10000.0, true);
  positive("robot.lookahead_m", robot.lookahead_m);
  positive("robot.waypoint_tolerance_m", robot.waypoint_tolerance_m);
  if (robot.drive == DriveType::kBicycle && robot.controller == ControllerType::kTurnThenDrive) {
    fail(
        "robot.controller = turn_then_drive needs robot.drive = diff_drive (a car cannot turn "
        "on the spot)");
  }
}

void checkOdometry(const OdometryConfig& odometry, DriveType drive) {
  nonNegative("odometry.translation_noise_m_per_m", odometry.translation_noise_m_per_m);
  nonNegative("odometry.rotation_noise_rad_per_rad", odometry.rotation_noise_rad_per_rad);
  nonNegative("odometry.rotation_noise_rad_per_m", odometry.rotation_noise_rad_per_m);
  checkRange("odometry.translation_scale_bias", odometry.translation_scale_bias, -1.0, 1.0, true,
             true);
  checkRange("odometry.rotation_scale_bias", odometry.rotation_scale_bias, -1.0, 1.0, true, true);
  nonNegative("odometry.speed_noise_mps", odometry.speed_noise_mps);
  nonNegative("odometry.steering_noise_deg", odometry.steering_noise_deg);
  if (odometry.steering_noise_deg > 0.0 && drive != DriveType::kBicycle) {
    fail("odometry.steering_noise_deg = " + number(odometry.steering_noise_deg) +
         " needs robot.drive = bicycle");
  }
}

void checkRangeLimits(const std::string& prefix, double min_range_m, double max_range_m) {
  nonNegative(prefix + ".min_range_m", min_range_m);
  if (!(max_range_m > min_range_m) || !std::isfinite(max_range_m)) {
    fail(prefix + ".max_range_m = " + number(max_range_m) + " must be finite and greater than " +
         prefix + ".min_range_m = " + number(min_range_m));
  }
  // The filters and converters take ranges beyond a kilometre as corrupt (core/plausibility.h);
  // above 3.4e38 the bag's float range_max is inf.
  checkRange(prefix + ".max_range_m", max_range_m, 0.0, kMaxPlausibleRangeM, true);
}

/// Readings are taken at control steps, so no sensor can be faster than the control loop.
void checkRate(const std::string& field, double rate_hz, double control_rate_hz) {
  checkRange(field, rate_hz, 0.0, control_rate_hz, true);
}

void checkLaser(const LaserConfig& laser, double control_rate_hz) {
  const std::string p = "sensors.laser";
  checkRate(p + ".rate_hz", laser.rate_hz, control_rate_hz);
  checkRange(p + ".fov_deg", laser.fov_deg, 0.0, 360.0, true);
  checkRange(p + ".resolution_deg", laser.resolution_deg, 0.0, laser.fov_deg, true);
  // A beam every 0.001 deg is 360000 beams a scan: beyond any laser and any memory budget.
  if (laser.resolution_deg > 0.0 && laser.fov_deg / laser.resolution_deg > 100000.0) {
    fail(p + ".resolution_deg = " + number(laser.resolution_deg) + " gives " +
         number(std::floor(laser.fov_deg / laser.resolution_deg)) +
         " beams a scan (at most 100000)");
  }
  // ... and beams a second: a 1 million beams/s laser writes about 4 MB of bag a second.
  if (laser.resolution_deg > 0.0 && laser.rate_hz * laser.fov_deg / laser.resolution_deg > 1e6) {
    fail(p + ": rate_hz x fov_deg / resolution_deg = " +
         number(laser.rate_hz * laser.fov_deg / laser.resolution_deg) +
         " beams a second (at most 1000000)");
  }
  checkRangeLimits(p, laser.min_range_m, laser.max_range_m);
  checkRange(p + ".range_noise_m", laser.range_noise_m, 0.0, 100.0);  // 1e300 gave inf covariances
  checkRange(p + ".mount_x_m", laser.mount_x_m, -kInf, kInf, true, true);
  checkRange(p + ".mount_y_m", laser.mount_y_m, -kInf, kInf, true, true);
  checkRange(p + ".mount_yaw_deg", laser.mount_yaw_deg, -360.0, 360.0);
}

void checkRing(const RingSensorConfig& ring, const std::string& p, double control_rate_hz) {
  checkRate(p + ".rate_hz", ring.rate_hz, control_rate_hz);
  if (ring.angles_deg.empty()) {
    checkRange(p + ".count", ring.count, 1, 64);
  }
  for (size_t i = 0; i < ring.angles_deg.size(); ++i) {
    checkRange(p + ".angles_deg[" + std::to_string(i) + "]", ring.angles_deg[i], -360.0, 360.0);
  }
  nonNegative(p + ".ring_radius_m", ring.ring_radius_m);
  checkRange(p + ".cone_deg", ring.cone_deg, 0.0, 180.0, true);
  checkRangeLimits(p, ring.min_range_m, ring.max_range_m);
  checkRange(p + ".range_noise_m", ring.range_noise_m, 0.0, 100.0);  // 1e300 gave inf covariances
  checkRange(p + ".critical_angle_deg", ring.critical_angle_deg, 0.0, 90.0, true);
  checkRange(p + ".ray_spacing_deg", ring.ray_spacing_deg, 0.0, ring.cone_deg, true);
  // Every reading casts a ray per spacing over the cone; a hair's spacing made a run hang (and
  // 1e-300 overflowed the ray count to none).
  constexpr double kMaxRaysPerCone = 10000.0;
  if (ring.cone_deg / ring.ray_spacing_deg > kMaxRaysPerCone) {
    fail(p + ".ray_spacing_deg = " + number(ring.ray_spacing_deg) + " gives " +
         number(std::ceil(ring.cone_deg / ring.ray_spacing_deg)) + " rays a reading over " +
         p + ".cone_deg = " + number(ring.cone_deg) + " (at most " + number(kMaxRaysPerCone) +
         ")");
  }
}

void checkRangeBearing(const RangeBearingConfig& sensor, double control_rate_hz) {
  const std::string p = "sensors.range_bearing";
  checkRate(p + ".rate_hz", sensor.rate_hz, control_rate_hz);
  checkRangeLimits(p, sensor.min_range_m, sensor.max_range_m);
  checkRange(p + ".fov_deg", sensor.fov_deg, 0.0, 360.0, true);
  checkRange(p + ".range_noise_m", sensor.range_noise_m, 0.0, 100.0);  // 1e300 gave inf covariances
  checkRange(p + ".bearing_noise_deg", sensor.bearing_noise_deg, 0.0, 180.0);
  checkRange(p + ".detection_probability", sensor.detection_probability, 0.0, 1.0, true);
}

/// True when the segments pq and ab cross or touch.
bool segmentsIntersect(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b) {
  auto cross = [](const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
    return u.x() * v.y() - u.y() * v.x();
  };
  const Eigen::Vector2d r = q - p, s = b - a;
  const double denominator = cross(r, s);
  if (std::abs(denominator) < 1e-12) return false;  // parallel: the clearance check covers it
  const double t = cross(a - p, s) / denominator;
  const double u = cross(a - p, r) / denominator;
  return t >= 0.0 && t <= 1.0 && u >= 0.0 && u <= 1.0;
}

/// Rejects a waypoint that is within the robot's radius of an object or inside a polygon.
void checkWaypointClear(const World& world, const WorldObject& object, int object_index,
                        const std::string& what) {
  for (size_t w = 0; w < world.waypoints.size(); ++w) {
    const Eigen::Vector2d& p = world.waypoints[w];
    const std::string field = "waypoints[" + std::to_string(w) + "] = " + point(p);
    if (object.shape == ShapeType::kPolygon && insideOutline(object, p)) {
      fail(field + " is inside " + what + " '" + object.name + "'");
    }
    for (const Segment& segment : objectSegments(object, object_index)) {
      const double distance = distanceToSegment(p, segment.a, segment.b);
      if (distance < world.robot.radius_m) {
        fail(field + " is inside the wall of " + what + " '" + object.name +
             "': " + number(distance) +
             " m from it, closer than robot.radius_m = " + number(world.robot.radius_m));
      }
    }
  }
}

void checkWaypoints(const World& world) {
  const auto& waypoints = world.waypoints;
  if (waypoints.size() < 2) {
    fail("waypoints has " + std::to_string(waypoints.size()) + " points; at least 2 are needed");
  }
  for (size_t i = 0; i < waypoints.size(); ++i) {
    finitePoint("waypoints[" + std::to_string(i) + "]", waypoints[i]);
    const size_t j = (i + 1) % waypoints.size();
    if ((waypoints[i] - waypoints[j]).norm() <= world.robot.waypoint_tolerance_m) {
      fail("waypoints[" + std::to_string(j) + "] = " + point(waypoints[j]) +
           " is within robot.waypoint_tolerance_m of waypoints[" + std::to_string(i) +
           "] (the route returns to waypoints[0] by itself)");
    }
  }
  for (size_t k = 0; k < world.objects.size(); ++k) {
    const WorldObject& object = world.objects[k];
    checkWaypointClear(world, object, static_cast<int>(k), "object");
    for (size_t i = 0; i < waypoints.size(); ++i) {
      const size_t j = (i + 1) % waypoints.size();
      for (const Segment& s : objectSegments(object, static_cast<int>(k))) {
        if (segmentsIntersect(waypoints[i], waypoints[j], s.a, s.b)) {
          fail("waypoints: the route from waypoints[" + std::to_string(i) + "] to waypoints[" +
               std::to_string(j) + "] crosses object '" + object.name + "'");
        }
      }
    }
  }
  for (const Landmark& landmark : world.landmarks) {
    if (landmark.radius_m <= 0.0) continue;
    for (size_t w = 0; w < waypoints.size(); ++w) {
      if ((waypoints[w] - landmark.position).norm() < landmark.radius_m + world.robot.radius_m) {
        fail("waypoints[" + std::to_string(w) + "] = " + point(waypoints[w]) +
             " is inside landmark " + std::to_string(landmark.id) + " (a post of radius " +
             number(landmark.radius_m) + " m) given robot.radius_m");
      }
    }
  }
}

void checkObjectsAndLandmarks(const World& world) {
  std::set<std::string> names;
  for (size_t i = 0; i < world.objects.size(); ++i) {
    const WorldObject& object = world.objects[i];
    const std::string field = "objects[" + std::to_string(i) + "]";
    if (object.name.empty()) fail(field + ".name is empty");
    if (!names.insert(object.name).second) fail(field + ".name '" + object.name + "' is repeated");
    checkObjectShape(object, objectField(object, static_cast<int>(i)));
  }
  std::set<int> ids;
  for (size_t i = 0; i < world.landmarks.size(); ++i) {
    const Landmark& landmark = world.landmarks[i];
    const std::string field = "landmarks[" + std::to_string(i) + "]";
    checkRange(field + ".id", landmark.id, 0, std::numeric_limits<int>::max());
    if (!ids.insert(landmark.id).second) {
      fail(field + ".id = " + std::to_string(landmark.id) + " is repeated");
    }
    finitePoint(field + ".x_m, y_m", landmark.position);
    nonNegative(field + ".radius_m", landmark.radius_m);
  }
}

void checkChange(const World& world, const WorldChange& change, const std::string& p) {
  const bool by_lap = change.after_lap != 0;
  const bool by_time = change.at_time_s >= 0.0;
  if (by_lap == by_time) fail(p + " needs exactly one of after_lap and at_time_s");
  if (by_lap) {
    checkRange(p + ".after_lap", change.after_lap, 1, world.laps - 1);
  } else {
    checkRange(p + ".at_time_s", change.at_time_s, 0.0, world.max_duration_s, false, true);
  }
  const RandomDisplacement& random = change.random_landmarks;
  if (change.objects.empty() && change.landmarks.empty() && random.count_max == 0) {
    fail(p + " changes nothing");
  }
  for (size_t i = 0; i < change.objects.size(); ++i) {
    const ObjectMove& move = change.objects[i];
    const std::string field = p + ".objects[" + std::to_string(i) + "]";
    int index = -1;
    for (size_t k = 0; k < world.objects.size(); ++k) {
      if (world.objects[k].name == move.name) index = static_cast<int>(k);
    }
    if (index < 0) fail(field + ".name '" + move.name + "' is not an object of the world");
    finitePoint(field + ".translate_m", move.translate_m);
    checkRange(field + ".rotate_deg", move.rotate_deg, -360.0, 360.0);
    for (size_t k = 0; k < move.points.size(); ++k) {
      finitePoint(field + ".points[" + std::to_string(k) + "]", move.points[k]);
    }
  }
  std::set<int> ids;
  for (const Landmark& landmark : world.landmarks) ids.insert(landmark.id);
  for (size_t i = 0; i < change.landmarks.size(); ++i) {
    const std::string field = p + ".landmarks[" + std::to_string(i) + "]";
    if (!ids.count(change.landmarks[i].id)) {
      fail(field + ".id = " + std::to_string(change.landmarks[i].id) + " is not a landmark");
    }
    finitePoint(field + ".x_m, y_m", change.landmarks[i].position);
  }
  const std::string field = p + ".random_landmarks";
  for (size_t i = 0; i < random.candidate_ids.size(); ++i) {
    if (!ids.count(random.candidate_ids[i])) {
      fail(field + ".candidate_ids[" + std::to_string(i) +
           "] = " + std::to_string(random.candidate_ids[i]) + " is not a landmark");
    }
  }
  const int pool = static_cast<int>(random.candidate_ids.empty() ? world.landmarks.size()
                                                                 : random.candidate_ids.size());
  checkRange(field + ".count_min", random.count_min, 0, pool);
  checkRange(field + ".count_max", random.count_max, random.count_min, pool);
  nonNegative(field + ".sigma_m", random.sigma_m);
}

/// "by changes[j], which happens before this one", or "earlier in this change".
std::string removedWhere(size_t by, size_t current) {
  if (by == current) return "earlier in this change";
  return "by changes[" + std::to_string(by) + "], which happens before this one";
}

/// Replays the changes in the order they happen on a copy of the world: an object or landmark
/// removed earlier cannot be moved later, and every state the robot drives through keeps the
/// route clear (outlines, waypoints, posts), moves adding up.
void checkChangeSequence(const World& world) {
  World state = world;
  std::map<std::string, size_t> removed_objects;
  std::map<int, size_t> removed_landmarks;
  for (size_t i : changeOrder(world)) {  // declared in world.h, defined below
    const WorldChange& change = world.changes[i];
    const std::string p = "changes[" + std::to_string(i) + "]";
    for (size_t k = 0; k < change.objects.size(); ++k) {
      const ObjectMove& move = change.objects[k];
      const std::string field = p + ".objects[" + std::to_string(k) + "]";
      const auto removed = removed_objects.find(move.name);
      if (removed != removed_objects.end()) {
        fail(field + ": object '" + move.name + "' was removed " + removedWhere(removed->second, i));
      }
      auto object = std::find_if(state.objects.begin(), state.objects.end(),
                                 [&move](const WorldObject& o) { return o.name == move.name; });
      if (object == state.objects.end()) continue;  // not an object: checkChange names it
      if (move.remove) {
        removed_objects.emplace(move.name, i);
        state.objects.erase(object);
        continue;
      }
      *object = movedObject(*object, move);
      checkObjectShape(*object, field + (move.points.empty() ? " (moved outline)" : ".points"));
    }
    for (size_t k = 0; k < change.landmarks.size(); ++k) {
      const LandmarkMove& move = change.landmarks[k];
      const std::string field = p + ".landmarks[" + std::to_string(k) + "]";
      const auto removed = removed_landmarks.find(move.id);
      if (removed != removed_landmarks.end()) {
        fail(field + ": landmark " + std::to_string(move.id) + " was removed " +
             removedWhere(removed->second, i));
      }
      auto landmark = std::find_if(state.landmarks.begin(), state.landmarks.end(),
                                   [&move](const Landmark& l) { return l.id == move.id; });
      if (landmark == state.landmarks.end()) continue;
      if (move.remove) {
        removed_landmarks.emplace(move.id, i);
        state.landmarks.erase(landmark);
      } else {
        landmark->position = move.position;
      }
    }
    try {
      checkWaypoints(state);
    } catch (const std::invalid_argument& error) {
      fail("after " + p + ": " + error.what());
    }
  }
}

}  // namespace

RingSensorConfig defaultSonarConfig() { return RingSensorConfig(); }

RingSensorConfig defaultInfraredConfig() {
  RingSensorConfig ring;
  ring.rate_hz = 10.0;
  ring.count = 8;
  // e-puck proximity sensors ps0..ps7, clockwise from front-right.
  ring.angles_deg = {-17.0, -48.0, -90.0, -150.0, 150.0, 90.0, 48.0, 17.0};
  ring.ring_radius_m = 0.037;
  ring.cone_deg = 20.0;
  ring.min_range_m = 0.005;
  ring.max_range_m = 0.07;
  ring.range_noise_m = 0.003;
  ring.critical_angle_deg = 90.0;
  ring.corner_echoes = false;
  ring.ray_spacing_deg = 5.0;
  return ring;
}

bool isClosed(const WorldObject& object) {
  if (object.closed) return true;
  return object.points.size() >= 2 && object.points.front() == object.points.back();
}

std::vector<Segment> objectSegments(const WorldObject& object, int object_index) {
  std::vector<Segment> segments;
  const auto& points = object.points;
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    segments.push_back({points[i], points[i + 1], object_index});
  }
  const bool add_closing = object.closed && points.size() >= 3 && points.front() != points.back();
  if (add_closing) segments.push_back({points.back(), points.front(), object_index});
  return segments;
}

bool insideOutline(const WorldObject& object, const Eigen::Vector2d& p) {
  bool inside = false;
  for (const Segment& s : objectSegments(object, 0)) {
    if ((s.a.y() > p.y()) != (s.b.y() > p.y())) {
      const double x = s.a.x() + (p.y() - s.a.y()) / (s.b.y() - s.a.y()) * (s.b.x() - s.a.x());
      if (p.x() < x) inside = !inside;
    }
  }
  return inside;
}

double distanceToSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                         const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double length_squared = ab.squaredNorm();
  if (length_squared <= 0.0) return (p - a).norm();
  const double t = std::clamp((p - a).dot(ab) / length_squared, 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

WorldObject movedObject(const WorldObject& object, const ObjectMove& move) {
  WorldObject moved = object;
  if (!move.points.empty()) {
    moved.points = move.points;
    return moved;
  }
  size_t distinct = object.points.size();
  if (distinct >= 2 && object.points.front() == object.points.back()) --distinct;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < distinct; ++i) centroid += object.points[i];
  if (distinct > 0) centroid /= static_cast<double>(distinct);
  const double angle = move.rotate_deg * M_PI / 180.0;
  const Eigen::Matrix2d rotation =
      (Eigen::Matrix2d() << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle))
          .finished();
  for (Eigen::Vector2d& p : moved.points)
    p = centroid + rotation * (p - centroid) + move.translate_m;
  return moved;
}

std::vector<Pose2> ringPoses(const RingSensorConfig& ring) {
  std::vector<double> angles_deg = ring.angles_deg;
  if (angles_deg.empty()) {
    for (int i = 0; i < ring.count; ++i) angles_deg.push_back(360.0 * i / ring.count);
  }
  std::vector<Pose2> poses;
  for (double degrees : angles_deg) {
    const double a = wrapAngle(degrees * M_PI / 180.0);
    poses.emplace_back(ring.ring_radius_m * std::cos(a), ring.ring_radius_m * std::sin(a), a);
  }
  return poses;
}

// A world that triggers changes both ways must not let the two kinds touch one object or
// landmark, whose state would then depend on the robot's speed (world.h).
std::vector<size_t> changeOrder(const World& world) {
  std::vector<size_t> order(world.changes.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&world](size_t a, size_t b) {
    const WorldChange& x = world.changes[a];
    const WorldChange& y = world.changes[b];
    const bool x_lap = x.after_lap != 0, y_lap = y.after_lap != 0;
    if (x_lap != y_lap) return x_lap;  // apart: shared targets are refused below
    return x_lap ? x.after_lap < y.after_lap : x.at_time_s < y.at_time_s;
  });
  std::map<std::string, size_t> by_lap, by_time;  // target -> a change that moves it
  for (size_t i = 0; i < world.changes.size(); ++i) {
    const WorldChange& change = world.changes[i];
    auto& mine = change.after_lap != 0 ? by_lap : by_time;
    const auto& theirs = change.after_lap != 0 ? by_time : by_lap;
    std::vector<std::string> targets;
    for (const ObjectMove& move : change.objects) targets.push_back("object '" + move.name + "'");
    for (const LandmarkMove& move : change.landmarks) {
      targets.push_back("landmark " + std::to_string(move.id));
    }
    const RandomDisplacement& random = change.random_landmarks;
    if (random.count_max > 0) {  // any candidate may be drawn
      if (random.candidate_ids.empty()) {
        for (const Landmark& l : world.landmarks) targets.push_back("landmark " + std::to_string(l.id));
      } else {
        for (int id : random.candidate_ids) targets.push_back("landmark " + std::to_string(id));
      }
    }
    for (const std::string& target : targets) {
      const auto other = theirs.find(target);
      if (other != theirs.end()) {
        fail("changes[" + std::to_string(i) + "] and changes[" + std::to_string(other->second) +
             "] both change " + target + ", one after a lap and one at a time: their order " +
             "depends on the run; trigger both by lap or both by time");
      }
      mine.emplace(target, i);
    }
  }
  return order;
}

void validate(const World& world) {
  checkRange("laps", world.laps, 1, 1000000);
  positive("max_duration_s", world.max_duration_s);
  checkRobot(world.robot);
  checkOdometry(world.odometry, world.robot.drive);
  checkObjectsAndLandmarks(world);
  checkWaypoints(world);
  const double control_rate_hz = world.robot.control_rate_hz;
  checkRate("odometry.rate_hz", world.odometry.rate_hz, control_rate_hz);
  checkLaser(world.sensors.laser, control_rate_hz);
  checkRing(world.sensors.sonar, "sensors.sonar", control_rate_hz);
  checkRangeBearing(world.sensors.range_bearing, control_rate_hz);
  checkRing(world.sensors.infrared, "sensors.infrared", control_rate_hz);
  for (size_t i = 0; i < world.changes.size(); ++i) {
    checkChange(world, world.changes[i], "changes[" + std::to_string(i) + "]");
  }
  checkChangeSequence(world);
}

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

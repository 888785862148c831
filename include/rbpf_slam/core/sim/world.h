#pragma once
// A simulated world: walls and furniture, point landmarks, a route, the robot that drives
// it, its odometry errors, its sensors and the changes made to the world while it drives.
// Field names match the keys of the world YAML format (docs/worlds.md) so that validation
// messages name the key a user has to fix.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {
namespace sim {

enum class DriveType { kDiffDrive, kBicycle };
enum class ControllerType { kPurePursuit, kTurnThenDrive };
enum class ShapeType { kPolyline, kPolygon };

/// The robot's kinematics and the waypoint-following controller that steers it.
struct RobotConfig {
  DriveType drive = DriveType::kDiffDrive;
  ControllerType controller = ControllerType::kPurePursuit;
  double radius_m = 0.2;                 // footprint, for the waypoint clearance checks
  double wheelbase_m = 0.33;             // diff drive: wheel separation; bicycle: axle distance
  double speed_mps = 0.3;                // cruise speed
  double max_turn_rate_deg_s = 90.0;     // diff drive only
  double max_steering_deg = 30.0;        // bicycle only
  double max_steering_rate_deg_s = 0.0;  // bicycle only; 0 = unlimited
  double control_rate_hz = 20.0;         // integration and control step
  double lookahead_m = 0.5;              // pure pursuit carrot distance
  double waypoint_tolerance_m = 0.2;     // a waypoint closer than this is reached
};

/// How the reported odometry departs from the true motion.
struct OdometryConfig {
  double rate_hz = 10.0;  // odometry messages per second (plus one at every sensor reading)
  // Random error of each odometry increment, as a sigma proportional to its size.
  double translation_noise_m_per_m = 0.0;
  double rotation_noise_rad_per_rad = 0.0;
  double rotation_noise_rad_per_m = 0.0;  // heading drift per metre driven
  // Systematic error: reported = (1 + bias) * true.
  double translation_scale_bias = 0.0;
  double rotation_scale_bias = 0.0;
  // Control noise (Havangi et al.): odometry dead-reckons controls perturbed at every
  // control step by these sigmas.
  double speed_noise_mps = 0.0;
  double steering_noise_deg = 0.0;  // bicycle only
};

/// A planar laser range finder.
struct LaserConfig {
  bool enabled = false;
  double rate_hz = 4.0;
  double fov_deg = 180.0;
  double resolution_deg = 1.0;
  double min_range_m = 0.02;
  double max_range_m = 8.2;
  double range_noise_m = 0.01;
  double mount_x_m = 0.0;  // sensor in the base frame
  double mount_y_m = 0.0;
  double mount_yaw_deg = 0.0;
};

/// A ring of cone sensors (sonar or infrared): each reports the nearest echo in its cone.
struct RingSensorConfig {
  bool enabled = false;
  double rate_hz = 4.0;
  int count = 12;                  // evenly spaced over 360 deg, unless angles_deg is given
  std::vector<double> angles_deg;  // explicit transducer directions (overrides count)
  double ring_radius_m = 0.2;      // transducers sit on this circle, facing outwards
  double cone_deg = 30.0;          // full opening angle
  double min_range_m = 0.1;
  double max_range_m = 5.0;  // a reading of max_range_m means "no echo"
  double range_noise_m = 0.02;
  double critical_angle_deg = 25.0;  // incidence beyond which a surface echo is lost
  bool corner_echoes = true;         // object vertices echo at any incidence
  double ray_spacing_deg = 1.0;      // ray casting resolution inside the cone
};

/// Default sonar ring: 12 transducers, 30 deg cones, 5 m, echoes lost beyond 25 deg incidence.
RingSensorConfig defaultSonarConfig();
/// Default infrared ring: 8 e-puck-like proximity sensors, 7 cm.
RingSensorConfig defaultInfraredConfig();

/// A range-bearing point landmark sensor in the base frame.
struct RangeBearingConfig {
  bool enabled = false;
  double rate_hz = 5.0;
  double min_range_m = 0.0;
  double max_range_m = 20.0;
  double fov_deg = 180.0;  // centred on the robot's heading
  double range_noise_m = 0.2;
  double bearing_noise_deg = 2.0;
  bool known_ids = false;  // report landmark ids, else -1
  bool occlusion = true;   // walls hide landmarks behind them
  double detection_probability = 1.0;
};

/// Every sensor of the robot; each is optional and has its own rate.
struct SensorsConfig {
  LaserConfig laser;
  RingSensorConfig sonar = defaultSonarConfig();
  RangeBearingConfig range_bearing;
  RingSensorConfig infrared = defaultInfraredConfig();
};

/// A named wall or piece of furniture: an open or looped polyline, or a solid polygon.
struct WorldObject {
  std::string name;
  ShapeType shape = ShapeType::kPolyline;
  std::vector<Eigen::Vector2d> points;
  bool closed = false;  // polyline: add the closing segment; polygon: close it implicitly
};

/// A point landmark; a positive radius makes it a post that also blocks laser and sonar.
struct Landmark {
  int id = 0;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double radius_m = 0.0;
};

/// Moves or removes one object: new points, or a translation and a rotation about its centroid.
struct ObjectMove {
  std::string name;
  std::vector<Eigen::Vector2d> points;  // when not empty, replaces the object's points
  Eigen::Vector2d translate_m = Eigen::Vector2d::Zero();
  double rotate_deg = 0.0;
  bool remove = false;
};

/// Moves or removes one landmark.
struct LandmarkMove {
  int id = 0;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  bool remove = false;
};

/// Displaces a random number of randomly chosen landmarks by Gaussian offsets.
struct RandomDisplacement {
  int count_min = 0;
  int count_max = 0;
  double sigma_m = 0.0;
  std::vector<int> candidate_ids;  // empty: every landmark
};

/// Changes applied once, after a lap is completed or at a time.
struct WorldChange {
  int after_lap = 0;        // >= 1: when this lap is completed
  double at_time_s = -1.0;  // >= 0: at this simulated time (exactly one trigger is set)
  std::vector<ObjectMove> objects;
  std::vector<LandmarkMove> landmarks;
  RandomDisplacement random_landmarks;
};

/// A complete simulation scenario.
struct World {
  std::string name;
  RobotConfig robot;
  OdometryConfig odometry;
  std::vector<WorldObject> objects;
  std::vector<Landmark> landmarks;
  std::vector<Eigen::Vector2d> waypoints;  // a lap visits them in order and returns to the first
  int laps = 1;
  double max_duration_s = 7200.0;  // safety stop if the route is never completed
  SensorsConfig sensors;
  std::vector<WorldChange> changes;
};

/// A wall piece, with the index of the object it belongs to.
struct Segment {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  int object = -1;
};

/// The segments of one object (polygons and looped polylines include the closing segment).
std::vector<Segment> objectSegments(const WorldObject& object, int object_index);
/// True when the polygon is closed explicitly (flag) or implicitly (first == last).
bool isClosed(const WorldObject& object);
/// True when p lies inside the closed outline of object (even-odd rule).
bool insideOutline(const WorldObject& object, const Eigen::Vector2d& p);
/// Distance from p to the segment ab.
double distanceToSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                         const Eigen::Vector2d& b);
/// The object after a move (rotation about the centroid of its distinct points, then shift).
WorldObject movedObject(const WorldObject& object, const ObjectMove& move);
/// Transducer poses in the base frame for a ring configuration.
std::vector<Pose2> ringPoses(const RingSensorConfig& ring);

/// The indices of world.changes in the order they happen: those after a lap by lap, those at a
/// time by time, equal triggers in list order (lap changes listed first: validate() refuses a
/// lap and a time change of one object or landmark, whose order would depend on the run). The
/// simulator applies the changes due at a step in this order, and validate() replays them so.
/// Throws std::invalid_argument for such a shared target.
std::vector<size_t> changeOrder(const World& world);

/// Throws std::invalid_argument naming the first offending field (e.g. "laps = 0 ...").
void validate(const World& world);

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

#include "rbpf_slam/io/world_yaml.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <type_traits>
#include <vector>

#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/yaml_section.h"

namespace rbpf_slam {
namespace io {
namespace {

using core::sim::World;

std::string describe(const YAML::Node& node) {
  if (node.IsScalar()) return node.Scalar();
  YAML::Emitter out;
  out << YAML::Flow << node;
  return out.c_str();
}

/// One YAML map being read: typed reads by key, and a check that no other key is present.
class MapReader {
 public:
  /// An absent or empty node reads as an empty map.
  MapReader(const YAML::Node& node, const std::string& source, std::string path)
      : node_(asMap(node)), source_(source), path_(std::move(path)) {
    if (!node_.IsMap()) fail(path_ + " must be a map of key: value");
  }

  const std::string& path() const { return path_; }
  std::string field(const std::string& key) const {
    return path_.empty() ? key : path_ + "." + key;
  }
  [[noreturn]] void fail(const std::string& message) const {
    throw WorldFileError(source_ + ": " + message);
  }
  bool has(const std::string& key) { return child(key).IsDefined(); }
  /// The value under key (undefined when absent); marks key as known.
  YAML::Node child(const std::string& key) {
    known_.insert(key);
    const YAML::Node& map = node_;  // const lookup never inserts the key
    return map[key];
  }

  template <typename T>
  void read(const std::string& key, T* value) {
    const YAML::Node n = child(key);
    if (n.IsDefined()) *value = convert<T>(n, field(key));
  }

  template <typename T>
  T convert(const YAML::Node& n, const std::string& where) const {
    if constexpr (std::is_same_v<T, int>) {
      // Decimal only: yaml-cpp reads 010 as octal 8 and 0x10 as 16 (laps: 010 drove 8 laps).
      bool negative = false;
      unsigned long long magnitude = 0;
      if (!decimalInteger(n, &negative, &magnitude) ||
          magnitude > static_cast<unsigned long long>(std::numeric_limits<int>::max())) {
        fail(where + " = " + describe(n) +
             " is not an integer (decimal digits, no leading zero, within int)");
      }
      return negative ? -static_cast<int>(magnitude) : static_cast<int>(magnitude);
    } else {
      try {
        if (n.IsScalar()) return n.as<T>();
      } catch (const YAML::Exception&) {
      }
      fail(where + " = " + describe(n) + " is not " + typeName(T()));
    }
  }

  void readEnum(const std::string& key, const std::vector<std::string>& names, int* value) {
    if (!has(key)) return;
    std::string text;
    read(key, &text);
    for (size_t i = 0; i < names.size(); ++i) {
      if (names[i] == text) {
        *value = static_cast<int>(i);
        return;
      }
    }
    std::string list;
    for (const auto& name : names) list += (list.empty() ? "" : ", ") + name;
    fail(field(key) + " = '" + text + "' is not one of: " + list);
  }

  Eigen::Vector2d point(const YAML::Node& n, const std::string& where) const {
    if (!n.IsSequence() || n.size() != 2) fail(where + " = " + describe(n) + " is not [x, y]");
    return Eigen::Vector2d(convert<double>(n[0], where + "[0]"),
                           convert<double>(n[1], where + "[1]"));
  }
  void readPoint(const std::string& key, Eigen::Vector2d* value) {
    const YAML::Node n = child(key);
    if (n.IsDefined()) *value = point(n, field(key));
  }
  void readPoints(const std::string& key, std::vector<Eigen::Vector2d>* value) {
    const YAML::Node n = child(key);
    if (!n.IsDefined()) return;
    if (!n.IsSequence()) fail(field(key) + " must be a list of [x, y] points");
    value->clear();
    for (size_t i = 0; i < n.size(); ++i) {
      value->push_back(point(n[i], field(key) + "[" + std::to_string(i) + "]"));
    }
  }
  template <typename T>
  void readList(const std::string& key, std::vector<T>* value) {
    const YAML::Node n = child(key);
    if (!n.IsDefined()) return;
    if (!n.IsSequence()) fail(field(key) + " must be a list");
    value->clear();
    for (size_t i = 0; i < n.size(); ++i) {
      value->push_back(convert<T>(n[i], field(key) + "[" + std::to_string(i) + "]"));
    }
  }
  /// The items of a list of maps under key, each with its own path "key[i]".
  std::vector<MapReader> items(const std::string& key) {
    const YAML::Node n = child(key);
    std::vector<MapReader> result;
    if (!n.IsDefined() || n.IsNull()) return result;
    if (!n.IsSequence()) fail(field(key) + " must be a list");
    for (size_t i = 0; i < n.size(); ++i) {
      const std::string where = field(key) + "[" + std::to_string(i) + "]";
      if (!n[i].IsMap()) fail(where + " must be a map of key: value");
      result.emplace_back(n[i], source_, where);
    }
    return result;
  }
  MapReader section(const std::string& key) { return MapReader(child(key), source_, field(key)); }

  /// Throws when the map holds a key that was never asked for.
  void finish() const {
    std::set<std::string> seen;
    for (const auto& item : node_) {
      if (!item.first.IsScalar())
        fail((path_.empty() ? "top level" : path_) + ": a key that is not a plain name");
      const std::string key = item.first.Scalar();
      // yaml-cpp reads the first of two copies of a key: an edit of the second would be lost.
      if (!seen.insert(key).second) fail(field(key) + " appears more than once");
      if (known_.count(key)) continue;
      std::string list;
      for (const auto& k : known_) list += (list.empty() ? "" : ", ") + k;
      fail(field(key) + " is not a known key (known here: " + list + ")");
    }
  }

 private:
  // yaml-cpp cannot assign to a missing (zombie) node, hence a fresh map here.
  static YAML::Node asMap(const YAML::Node& node) {
    if (!node.IsDefined() || node.IsNull()) return YAML::Node(YAML::NodeType::Map);
    return node;
  }
  static std::string typeName(double) { return "a number"; }
  static std::string typeName(int) { return "an integer"; }
  static std::string typeName(bool) { return "true or false"; }
  static std::string typeName(const std::string&) { return "a string"; }

  YAML::Node node_;
  std::string source_;
  std::string path_;
  std::set<std::string> known_;
};

void readRobot(MapReader reader, core::sim::RobotConfig* robot) {
  int drive = static_cast<int>(robot->drive);
  reader.readEnum("drive", {"diff_drive", "bicycle"}, &drive);
  robot->drive = static_cast<core::sim::DriveType>(drive);
  int controller = static_cast<int>(robot->controller);
  reader.readEnum("controller", {"pure_pursuit", "turn_then_drive"}, &controller);
  robot->controller = static_cast<core::sim::ControllerType>(controller);
  reader.read("radius_m", &robot->radius_m);
  reader.read("wheelbase_m", &robot->wheelbase_m);
  reader.read("speed_mps", &robot->speed_mps);
  reader.read("max_turn_rate_deg_s", &robot->max_turn_rate_deg_s);
  reader.read("max_steering_deg", &robot->max_steering_deg);
  reader.read("max_steering_rate_deg_s", &robot->max_steering_rate_deg_s);
  reader.read("control_rate_hz", &robot->control_rate_hz);
  reader.read("lookahead_m", &robot->lookahead_m);
  reader.read("waypoint_tolerance_m", &robot->waypoint_tolerance_m);
  reader.finish();
}

void readOdometry(MapReader reader, core::sim::OdometryConfig* odometry) {
  reader.read("rate_hz", &odometry->rate_hz);
  reader.read("translation_noise_m_per_m", &odometry->translation_noise_m_per_m);
  reader.read("rotation_noise_rad_per_rad", &odometry->rotation_noise_rad_per_rad);
  reader.read("rotation_noise_rad_per_m", &odometry->rotation_noise_rad_per_m);
  reader.read("translation_scale_bias", &odometry->translation_scale_bias);
  reader.read("rotation_scale_bias", &odometry->rotation_scale_bias);
  reader.read("speed_noise_mps", &odometry->speed_noise_mps);
  reader.read("steering_noise_deg", &odometry->steering_noise_deg);
  reader.finish();
}

/// A sensor is enabled by its section's presence, unless it says enabled: false.
bool readEnabled(MapReader& reader, const YAML::Node& section) {
  bool enabled = section.IsDefined();
  reader.read("enabled", &enabled);
  return enabled;
}

void readLaser(const YAML::Node& node, MapReader reader, core::sim::LaserConfig* laser) {
  laser->enabled = readEnabled(reader, node);
  reader.read("rate_hz", &laser->rate_hz);
  reader.read("fov_deg", &laser->fov_deg);
  reader.read("resolution_deg", &laser->resolution_deg);
  reader.read("min_range_m", &laser->min_range_m);
  reader.read("max_range_m", &laser->max_range_m);
  reader.read("range_noise_m", &laser->range_noise_m);
  reader.read("mount_x_m", &laser->mount_x_m);
  reader.read("mount_y_m", &laser->mount_y_m);
  reader.read("mount_yaw_deg", &laser->mount_yaw_deg);
  reader.finish();
}

void readRing(const YAML::Node& node, MapReader reader, core::sim::RingSensorConfig* ring) {
  ring->enabled = readEnabled(reader, node);
  reader.read("rate_hz", &ring->rate_hz);
  // An explicit count replaces the default directions (which override the count).
  if (reader.has("count") && !reader.has("angles_deg")) ring->angles_deg.clear();
  reader.read("count", &ring->count);
  reader.readList("angles_deg", &ring->angles_deg);
  if (reader.has("angles_deg") && ring->angles_deg.empty()) {
    reader.fail(reader.field("angles_deg") + " is empty: give the transducers' directions, or "
                "count alone for an even ring");
  }
  reader.read("ring_radius_m", &ring->ring_radius_m);
  reader.read("cone_deg", &ring->cone_deg);
  reader.read("min_range_m", &ring->min_range_m);
  reader.read("max_range_m", &ring->max_range_m);
  reader.read("range_noise_m", &ring->range_noise_m);
  reader.read("critical_angle_deg", &ring->critical_angle_deg);
  reader.read("corner_echoes", &ring->corner_echoes);
  reader.read("ray_spacing_deg", &ring->ray_spacing_deg);
  reader.finish();
}

void readRangeBearing(const YAML::Node& node, MapReader reader,
                      core::sim::RangeBearingConfig* sensor) {
  sensor->enabled = readEnabled(reader, node);
  reader.read("rate_hz", &sensor->rate_hz);
  reader.read("min_range_m", &sensor->min_range_m);
  reader.read("max_range_m", &sensor->max_range_m);
  reader.read("fov_deg", &sensor->fov_deg);
  reader.read("range_noise_m", &sensor->range_noise_m);
  reader.read("bearing_noise_deg", &sensor->bearing_noise_deg);
  reader.read("known_ids", &sensor->known_ids);
  reader.read("occlusion", &sensor->occlusion);
  reader.read("detection_probability", &sensor->detection_probability);
  reader.finish();
}

void readSensors(MapReader reader, core::sim::SensorsConfig* sensors) {
  readLaser(reader.child("laser"), reader.section("laser"), &sensors->laser);
  readRing(reader.child("sonar"), reader.section("sonar"), &sensors->sonar);
  readRangeBearing(reader.child("range_bearing"), reader.section("range_bearing"),
                   &sensors->range_bearing);
  readRing(reader.child("infrared"), reader.section("infrared"), &sensors->infrared);
  reader.finish();
}

core::sim::WorldObject readObject(MapReader& reader) {
  core::sim::WorldObject object;
  reader.read("name", &object.name);
  const bool polyline = reader.has("polyline"), polygon = reader.has("polygon");
  if (polyline == polygon) {
    reader.fail(reader.field("polyline") + " or " + reader.field("polygon") +
                ": give exactly one of them");
  }
  object.shape = polygon ? core::sim::ShapeType::kPolygon : core::sim::ShapeType::kPolyline;
  reader.readPoints(polygon ? "polygon" : "polyline", &object.points);
  reader.read("closed", &object.closed);
  reader.finish();
  return object;
}

core::sim::Landmark readLandmark(MapReader& reader) {
  core::sim::Landmark landmark;
  if (!reader.has("id") || !reader.has("x_m") || !reader.has("y_m")) {
    reader.fail(reader.field("id, x_m, y_m") + " are required");
  }
  reader.read("id", &landmark.id);
  reader.read("x_m", &landmark.position.x());
  reader.read("y_m", &landmark.position.y());
  reader.read("radius_m", &landmark.radius_m);
  reader.finish();
  return landmark;
}

core::sim::WorldChange readChange(MapReader& reader) {
  core::sim::WorldChange change;
  reader.read("after_lap", &change.after_lap);
  reader.read("at_time_s", &change.at_time_s);
  for (MapReader& item : reader.items("objects")) {
    core::sim::ObjectMove move;
    item.read("name", &move.name);
    item.readPoints("points", &move.points);
    item.readPoint("translate_m", &move.translate_m);
    item.read("rotate_deg", &move.rotate_deg);
    item.read("remove", &move.remove);
    if (item.has("points") && move.points.empty()) {
      item.fail(item.field("points") + " is empty: give the new outline, or remove: true");
    }
    const bool rigid = item.has("translate_m") || item.has("rotate_deg");
    if (move.remove && (rigid || item.has("points"))) {
      item.fail(item.field("remove") + ": true excludes points, translate_m and rotate_deg");
    }
    if (item.has("points") && rigid) {
      item.fail(item.field("points") + " replaces the outline: it excludes translate_m and "
                "rotate_deg, which would be ignored");
    }
    if (!move.remove && !item.has("points") && !rigid) {
      item.fail(item.path() + ": '" + move.name + "' changes nothing: give remove: true, points, or "
                "translate_m and/or rotate_deg");
    }
    item.finish();
    change.objects.push_back(move);
  }
  for (MapReader& item : reader.items("landmarks")) {
    core::sim::LandmarkMove move;
    item.read("id", &move.id);
    item.read("remove", &move.remove);
    if (!move.remove && (!item.has("x_m") || !item.has("y_m"))) {
      item.fail(item.field("x_m, y_m") + " are required unless remove: true");
    }
    item.read("x_m", &move.position.x());
    item.read("y_m", &move.position.y());
    item.finish();
    change.landmarks.push_back(move);
  }
  MapReader random = reader.section("random_landmarks");
  core::sim::RandomDisplacement& displacement = change.random_landmarks;
  if (random.has("count") && (random.has("count_min") || random.has("count_max"))) {
    random.fail(random.field("count") + " excludes count_min and count_max");
  }
  random.read("count", &displacement.count_min);
  random.read("count", &displacement.count_max);
  random.read("count_min", &displacement.count_min);
  random.read("count_max", &displacement.count_max);
  random.read("sigma_m", &displacement.sigma_m);
  random.readList("candidate_ids", &displacement.candidate_ids);
  random.finish();
  reader.finish();
  return change;
}

World readWorld(const YAML::Node& root, const std::string& source) {
  if (!root.IsMap()) throw WorldFileError(source + ": the top level must be a map of key: value");
  // Every read below asks for each key the format knows; finish() rejects the rest.
  MapReader reader(root, source, "");
  World world;
  std::string description;
  reader.read("name", &world.name);
  reader.read("description", &description);
  reader.read("laps", &world.laps);
  reader.read("max_duration_s", &world.max_duration_s);
  readRobot(reader.section("robot"), &world.robot);
  readOdometry(reader.section("odometry"), &world.odometry);
  for (MapReader& item : reader.items("objects")) world.objects.push_back(readObject(item));
  for (MapReader& item : reader.items("landmarks")) world.landmarks.push_back(readLandmark(item));
  reader.readPoints("waypoints", &world.waypoints);
  readSensors(reader.section("sensors"), &world.sensors);
  for (MapReader& item : reader.items("changes")) world.changes.push_back(readChange(item));
  reader.finish();
  try {
    core::sim::validate(world);
  } catch (const std::invalid_argument& error) {
    throw WorldFileError(source + ": " + error.what());
  }
  return world;
}

}  // namespace

World parseWorld(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& error) {
    throw WorldFileError(source + ":" + std::to_string(error.mark.line + 1) + ":" +
                         std::to_string(error.mark.column + 1) +
                         ": YAML syntax error: " + error.msg);
  }
  return readWorld(root, source);
}

World loadWorld(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    throw WorldFileError(path + ": is a directory, not a world file");
  }
  if (isDevice(path)) throw WorldFileError(path + ": is a device, not a world file");
  std::ifstream file(path);
  if (!file) throw WorldFileError(path + ": cannot be opened");
  std::stringstream text;
  text << file.rdbuf();
  return parseWorld(text.str(), path);
}

}  // namespace io
}  // namespace rbpf_slam

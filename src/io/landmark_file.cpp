#include "rbpf_slam/io/landmark_file.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/io/grid_map_file.h"
#include "rbpf_slam/io/plausibility.h"

namespace rbpf_slam {
namespace io {
namespace {

double readNumber(const YAML::Node& node, const std::string& key, const std::string& where) {
  if (!node[key]) throw std::runtime_error(where + ": '" + key + "' is missing");
  double value = 0.0;
  try {
    value = node[key].as<double>();
  } catch (const YAML::Exception&) {
    throw std::runtime_error(where + ": '" + key + "' is not a number");
  }
  if (!std::isfinite(value)) throw std::runtime_error(where + ": '" + key + "' is not finite");
  return value;
}

Eigen::Vector2d readPair(const YAML::Node& node, const std::string& key, const std::string& where) {
  const YAML::Node list = node[key];
  if (!list || !list.IsSequence() || list.size() != 2) {
    throw std::runtime_error(where + ": '" + key + "' must be a list of 2 numbers");
  }
  Eigen::Vector2d v;
  for (int i = 0; i < 2; ++i) {
    try {
      v[i] = list[i].as<double>();
    } catch (const YAML::Exception&) {
      throw std::runtime_error(where + ": '" + key + "' must be a list of 2 numbers");
    }
  }
  if (!v.allFinite()) throw std::runtime_error(where + ": '" + key + "' is not finite");
  return v;
}

/// readNumber() that must be a whole number in [min, 1e9]; else `why` after where.
int readInteger(const YAML::Node& node, const std::string& key, const std::string& where,
                double min, const std::string& why) {
  const double value = readNumber(node, key, where);
  if (value != std::floor(value) || value < min || value > 1e9) {
    throw std::runtime_error(where + ": " + why);
  }
  return static_cast<int>(value);
}

/// Refuses a key that is not in `allowed` or is written twice (yaml-cpp keeps the first of two
/// and says nothing): a misspelt key (`covarience`) or a second `x` would be silently ignored.
void checkKeys(const YAML::Node& map, const std::set<std::string>& allowed,
               const std::string& where) {
  std::set<std::string> seen;
  for (const auto& item : map) {
    const std::string key = item.first.IsScalar() ? item.first.Scalar() : "(not a name)";
    if (!allowed.count(key)) {
      std::string names;
      for (const std::string& a : allowed) names += (names.empty() ? "" : ", ") + a;
      throw std::runtime_error(where + ": unknown key '" + key + "' (known: " + names + ")");
    }
    if (!seen.insert(key).second) throw std::runtime_error(where + ": '" + key + "' twice");
  }
}

core::LandmarkEstimate readLandmark(const YAML::Node& node, const std::string& where) {
  if (!node.IsMap()) throw std::runtime_error(where + ": not a map of keys (id, type, ...)");
  core::LandmarkEstimate l;
  l.id = readInteger(node, "id", where, -1e9, "'id' must be an integer");
  const std::string type = node["type"] ? node["type"].as<std::string>() : "";
  if (type == "line") {
    checkKeys(node, {"id", "type", "rho", "theta", "start", "end", "covariance", "observations"},
              where);
    l.type = core::LandmarkType::kLine;
    l.mean << readNumber(node, "rho", where), readNumber(node, "theta", where);
    l.start = readPair(node, "start", where);
    l.end = readPair(node, "end", where);
  } else if (type == "point") {
    checkKeys(node, {"id", "type", "x", "y", "covariance", "observations"}, where);
    l.mean << readNumber(node, "x", where), readNumber(node, "y", where);
    l.start = l.end = l.mean;
  } else if (type.empty() && node["x_m"] && node["y_m"]) {
    throw std::runtime_error(where +
                             ": surveyed positions (x_m, y_m) of a ground-truth file "
                             "(OUT.landmarks.yaml of mrclam_to_bag or simulate), not a map; a "
                             "map is written by offline_slam (landmarks.yaml) or ~save_map");
  } else {
    throw std::runtime_error(where + ": type = '" + type + "' is not point or line");
  }
  // A map's coordinates are metres from its origin: beyond a thousand kilometres they are
  // corrupt (a line from -1e300 to 1e300 made the map index file it in 2^29 cells).
  for (const Eigen::Vector2d& v : {l.mean, l.start, l.end}) {
    if (v.cwiseAbs().maxCoeff() > kMaxPlausibleCoordinateM) {
      throw std::runtime_error(where + ": a coordinate beyond " +
                               std::to_string(static_cast<long>(kMaxPlausibleCoordinateM)) +
                               " m (corrupt data)");
    }
  }
  const YAML::Node c = node["covariance"];
  if (!c || !c.IsSequence() || c.size() != 4) {
    throw std::runtime_error(where + ": 'covariance' must be a list of 4 numbers (row-major 2x2)");
  }
  for (int k = 0; k < 4; ++k) l.covariance(k / 2, k % 2) = c[k].as<double>();
  const bool symmetric = std::fabs(l.covariance(0, 1) - l.covariance(1, 0)) <=
                         1e-9 * (1.0 + l.covariance.cwiseAbs().maxCoeff());
  if (!l.covariance.allFinite() || !symmetric || l.covariance(0, 0) <= 0.0 ||
      l.covariance.determinant() <= 0.0) {
    throw std::runtime_error(where + ": covariance is not symmetric positive definite");
  }
  l.observations = node["observations"] ? readInteger(node, "observations", where, 0.0,
                                                      "'observations' must be an integer >= 0")
                                         : 1;
  if (l.type == core::LandmarkType::kLine) {
    // Normal form, as every filter keeps its lines (rho >= 0, theta in [-pi, pi)): a line
    // written with rho < 0 (by hand, or another tool) is the same line with the normal turned
    // by pi, and (rho, theta) -> (-rho, theta + pi) negates their covariance. Kept as given,
    // the EKF held it until its first correction and FastSLAM's association missed it.
    if (l.mean.x() < 0.0) l.covariance(0, 1) = l.covariance(1, 0) = -l.covariance(0, 1);
    core::normalizeLine(l.mean.x(), l.mean.y());
  }
  return l;
}

}  // namespace

void writeLandmarksYaml(const std::string& path,
                        const std::vector<core::LandmarkEstimate>& landmarks) {
  std::ofstream yaml(path);
  if (!yaml) throw std::runtime_error(path + ": cannot be written");
  // Enough digits that every number reads back as written (a covariance whose determinant is
  // tiny must not round to a singular one); count lets a reader tell a file cut short.
  yaml << std::setprecision(std::numeric_limits<double>::max_digits10)
       << "# rbpf_slam landmark map (map frame): points x, y in m; "
       << "lines rho (m), theta (rad) with the observed extent start/end\n"
       << "count: " << landmarks.size() << "\nlandmarks:\n";
  for (const auto& l : landmarks) {
    const bool line = l.type == core::LandmarkType::kLine;
    yaml << "  - {id: " << l.id << ", type: " << (line ? "line" : "point") << ", "
         << (line ? "rho: " : "x: ") << l.mean.x() << ", " << (line ? "theta: " : "y: ")
         << l.mean.y() << ", covariance: [" << l.covariance(0, 0) << ", " << l.covariance(0, 1)
         << ", " << l.covariance(1, 0) << ", " << l.covariance(1, 1) << "]";
    if (line) {
      yaml << ", start: [" << l.start.x() << ", " << l.start.y() << "], end: [" << l.end.x()
           << ", " << l.end.y() << "]";
    }
    yaml << ", observations: " << l.observations << "}\n";
  }
  if (!yaml) throw std::runtime_error(path + ": write failed");
}

std::vector<core::LandmarkEstimate> loadLandmarksYaml(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw std::runtime_error(path + ": cannot be read");
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": not YAML: " + e.what());
  } catch (const std::exception& e) {  // a directory, an unreadable file
    throw std::runtime_error(path + ": cannot be read: " + e.what());
  }
  if (!root.IsMap()) {  // an empty file, a bare list, a single value: not a map file
    throw std::runtime_error(path + ": 'landmarks' (a list) is missing (the file is " +
                             (root.IsNull() ? "empty" : "not a map of keys") + ")");
  }
  const YAML::Node list = root["landmarks"];
  if (!list || !(list.IsSequence() || list.IsNull())) {
    throw std::runtime_error(path + ": 'landmarks' (a list) is missing");
  }
  std::vector<core::LandmarkEstimate> out;
  std::map<int, size_t> index_of_id;
  for (size_t i = 0; list.IsSequence() && i < list.size(); ++i) {
    const std::string where = path + ": landmarks[" + std::to_string(i) + "]";
    try {
      out.push_back(readLandmark(list[i], where));
    } catch (const YAML::Exception& e) {
      throw std::runtime_error(where + ": " + e.what());
    }
    const auto [first, fresh] = index_of_id.emplace(out.back().id, i);
    if (!fresh) {
      throw std::runtime_error(where + ": id " + std::to_string(out.back().id) +
                               " is landmarks[" + std::to_string(first->second) + "]'s too");
    }
  }
  // After the entries: a ground-truth file (world, seed, ... at the top) is named as such there.
  checkKeys(root, {"count", "landmarks"}, path);
  if (root["count"]) {  // written by writeLandmarksYaml: a file cut short has fewer
    long long count = -1;
    try {
      count = root["count"].as<long long>();
    } catch (const YAML::Exception&) {
    }
    if (count != static_cast<long long>(out.size())) {
      throw std::runtime_error(path + ": count = " + root["count"].Scalar() + ", but " +
                               std::to_string(out.size()) +
                               " landmarks are listed (a file cut short?)");
    }
  }
  return out;
}


std::vector<std::string> writeLandmarkGrid(const std::string& prefix,
                                           const std::vector<core::LandmarkEstimate>& landmarks,
                                           const GridMapOptions& options) {
  const core::GridMapData grid = core::rasterizeLandmarks(
      landmarks, options.resolution_m, options.margin_m, options.point_radius_m);
  return writeGridMap(prefix, grid, "rbpf_slam landmark map");
}

}  // namespace io
}  // namespace rbpf_slam

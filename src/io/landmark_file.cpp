#include "rbpf_slam/io/landmark_file.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <stdexcept>

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

core::LandmarkEstimate readLandmark(const YAML::Node& node, const std::string& where) {
  core::LandmarkEstimate l;
  const double id = readNumber(node, "id", where);
  if (id != std::floor(id) || std::fabs(id) > 1e9) {
    throw std::runtime_error(where + ": 'id' must be an integer");
  }
  l.id = static_cast<int>(id);
  const std::string type = node["type"] ? node["type"].as<std::string>() : "";
  if (type == "line") {
    l.type = core::LandmarkType::kLine;
    l.mean << readNumber(node, "rho", where), readNumber(node, "theta", where);
    l.start = readPair(node, "start", where);
    l.end = readPair(node, "end", where);
  } else if (type == "point") {
    l.mean << readNumber(node, "x", where), readNumber(node, "y", where);
    l.start = l.end = l.mean;
  } else {
    throw std::runtime_error(where + ": type = '" + type + "' is not point or line");
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
  l.observations = node["observations"] ? node["observations"].as<int>() : 1;
  return l;
}

}  // namespace

void writeLandmarksYaml(const std::string& path,
                        const std::vector<core::LandmarkEstimate>& landmarks) {
  std::ofstream yaml(path);
  if (!yaml) throw std::runtime_error(path + ": cannot be written");
  yaml << std::setprecision(9) << "# rbpf_slam landmark map (map frame): points x, y in m; "
       << "lines rho (m), theta (rad) with the observed extent start/end\nlandmarks:\n";
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
  }
  const YAML::Node list = root.IsMap() ? root["landmarks"] : YAML::Node();
  if (!list || !(list.IsSequence() || list.IsNull())) {
    throw std::runtime_error(path + ": 'landmarks' (a list) is missing");
  }
  std::vector<core::LandmarkEstimate> out;
  for (size_t i = 0; list.IsSequence() && i < list.size(); ++i) {
    const std::string where = path + ": landmarks[" + std::to_string(i) + "]";
    try {
      out.push_back(readLandmark(list[i], where));
    } catch (const YAML::Exception& e) {
      throw std::runtime_error(where + ": " + e.what());
    }
  }
  return out;
}


std::vector<std::string> writeLandmarkGrid(const std::string& prefix,
                                           const std::vector<core::LandmarkEstimate>& landmarks,
                                           const GridMapOptions& options) {
  if (!(options.resolution_m > 0.0)) throw std::invalid_argument("grid resolution must be > 0");
  double min_x = std::numeric_limits<double>::max(), min_y = min_x;
  double max_x = -min_x, max_y = -min_x;
  auto extend = [&](const Eigen::Vector2d& p) {
    min_x = std::min(min_x, p.x());
    min_y = std::min(min_y, p.y());
    max_x = std::max(max_x, p.x());
    max_y = std::max(max_y, p.y());
  };
  for (const auto& l : landmarks) {
    extend(l.start);
    extend(l.end);
  }
  if (landmarks.empty()) min_x = min_y = max_x = max_y = 0.0;
  min_x -= options.margin_m;
  min_y -= options.margin_m;
  max_x += options.margin_m;
  max_y += options.margin_m;
  const int width = static_cast<int>(std::ceil((max_x - min_x) / options.resolution_m));
  const int height = static_cast<int>(std::ceil((max_y - min_y) / options.resolution_m));
  if (static_cast<double>(width) * height > 2.5e8) {
    throw std::runtime_error("grid of " + std::to_string(width) + " x " + std::to_string(height) +
                             " cells is too large: raise the resolution");
  }
  std::vector<unsigned char> cells(static_cast<size_t>(width) * height, 205);
  auto mark = [&](const Eigen::Vector2d& p) {
    const int cx = static_cast<int>((p.x() - min_x) / options.resolution_m);
    const int cy = static_cast<int>((p.y() - min_y) / options.resolution_m);
    if (cx < 0 || cy < 0 || cx >= width || cy >= height) return;
    cells[static_cast<size_t>(height - 1 - cy) * width + cx] = 0;  // row 0 is the top (max y)
  };
  for (const auto& l : landmarks) {
    if (l.type == core::LandmarkType::kLine) {
      const double length = (l.end - l.start).norm();
      const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * length / options.resolution_m)));
      for (int i = 0; i <= steps; ++i) mark(l.start + (l.end - l.start) * (double(i) / steps));
    } else {
      const double r = options.point_radius_m;
      for (double dx = -r; dx <= r; dx += 0.5 * options.resolution_m) {
        for (double dy = -r; dy <= r; dy += 0.5 * options.resolution_m) {
          if (dx * dx + dy * dy <= r * r) mark(l.mean + Eigen::Vector2d(dx, dy));
        }
      }
    }
  }
  const std::string pgm_path = prefix + ".pgm", yaml_path = prefix + ".yaml";
  {
    std::ofstream pgm(pgm_path, std::ios::binary);
    if (!pgm) throw std::runtime_error(pgm_path + ": cannot be written");
    pgm << "P5\n# rbpf_slam landmark map\n" << width << " " << height << "\n255\n";
    pgm.write(reinterpret_cast<const char*>(cells.data()), static_cast<std::streamsize>(cells.size()));
    if (!pgm) throw std::runtime_error(pgm_path + ": write failed");
  }
  std::ofstream yaml(yaml_path);
  if (!yaml) throw std::runtime_error(yaml_path + ": cannot be written");
  const std::string image = pgm_path.substr(pgm_path.find_last_of('/') + 1);
  yaml << std::setprecision(9) << "image: " << image << "\nresolution: " << options.resolution_m
       << "\norigin: [" << min_x << ", " << min_y << ", 0.0]\nnegate: 0\n"
       << "occupied_thresh: 0.65\nfree_thresh: 0.196\n";
  if (!yaml) throw std::runtime_error(yaml_path + ": write failed");
  return {pgm_path, yaml_path};
}

}  // namespace io
}  // namespace rbpf_slam

#include "rbpf_slam/io/grid_map_file.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/io/map_image.h"

namespace rbpf_slam {
namespace io {
namespace {

uint8_t pgmValue(int8_t cell) {
  if (cell >= kOccupiedPercent) return 0;
  if (cell >= 0 && cell <= kFreePercent) return 254;
  return 205;
}

}  // namespace

std::vector<std::string> gridMapFiles(const std::string& prefix) {
  return {prefix + ".pgm", prefix + ".yaml"};
}

std::vector<std::string> writeGridMap(const std::string& prefix, const core::GridMapData& grid,
                                      const std::string& comment) {
  const int width = std::max(grid.width, 1), height = std::max(grid.height, 1);
  std::vector<uint8_t> pixels(static_cast<size_t>(width) * height, 205);
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      // PGM row 0 is the top of the map (the largest y).
      pixels[static_cast<size_t>(height - 1 - y) * width + x] = pgmValue(grid.at(x, y));
    }
  }
  const std::vector<std::string> files = gridMapFiles(prefix);
  const std::string& pgm_path = files[0];
  const std::string& yaml_path = files[1];
  {
    std::ofstream pgm(pgm_path, std::ios::binary);
    if (!pgm) throw std::runtime_error(pgm_path + ": cannot be written");
    pgm << "P5\n# " << comment << "\n" << width << " " << height << "\n255\n";
    pgm.write(reinterpret_cast<const char*>(pixels.data()),
              static_cast<std::streamsize>(pixels.size()));
    if (!pgm) throw std::runtime_error(pgm_path + ": write failed");
  }
  std::ofstream yaml(yaml_path);
  if (!yaml) throw std::runtime_error(yaml_path + ": cannot be written");
  // Double-quoted: a name with '#', ': ' or brackets would otherwise be cut or not parse.
  std::string image = "\"";
  for (const char c : pgm_path.substr(pgm_path.find_last_of('/') + 1)) {
    if (c == '"' || c == '\\') image += '\\';
    image += c;
  }
  image += '"';
  yaml << std::setprecision(9) << "image: " << image << "\nresolution: " << grid.resolution_m
       << "\norigin: [" << grid.origin_x_m << ", " << grid.origin_y_m << ", 0.0]\nnegate: 0\n"
       << "occupied_thresh: 0.65\nfree_thresh: 0.196\n";
  if (!yaml) throw std::runtime_error(yaml_path + ": write failed");
  return files;
}

core::GridMapData readGridMap(const std::string& yaml_path) {
  const std::filesystem::path given(yaml_path);
  std::string extension = given.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
  if (extension == ".pgm" || extension == ".png" || extension == ".bmp" || extension == ".jpg") {
    throw std::runtime_error(yaml_path +
                             ": an image; give the map's .yaml (image, resolution, "
                             "origin), which names it");
  }
  std::error_code error;
  if (std::filesystem::exists(given, error) && !std::filesystem::is_regular_file(given, error)) {
    throw std::runtime_error(yaml_path + ": cannot be read (not a file)");
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(yaml_path);
  } catch (const YAML::BadFile&) {
    throw std::runtime_error(yaml_path + ": cannot be read");
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(yaml_path + ": not YAML: " + e.what());
  }
  core::GridMapData grid;
  std::string image;
  int negate = 0;
  double occupied_thresh = 0.65, free_thresh = 0.196, yaw = 0.0;
  std::string mode = "trinary";
  try {
    if (!root.IsMap()) throw std::runtime_error(yaml_path + ": not a map_server map (not a map)");
    image = root["image"].as<std::string>();
    grid.resolution_m = root["resolution"].as<double>();
    const YAML::Node origin = root["origin"];
    if (!origin.IsSequence() || origin.size() < 2) {
      throw std::runtime_error(yaml_path + ": origin must be [x, y, yaw]");
    }
    grid.origin_x_m = origin[0].as<double>();
    grid.origin_y_m = origin[1].as<double>();
    yaw = origin.size() >= 3 ? origin[2].as<double>() : 0.0;
    if (root["negate"]) negate = root["negate"].as<int>();
    if (root["occupied_thresh"]) occupied_thresh = root["occupied_thresh"].as<double>();
    if (root["free_thresh"]) free_thresh = root["free_thresh"].as<double>();
    if (root["mode"]) mode = root["mode"].as<std::string>();
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(yaml_path + ": not a map_server map: " + e.what());
  }
  if (!(std::isfinite(grid.resolution_m) && grid.resolution_m > 0.0)) {
    throw std::runtime_error(yaml_path + ": resolution must be a finite number > 0");
  }
  if (!std::isfinite(grid.origin_x_m) || !std::isfinite(grid.origin_y_m)) {
    throw std::runtime_error(yaml_path + ": origin must be finite");
  }
  if (!(std::abs(yaw) <= 1e-9)) {  // NaN too
    throw std::runtime_error(yaml_path + ": origin yaw " + std::to_string(yaw) +
                             " is not supported (the map's rows must run along the map frame's "
                             "x axis): rotate the image and set the yaw to 0");
  }
  if (mode != "trinary" && mode != "scale" && mode != "raw") {
    throw std::runtime_error(yaml_path + ": mode '" + mode +
                             "' is not one of map_server's "
                             "trinary, scale, raw");
  }
  if (negate != 0 && negate != 1) throw std::runtime_error(yaml_path + ": negate must be 0 or 1");
  if (!(free_thresh >= 0.0 && free_thresh < occupied_thresh && occupied_thresh <= 1.0)) {
    throw std::runtime_error(yaml_path + ": need 0 <= free_thresh < occupied_thresh <= 1");
  }
  if (image.empty() || image[0] != '/') {
    const size_t slash = yaml_path.find_last_of('/');
    if (slash != std::string::npos) image = yaml_path.substr(0, slash + 1) + image;
  }
  if (!std::filesystem::is_regular_file(image, error)) {
    throw std::runtime_error(image + " (the image of " + yaml_path + "): cannot be read");
  }
  std::ifstream pgm(image, std::ios::binary);
  std::string magic;
  pgm >> magic;
  if (!pgm || magic != "P5") throw std::runtime_error(image + ": not a binary PGM");
  auto next_number = [&]() {
    pgm >> std::ws;
    while (pgm.peek() == '#') {
      std::string comment;
      std::getline(pgm, comment);
      pgm >> std::ws;
    }
    int v = -1;
    pgm >> v;
    return v;
  };
  grid.width = next_number();
  grid.height = next_number();
  const int max_value = next_number();
  if (grid.width <= 0 || grid.height <= 0 || max_value != 255) {
    throw std::runtime_error(image + ": unsupported PGM header");
  }
  pgm.get();
  // The header's size against the bytes left, before allocating: a corrupt header must not
  // ask for gigabytes.
  const std::streampos data_start = pgm.tellg();
  pgm.seekg(0, std::ios::end);
  const std::streamoff available = pgm.tellg() - data_start;
  pgm.seekg(data_start);
  const unsigned long long needed = static_cast<unsigned long long>(grid.width) * grid.height;
  if (available < 0 || needed > static_cast<unsigned long long>(available)) {
    throw std::runtime_error(image + ": truncated (" + std::to_string(grid.width) + " x " +
                             std::to_string(grid.height) + " pixels announced, " +
                             std::to_string(available) + " bytes of data)");
  }
  std::vector<uint8_t> pixels(static_cast<size_t>(needed));
  pgm.read(reinterpret_cast<char*>(pixels.data()), static_cast<std::streamsize>(pixels.size()));
  if (!pgm) throw std::runtime_error(image + ": truncated");
  grid.cells.assign(pixels.size(), -1);
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const size_t pixel = static_cast<size_t>(grid.height - 1 - y) * grid.width + x;
      int8_t& cell = grid.cells[static_cast<size_t>(y) * grid.width + x];
      if (mode == "raw") {  // the pixel (negated first, as map_server does) is the value
        const int value = negate ? 255 - pixels[pixel] : pixels[pixel];
        if (value <= 100) cell = static_cast<int8_t>(value);  // beyond 100: unknown
        continue;
      }
      const double occupancy =
          negate ? pixels[pixel] / 255.0 : (255 - pixels[pixel]) / 255.0;  // map_server's rule
      if (occupancy > occupied_thresh) {
        cell = 100;
      } else if (occupancy < free_thresh) {
        cell = 0;
      } else if (mode == "scale") {  // map_server: 1 + 98 x the place between the thresholds
        cell = static_cast<int8_t>(
            std::lround(1.0 + 98.0 * (occupancy - free_thresh) / (occupied_thresh - free_thresh)));
      }
    }
  }
  return grid;
}

void drawGridRunMap(const std::string& path, const core::GridMapData& grid,
                    const std::vector<core::Pose2>& trajectory,
                    const std::vector<core::Pose2>& reference) {
  const Eigen::Vector2d min(grid.origin_x_m, grid.origin_y_m);
  const Eigen::Vector2d max = min + grid.resolution_m * Eigen::Vector2d(grid.width, grid.height);
  // At least ~800 pixels across for small maps (an e-puck arena is 120 cells of 1 cm).
  const int scale = std::clamp(800 / std::max(1, std::max(grid.width, grid.height)), 1, 8);
  MapImage image(min, max, grid.resolution_m / scale, 0.0);
  const uint8_t unknown[3] = {205, 205, 205}, free[3] = {255, 255, 255}, occupied[3] = {0, 0, 0};
  const uint8_t grey[3] = {150, 150, 150}, blue[3] = {30, 90, 220};
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const int8_t v = grid.at(x, y);
      const uint8_t* colour = v >= kOccupiedPercent ? occupied
                              : (v >= 0 && v <= kFreePercent) ? free : unknown;
      const Eigen::Vector2d corner = min + grid.resolution_m * Eigen::Vector2d(x, y);
      image.fill(corner, corner + Eigen::Vector2d::Constant(grid.resolution_m), colour);
    }
  }
  for (size_t i = 1; i < reference.size(); ++i) {
    image.line(reference[i - 1].head<2>(), reference[i].head<2>(), grey);
  }
  for (size_t i = 1; i < trajectory.size(); ++i) {
    image.line(trajectory[i - 1].head<2>(), trajectory[i].head<2>(), blue);
  }
  image.writePng(path);
}

}  // namespace io
}  // namespace rbpf_slam

#include "rbpf_slam/io/victoria_park.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/core/filters/observation.h"
#include "rbpf_slam/io/number_text.h"
#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/plausibility.h"

namespace rbpf_slam {
namespace io {
namespace {

[[noreturn]] void fail(const std::string& source, std::size_t line, const std::string& why) {
  throw std::runtime_error(source + ":" + std::to_string(line) + ": " + why);
}

double number(const std::string& token, const std::string& source, std::size_t line) {
  double value = 0.0;
  const NumberText parsed = parseNumberText(token, &value);
  if (parsed == NumberText::kNotNumber) fail(source, line, "'" + token + "' is not a number");
  if (parsed == NumberText::kNotFinite) fail(source, line, "'" + token + "' is not finite");
  return value;
}

long index(const std::string& token, const std::string& source, std::size_t line) {
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(token.c_str(), &end, 10);
  if (token.empty() || end != token.c_str() + token.size() || value < 0 || errno == ERANGE) {
    fail(source, line, "'" + token + "' is not a non-negative integer index");
  }
  return value;
}

}  // namespace

namespace {

bool positiveSemidefinite(const Eigen::MatrixXd& m) {
  if (!m.allFinite()) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(0.5 * (m + m.transpose()));
  return eigen.eigenvalues().minCoeff() >= -1e-12 * std::max(1.0, m.cwiseAbs().maxCoeff());
}

}  // namespace

VictoriaParkLog parseVictoriaPark(std::istream& in, const std::string& source) {
  VictoriaParkLog log;
  std::string text;
  std::size_t line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    std::istringstream fields(text);
    std::vector<std::string> tokens;
    for (std::string t; fields >> t;) tokens.push_back(t);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    const std::string& tag = tokens[0];
    if (tag == "ODOMETRY") {
      if (tokens.size() != 12) {
        fail(source, line, "ODOMETRY needs 11 fields (i j dx dy dtheta + 6 covariance terms), "
                           "got " + std::to_string(tokens.size() - 1));
      }
      VictoriaOdometry o;
      o.line = line;
      o.from = index(tokens[1], source, line);
      o.to = index(tokens[2], source, line);
      double v[9];
      for (int k = 0; k < 9; ++k) v[k] = number(tokens[3 + k], source, line);
      // One step of a vehicle logged at a few Hz: beyond these it is corrupt data, which would be
      // dead-reckoned into poses of 1e308 m (and inf in the bag).
      if (std::hypot(v[0], v[1]) > kMaxPlausibleRangeM || std::fabs(v[2]) > kMaxPlausibleAngleRad) {
        fail(source, line,
             "ODOMETRY step (" + tokens[3] + ", " + tokens[4] + ", " + tokens[5] +
                 ") is implausible (over " + std::to_string(kMaxPlausibleRangeM) + " m or " +
                 std::to_string(kMaxPlausibleAngleRad) + " rad)");
      }
      o.delta = core::Pose2(v[0], v[1], core::wrapAngle(v[2]));
      o.covariance << v[3], v[4], v[5], v[4], v[6], v[7], v[5], v[7], v[8];
      if (!positiveSemidefinite(o.covariance)) {
        fail(source, line, "ODOMETRY covariance is not positive semi-definite");
      }
      if (!log.odometry.empty() && log.odometry.back().to != o.from) {
        fail(source, line, "ODOMETRY " + std::to_string(o.from) + " -> " + std::to_string(o.to) +
                               " does not continue from pose " +
                               std::to_string(log.odometry.back().to));
      }
      log.odometry.push_back(o);
    } else if (tag == "LANDMARK") {
      if (tokens.size() != 8) {
        fail(source, line, "LANDMARK needs 7 fields (i l dx dy + 3 covariance terms), got " +
                               std::to_string(tokens.size() - 1));
      }
      VictoriaLandmark l;
      l.line = line;
      l.pose = index(tokens[1], source, line);
      const long tree = index(tokens[2], source, line);
      if (tree > 2147483647L) fail(source, line, "tree id too large");
      l.tree = static_cast<int>(tree);
      double v[5];
      for (int k = 0; k < 5; ++k) v[k] = number(tokens[3 + k], source, line);
      l.position << v[0], v[1];
      l.covariance << v[2], v[3], v[3], v[4];
      if (l.position.norm() <= 0.0) fail(source, line, "a tree at the sensor (zero range)");
      // Tiny ranges make the bearing's variance blow up in toRangeBearing.
      if (l.position.norm() > kMaxPlausibleRangeM || l.position.norm() < 1e-3) {
        fail(source, line,
             "LANDMARK at range " + std::to_string(l.position.norm()) +
                 " m is implausible (0.001.." + std::to_string(kMaxPlausibleRangeM) + " m)");
      }
      if (!core::finitePositiveDefinite(l.covariance)) {
        fail(source, line, "LANDMARK covariance is not positive definite");
      }
      log.landmarks.push_back(l);
    } else {
      fail(source, line, "unknown record '" + tag + "' (expected ODOMETRY or LANDMARK)");
    }
  }
  if (log.odometry.empty()) throw std::runtime_error(source + ": no ODOMETRY line");
  return log;
}

VictoriaParkLog loadVictoriaPark(const std::string& path) {
  requireNotADevice(path);
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be opened");
  return parseVictoriaPark(in, path);
}

std::vector<VictoriaPose> victoriaParkPoses(const VictoriaParkLog& log, std::size_t* orphans) {
  std::vector<VictoriaPose> poses;
  std::map<long, std::size_t> position;
  VictoriaPose first;
  first.index = log.odometry.front().from;
  poses.push_back(first);
  position[first.index] = 0;
  for (const auto& o : log.odometry) {
    VictoriaPose next;
    next.index = o.to;
    next.odometry = core::compose(poses.back().odometry, o.delta);
    position[o.to] = poses.size();
    poses.push_back(next);
  }
  *orphans = 0;
  for (const auto& l : log.landmarks) {
    auto it = position.find(l.pose);
    if (it == position.end()) {
      ++*orphans;
      continue;
    }
    poses[it->second].landmarks.push_back(l);
  }
  return poses;
}

void toRangeBearing(const VictoriaLandmark& landmark, double* range, double* bearing,
                    Eigen::Matrix2d* covariance) {
  const double x = landmark.position.x(), y = landmark.position.y();
  const double r2 = x * x + y * y, r = std::sqrt(r2);
  *range = r;
  *bearing = std::atan2(y, x);
  Eigen::Matrix2d j;
  j << x / r, y / r, -y / r2, x / r2;
  *covariance = j * landmark.covariance * j.transpose();
}

}  // namespace io
}  // namespace rbpf_slam

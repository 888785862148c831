#include "rbpf_slam/io/trajectory.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/io/number_text.h"
#include "rbpf_slam/io/output_file.h"

namespace rbpf_slam {
namespace io {
namespace {

std::runtime_error lineError(const std::string& source, int line_number, const std::string& what) {
  return std::runtime_error(source + ":" + std::to_string(line_number) + ": " + what);
}

}  // namespace

double yawFromQuaternion(double qx, double qy, double qz, double qw) {
  const double norm2 = qx * qx + qy * qy + qz * qz + qw * qw;
  if (!std::isfinite(norm2) || norm2 <= 0.0) {
    throw std::invalid_argument("quaternion is zero or not finite");
  }
  // Scale-invariant form of the z-y-x Euler yaw, so an unnormalised quaternion works too.
  return std::atan2(2.0 * (qw * qz + qx * qy), qw * qw + qx * qx - qy * qy - qz * qz);
}

std::vector<StampedPose> readTum(std::istream& in, const std::string& source_name) {
  std::vector<StampedPose> poses;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::string token;
    double values[8];
    int count = 0;
    while (fields >> token) {
      if (count == 8) {
        throw lineError(source_name, line_number,
                        "expected 8 numbers (t x y z qx qy qz qw), got more");
      }
      const NumberText parsed = parseNumberText(token, &values[count]);
      if (parsed == NumberText::kNotNumber) {
        throw lineError(source_name, line_number, "not a number: '" + token + "'");
      }
      if (parsed == NumberText::kNotFinite) {
        throw lineError(source_name, line_number, "non-finite value: '" + token + "'");
      }
      ++count;
    }
    if (count != 8) {
      throw lineError(source_name, line_number,
                      "expected 8 numbers (t x y z qx qy qz qw), got " + std::to_string(count));
    }
    StampedPose stamped;
    stamped.stamp = values[0];
    try {
      stamped.pose = core::Pose2(values[1], values[2],
                                 yawFromQuaternion(values[4], values[5], values[6], values[7]));
    } catch (const std::invalid_argument& error) {
      throw lineError(source_name, line_number, error.what());
    }
    poses.push_back(stamped);
  }
  if (in.bad()) throw std::runtime_error(source_name + ": read error");
  return poses;
}

std::vector<StampedPose> readTum(const std::string& path) {
  requireNotADevice(path);  // /dev/zero: one endless line, gigabytes before "read error"
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open trajectory file");
  return readTum(in, path);
}

void writeTum(std::ostream& out, const std::vector<StampedPose>& poses) {
  std::vector<char> buffer(256);
  for (const StampedPose& stamped : poses) {
    const double half_yaw = 0.5 * stamped.pose.z();
    // Sized for the line: a huge coordinate (corrupt data) must not cut it short.
    for (;;) {
      const int n = std::snprintf(
          buffer.data(), buffer.size(), "%.9f %.9f %.9f 0 0 0 %.12f %.12f\n", stamped.stamp,
          stamped.pose.x(), stamped.pose.y(), std::sin(half_yaw), std::cos(half_yaw));
      if (n < 0) throw std::runtime_error("writeTum: cannot format a pose");
      if (static_cast<size_t>(n) < buffer.size()) break;
      buffer.resize(static_cast<size_t>(n) + 1);
    }
    out << buffer.data();
  }
}

void writeTum(const std::string& path, const std::vector<StampedPose>& poses) {
  requireReplaceableFile(path);  // not into a pipe or a device
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << "# timestamp x y z qx qy qz qw\n";
  writeTum(out, poses);
  out.flush();
  if (!out) throw std::runtime_error(path + ": write failed");
}

}  // namespace io
}  // namespace rbpf_slam

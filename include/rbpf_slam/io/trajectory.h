#pragma once
// Planar trajectories in the TUM text format (`t x y z qx qy qz qw`, one pose per line).

#include <iosfwd>
#include <string>
#include <vector>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace io {

/// A planar pose with the time it holds at.
struct StampedPose {
  double stamp = 0.0;                      // s
  core::Pose2 pose = core::Pose2::Zero();  // x [m], y [m], theta [rad]
};

/// Heading (rotation about z) of the quaternion (x, y, z, w); need not be normalised.
/// Throws std::invalid_argument for a zero or non-finite quaternion.
double yawFromQuaternion(double qx, double qy, double qz, double qw);

/// Reads a TUM trajectory. Blank lines and lines starting with '#' are skipped; z, roll and
/// pitch are dropped. Throws std::runtime_error naming the file (and line) when the file cannot
/// be read, a line does not hold exactly eight numbers, or a value is not finite.
std::vector<StampedPose> readTum(const std::string& path);

/// As readTum(path), from a stream; source_name is used in error messages.
std::vector<StampedPose> readTum(std::istream& in, const std::string& source_name);

/// Writes poses as TUM lines (z = 0, rotation about z only), with nanosecond stamps and
/// nanometre positions. Throws std::runtime_error when the file cannot be written.
void writeTum(const std::string& path, const std::vector<StampedPose>& poses);

/// As writeTum(path, poses), to a stream.
void writeTum(std::ostream& out, const std::vector<StampedPose>& poses);

}  // namespace io
}  // namespace rbpf_slam

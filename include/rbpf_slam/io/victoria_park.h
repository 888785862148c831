#pragma once
// The Victoria Park dataset (Guivant and Nebot; the text form distributed with GTSAM):
// `ODOMETRY i j dx dy dtheta` + 6 upper-triangle terms (relative motion from pose i to pose j)
// and `LANDMARK i l dx dy` + 3 terms (tree l in the frame of pose i; association solved).
// The trailing terms are read as covariance entries, as GTSAM's loader does: read as
// information they would give odometry sigmas of 100 m per step. No ROS here.

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace io {

struct VictoriaOdometry {
  long from = 0, to = 0;  // pose indices
  core::Pose2 delta = core::Pose2::Zero();  // pose `to` in the frame of pose `from`
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // over (dx, dy, dtheta)
  std::size_t line = 0;  // 1-based
};

struct VictoriaLandmark {
  long pose = 0;  // the observing pose's index
  int tree = 0;   // landmark identity
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  // in the pose's frame, m
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  // over (x, y)
  std::size_t line = 0;
};

struct VictoriaParkLog {
  std::vector<VictoriaOdometry> odometry;  // file order
  std::vector<VictoriaLandmark> landmarks;
};

/// Parses the whole file. Skips blank lines and '#' comments; throws std::runtime_error
/// "SOURCE:LINE: why" on an unknown tag, a wrong number of fields, a non-number, a non-finite
/// value, a negative index, or an odometry line that does not continue the chain of poses.
VictoriaParkLog parseVictoriaPark(std::istream& in, const std::string& source);
VictoriaParkLog loadVictoriaPark(const std::string& path);

/// One pose of the chain: its index, the dead-reckoned pose (start at the origin) and the
/// landmarks seen from it.
struct VictoriaPose {
  long index = 0;
  core::Pose2 odometry = core::Pose2::Zero();
  std::vector<VictoriaLandmark> landmarks;
};

/// Integrates the odometry chain and attaches each landmark sighting to its pose; sightings
/// from a pose that is not on the chain are counted in *orphans and dropped.
std::vector<VictoriaPose> victoriaParkPoses(const VictoriaParkLog& log, std::size_t* orphans);

/// A sighting as range, bearing and their covariance (first-order propagation of (x, y)).
void toRangeBearing(const VictoriaLandmark& landmark, double* range, double* bearing,
                    Eigen::Matrix2d* covariance);

}  // namespace io
}  // namespace rbpf_slam

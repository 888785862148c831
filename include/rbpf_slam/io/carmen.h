#pragma once
// CARMEN robot logs (ODOM and FLASER lines, plain or gzip-compressed) and the odometry and
// reference trajectories derived from a corrected log. No ROS here: carmen_to_bag turns the
// result into messages.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/io/trajectory.h"

namespace rbpf_slam {
namespace io {

/// One front laser scan (FLASER line) with the poses logged with it.
struct CarmenLaser {
  double stamp = 0.0;                            // s, log time
  std::vector<double> ranges;                    // m, as logged, counter-clockwise
  core::Pose2 laser_pose = core::Pose2::Zero();  // pose of the laser in the log's frame
  core::Pose2 robot_pose = core::Pose2::Zero();  // pose of the robot when the scan was taken
  std::size_t line = 0;                          // 1-based line number in the log
};

/// One odometry reading (ODOM line).
struct CarmenOdometry {
  double stamp = 0.0;                      // s, log time
  core::Pose2 pose = core::Pose2::Zero();  // x [m], y [m], theta [rad]
  double translational_velocity = 0.0;     // m/s
  double rotational_velocity = 0.0;        // rad/s
  std::size_t lasers_before = 0;           // FLASER lines earlier in the file
  std::size_t line = 0;                    // 1-based line number in the log
};

/// A CARMEN log in file order, with a tally of what was skipped.
struct CarmenLog {
  std::vector<CarmenLaser> lasers;
  std::vector<CarmenOdometry> odometry;
  std::map<std::string, std::string> params;            // PARAM name value
  std::map<std::string, std::size_t> unknown_messages;  // skipped lines by message type
  std::size_t malformed_lines = 0;
  std::vector<std::string> malformed_examples;  // the first few, as "line N: why"
};

/// Parses a log line by line. Comments and blank lines are ignored; unknown message types and
/// malformed lines (wrong field count, non-numeric or non-finite values) are skipped and counted.
CarmenLog parseCarmenLog(std::istream& in);

/// Reads a plain or gzip-compressed log (through zlib). Throws std::runtime_error naming the
/// path when it cannot be opened or read.
CarmenLog readCarmenLog(const std::string& path);

/// Angles of a FLASER scan of `beam_count` beams over the front half-plane, as CARMEN and
/// GMapping read them: 180/181 beams are 1 degree apart, 360/361 half a degree, otherwise
/// the beams span 180 degrees evenly. The first beam looks to the right (-pi/2).
struct LaserGeometry {
  double angle_min_rad = -M_PI / 2.0;
  double angle_increment_rad = M_PI / 180.0;
};
LaserGeometry flaserGeometry(std::size_t beam_count);

/// A logged range as REP-117 wants it: +inf for "no return" (at or beyond max_range_m),
/// NaN for an invalid (non-positive or non-finite) reading, otherwise the reading.
double toRep117Range(double range_m, double max_range_m);

/// What correctedMotion() kept and dropped.
struct CorrectedMotionStats {
  std::size_t odometry_used = 0;
  std::size_t odometry_dropped = 0;  // stamp outside its scans' window or out of order
  std::size_t duplicate_stamps = 0;  // samples dropped because another had the same stamp
  // FLASER scans stamped before an earlier scan in the file (sorted by time, they also narrow
  // the ODOM windows): how many, the first one's line, and the earlier scan it follows (the
  // latest stamped up to there: a stamp far ahead of its neighbours shows here).
  std::size_t scans_out_of_order = 0;
  std::size_t first_out_of_order_line = 0;
  double first_out_of_order_stamp = 0.0;
  std::size_t latest_before_line = 0;
  double latest_before_stamp = 0.0;
};

/// The robot's motion as the corrected log describes it: the corrected pose at every scan
/// plus the ODOM poses between consecutive scans, in strictly increasing time.
///
/// In a corrected log (e.g. written by GMapping) each ODOM run restarts from the corrected
/// pose of the scan before it, and the jump to the next scan's corrected pose is the
/// correction. Composing the increments of this sequence therefore reproduces every corrected
/// scan pose. ODOM lines whose stamp is not strictly between the latest earlier scan and the
/// next scan (stamps of 0, stale clocks) are dropped, and so are the fewest others needed for
/// the stamps between two scans to increase in file order (a jittering clock). Poses are
/// absolute, so dropping a sample merges two increments and loses no motion.
std::vector<StampedPose> correctedMotion(const CarmenLog& log, CorrectedMotionStats* stats);

/// The corrected robot pose at every scan, sorted by stamp (stable for equal stamps).
std::vector<StampedPose> scanPoses(const CarmenLog& log);

/// Systematic and random error that turns true motion into drifting wheel odometry.
struct OdometryNoiseOptions {
  // Standard deviation per unit of motion: x and y sigma = noise * distance [m/m], theta sigma
  // = noise * |rotation| [rad/rad], drawn independently for every increment.
  double noise_per_unit = 0.03;
  // Systematic scale error of every increment (translation and rotation): 0.02 = 2 % too long.
  double scale_bias = 0.02;
  std::uint64_t seed = 1;
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const OdometryNoiseOptions& options);

/// Odometry poses at the stamps of `truth`: starts at truth's first pose and composes each true
/// increment (between consecutive poses, in the robot frame) scaled by 1 + scale_bias plus
/// Gaussian noise, from a std::mt19937_64 seeded with options.seed.
std::vector<StampedPose> simulateOdometry(const std::vector<StampedPose>& truth,
                                          const OdometryNoiseOptions& options);

}  // namespace io
}  // namespace rbpf_slam

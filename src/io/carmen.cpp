#include "rbpf_slam/io/carmen.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <istream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/core/random.h"
#include "rbpf_slam/io/number_text.h"
#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/plausibility.h"

namespace rbpf_slam {
namespace io {
namespace {

constexpr std::size_t kMalformedExamples = 5;
// FLASER: type, beam count, beams, laser x y theta, robot x y theta, timestamp (host and
// logger timestamp may follow).
constexpr std::size_t kFlaserFieldsAfterBeams = 7;
// ODOM: type, x y theta tv rv accel, timestamp (host and logger timestamp may follow).
constexpr std::size_t kOdomFields = 8;
// The host and logger timestamp after a record's own fields.
constexpr std::size_t kOptionalTrailingFields = 2;

std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::istringstream stream(line);
  std::string field;
  while (stream >> field) fields.push_back(field);
  return fields;
}

// Parses fields[first, first + count) into values; the index of the first bad field, or -1.
long parseFields(const std::vector<std::string>& fields, std::size_t first, std::size_t count,
                 std::vector<double>* values) {
  values->resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    if (!parseFiniteNumber(fields[first + i], &(*values)[i])) return static_cast<long>(first + i);
  }
  return -1;
}

// Records a malformed line; returns false so parsers can `return malformed(...)`.
bool malformed(CarmenLog* log, std::size_t line_number, const std::string& why) {
  ++log->malformed_lines;
  if (log->malformed_examples.size() < kMalformedExamples) {
    log->malformed_examples.push_back("line " + std::to_string(line_number) + ": " + why);
  }
  return false;
}

// Log stamps stay below 3e9 s so that the converter's offset (2010-01-01) keeps them within
// kMaxRosStampS.
constexpr double kMaxLogStampS = 3.0e9;
static_assert(kMaxLogStampS + 1262304000.0 < kMaxRosStampS, "carmen_to_bag's offset");

/// Empty when the pose, velocities and stamp are plausible; else what is not.
std::string implausible(const core::Pose2& pose, double stamp, double v = 0.0, double w = 0.0) {
  if (std::abs(pose.x()) > kMaxPlausibleCoordinateM ||
      std::abs(pose.y()) > kMaxPlausibleCoordinateM) {
    return "a position beyond 1e6 m";
  }
  if (std::abs(v) > kMaxPlausibleSpeed || std::abs(w) > kMaxPlausibleSpeed)
    return "a velocity beyond 100";
  if (!(stamp >= 0.0 && stamp <= kMaxLogStampS)) return "a stamp outside [0, 3e9] s";
  return "";
}

bool parseOdom(const std::vector<std::string>& fields, std::size_t line_number, CarmenLog* log) {
  if (fields.size() < kOdomFields) {
    return malformed(log, line_number,
                     "ODOM needs 7 numbers, got " + std::to_string(fields.size() - 1) + " fields");
  }
  if (fields.size() > kOdomFields + kOptionalTrailingFields) {
    return malformed(log, line_number, "ODOM with " + std::to_string(fields.size()) +
                                           " fields, at most " +
                                           std::to_string(kOdomFields + kOptionalTrailingFields) +
                                           " (two records on one line?)");
  }
  std::vector<double> values;
  const long bad = parseFields(fields, 1, kOdomFields - 1, &values);
  if (bad >= 0) return malformed(log, line_number, "ODOM field '" + fields[bad] + "'");
  CarmenOdometry odometry;
  odometry.pose = core::Pose2(values[0], values[1], core::wrapAngle(values[2]));
  odometry.translational_velocity = values[3];
  odometry.rotational_velocity = values[4];
  odometry.stamp = values[6];
  const std::string why = implausible(odometry.pose, odometry.stamp, values[3], values[4]);
  if (!why.empty()) return malformed(log, line_number, "ODOM with " + why);
  odometry.lasers_before = log->lasers.size();
  odometry.line = line_number;
  log->odometry.push_back(odometry);
  return true;
}

bool parseFlaser(const std::vector<std::string>& fields, std::size_t line_number, CarmenLog* log) {
  double count = 0.0;
  if (fields.size() < 2 || !parseFiniteNumber(fields[1], &count) || count < 0.0 ||
      count != std::floor(count) || count > 100000.0) {
    return malformed(log, line_number, "FLASER needs a beam count");
  }
  const std::size_t beams = static_cast<std::size_t>(count);
  if (fields.size() < 2 + beams + kFlaserFieldsAfterBeams) {
    return malformed(log, line_number,
                     "FLASER with " + std::to_string(beams) + " beams needs " +
                         std::to_string(2 + beams + kFlaserFieldsAfterBeams) + " fields, got " +
                         std::to_string(fields.size()));
  }
  const std::size_t most = 2 + beams + kFlaserFieldsAfterBeams + kOptionalTrailingFields;
  if (fields.size() > most) {
    return malformed(log, line_number,
                     "FLASER with " + std::to_string(beams) + " beams and " +
                         std::to_string(fields.size()) + " fields, at most " +
                         std::to_string(most) + " (two records on one line?)");
  }
  CarmenLaser laser;
  long bad = parseFields(fields, 2, beams, &laser.ranges);
  std::vector<double> values;
  if (bad < 0) bad = parseFields(fields, 2 + beams, kFlaserFieldsAfterBeams, &values);
  if (bad >= 0) return malformed(log, line_number, "FLASER field '" + fields[bad] + "'");
  laser.laser_pose = core::Pose2(values[0], values[1], core::wrapAngle(values[2]));
  laser.robot_pose = core::Pose2(values[3], values[4], core::wrapAngle(values[5]));
  laser.stamp = values[6];
  std::string why = implausible(laser.laser_pose, laser.stamp);
  if (why.empty()) why = implausible(laser.robot_pose, laser.stamp);
  if (!why.empty()) return malformed(log, line_number, "FLASER with " + why);
  laser.line = line_number;
  log->lasers.push_back(laser);
  return true;
}

void parseLine(const std::string& line, std::size_t line_number, CarmenLog* log) {
  if (line.find('\0') != std::string::npos) {
    malformed(log, line_number, "a NUL byte in the line (a damaged file?)");
    return;
  }
  const std::vector<std::string> fields = splitFields(line);
  if (fields.empty() || fields[0][0] == '#') return;
  const std::string& type = fields[0];
  if (type == "ODOM") {
    parseOdom(fields, line_number, log);
  } else if (type == "FLASER") {
    parseFlaser(fields, line_number, log);
  } else if (type == "PARAM") {
    if (fields.size() < 3) {
      malformed(log, line_number, "PARAM needs a name and a value");
    } else {
      log->params[fields[1]] = fields[2];
    }
  } else {
    ++log->unknown_messages[type];
  }
}

// Indices of a longest strictly increasing subsequence of values (patience sorting,
// O(n log n)), in order.
std::vector<std::size_t> longestIncreasingSubsequence(const std::vector<double>& values) {
  std::vector<std::size_t> tails;  // tails[k]: index of the smallest tail of a run of k + 1
  std::vector<std::size_t> previous(values.size(), std::numeric_limits<std::size_t>::max());
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto position = std::lower_bound(
        tails.begin(), tails.end(), values[i],
        [&values](std::size_t index, double value) { return values[index] < value; });
    if (position != tails.begin()) previous[i] = *(position - 1);
    if (position == tails.end()) {
      tails.push_back(i);
    } else {
      *position = i;
    }
  }
  std::vector<std::size_t> run;
  for (std::size_t i = tails.empty() ? previous.size() : tails.back(); i < previous.size();
       i = previous[i]) {
    run.push_back(i);
  }
  std::reverse(run.begin(), run.end());
  return run;
}

/// One line as read up to '\n' (without it): a CRLF line's '\r' dropped, and a lone '\r' (old Mac
/// line ends) taken as a line end, each piece counted as a line.
void parseRecord(std::string text, std::size_t* line_number, CarmenLog* log) {
  while (!text.empty() && text.back() == '\r') text.pop_back();  // CRLF (or CRCRLF)
  std::size_t start = 0;
  for (std::size_t cr = text.find('\r'); cr != std::string::npos; cr = text.find('\r', start)) {
    parseLine(text.substr(start, cr - start), ++*line_number, log);
    start = cr + 1;
  }
  parseLine(start == 0 ? text : text.substr(start), ++*line_number, log);
}

}  // namespace

CarmenLog parseCarmenLog(std::istream& in) {
  CarmenLog log;
  std::string line;
  std::size_t line_number = 0;
  while (std::getline(in, line)) parseRecord(line, &line_number, &log);
  return log;
}

CarmenLog readCarmenLog(const std::string& path) {
  requireNotADevice(path);                   // /dev/zero would be read for ever
  gzFile file = gzopen(path.c_str(), "rb");  // reads uncompressed files unchanged
  if (file == nullptr) throw std::runtime_error(path + ": cannot open CARMEN log");
  CarmenLog log;
  std::string pending;  // read, not yet split into lines (bytes as read: NULs included)
  std::size_t line_number = 0;
  std::vector<char> buffer(1 << 16);
  int got = 0;
  while ((got = gzread(file, buffer.data(), static_cast<unsigned>(buffer.size()))) > 0) {
    pending.append(buffer.data(), static_cast<std::size_t>(got));
    std::size_t start = 0;
    for (std::size_t end = pending.find('\n'); end != std::string::npos;
         end = pending.find('\n', start)) {
      parseRecord(pending.substr(start, end - start), &line_number, &log);
      start = end + 1;
    }
    pending.erase(0, start);
  }
  int error_number = Z_OK;
  const char* error_text = gzerror(file, &error_number);
  const std::string message = error_text != nullptr ? error_text : "";
  gzclose(file);
  if (error_number != Z_OK && error_number != Z_STREAM_END) {
    throw std::runtime_error(path + ": read error after line " + std::to_string(line_number) +
                             ": " + message);
  }
  if (!pending.empty()) parseRecord(pending, &line_number, &log);  // no final newline
  return log;
}

LaserGeometry flaserGeometry(std::size_t beam_count) {
  LaserGeometry geometry;
  if (beam_count == 180 || beam_count == 181) {
    geometry.angle_increment_rad = M_PI / 180.0;
  } else if (beam_count == 360 || beam_count == 361) {
    geometry.angle_increment_rad = M_PI / 360.0;
  } else if (beam_count > 1) {
    geometry.angle_increment_rad = M_PI / static_cast<double>(beam_count - 1);
  }
  return geometry;
}

double toRep117Range(double range_m, double max_range_m) {
  if (!std::isfinite(range_m) || range_m <= 0.0) return std::numeric_limits<double>::quiet_NaN();
  if (range_m >= max_range_m) return std::numeric_limits<double>::infinity();
  return range_m;
}

std::vector<StampedPose> correctedMotion(const CarmenLog& log, CorrectedMotionStats* stats) {
  CorrectedMotionStats local_stats;
  CorrectedMotionStats& counts = stats != nullptr ? *stats : local_stats;
  counts = CorrectedMotionStats();
  // Odometry after the s-th scan (in file order) must lie strictly inside (window_low[s],
  // window_high[s]): after every earlier scan and before the next one.
  const std::size_t scans = log.lasers.size();
  std::vector<double> window_low(scans + 1, -std::numeric_limits<double>::infinity());
  std::vector<double> window_high(scans + 1, std::numeric_limits<double>::infinity());
  std::size_t latest = 0;  // the scan with the latest stamp so far
  for (std::size_t s = 0; s < scans; ++s) {
    window_low[s + 1] = std::max(window_low[s], log.lasers[s].stamp);
    window_high[s] = log.lasers[s].stamp;
    if (s > 0 && log.lasers[s].stamp < log.lasers[latest].stamp) {
      if (counts.scans_out_of_order++ == 0) {
        counts.first_out_of_order_line = log.lasers[s].line;
        counts.first_out_of_order_stamp = log.lasers[s].stamp;
        counts.latest_before_line = log.lasers[latest].line;
        counts.latest_before_stamp = log.lasers[latest].stamp;
      }
    } else {
      latest = s;
    }
  }

  struct Sample {
    StampedPose pose;
    std::size_t line;
  };
  std::vector<Sample> samples;
  for (const CarmenLaser& laser : log.lasers) {
    samples.push_back({{laser.stamp, laser.robot_pose}, laser.line});
  }
  // Within a segment the clock jitters, so keep the largest set of in-window readings whose
  // stamps increase in file order.
  std::size_t first = 0;
  while (first < log.odometry.size()) {
    const std::size_t segment = log.odometry[first].lasers_before;
    std::size_t end = first;
    std::vector<std::size_t> candidates;
    std::vector<double> stamps;
    for (; end < log.odometry.size() && log.odometry[end].lasers_before == segment; ++end) {
      const double stamp = log.odometry[end].stamp;
      if (stamp > 0.0 && stamp > window_low[segment] && stamp < window_high[segment]) {
        candidates.push_back(end);
        stamps.push_back(stamp);
      }
    }
    for (std::size_t k : longestIncreasingSubsequence(stamps)) {
      const CarmenOdometry& odometry = log.odometry[candidates[k]];
      samples.push_back({{odometry.stamp, odometry.pose}, odometry.line});
      ++counts.odometry_used;
    }
    first = end;
  }
  counts.odometry_dropped = log.odometry.size() - counts.odometry_used;

  std::sort(samples.begin(), samples.end(), [](const Sample& a, const Sample& b) {
    return a.pose.stamp != b.pose.stamp ? a.pose.stamp < b.pose.stamp : a.line < b.line;
  });
  std::vector<StampedPose> motion;
  motion.reserve(samples.size());
  for (const Sample& sample : samples) {
    if (!motion.empty() && sample.pose.stamp <= motion.back().stamp) {
      ++counts.duplicate_stamps;
      continue;
    }
    motion.push_back(sample.pose);
  }
  return motion;
}

std::vector<StampedPose> scanPoses(const CarmenLog& log) {
  std::vector<StampedPose> poses;
  poses.reserve(log.lasers.size());
  for (const CarmenLaser& laser : log.lasers) poses.push_back({laser.stamp, laser.robot_pose});
  std::stable_sort(poses.begin(), poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.stamp < b.stamp; });
  return poses;
}

void validate(const OdometryNoiseOptions& options) {
  if (!(options.noise_per_unit >= 0.0) || !std::isfinite(options.noise_per_unit)) {
    throw std::invalid_argument("odometry noise_per_unit must be a finite number >= 0, got " +
                                std::to_string(options.noise_per_unit));
  }
  if (!(options.scale_bias > -1.0) || !std::isfinite(options.scale_bias)) {
    throw std::invalid_argument("odometry scale_bias must be a finite number > -1, got " +
                                std::to_string(options.scale_bias));
  }
}

std::vector<StampedPose> simulateOdometry(const std::vector<StampedPose>& truth,
                                          const OdometryNoiseOptions& options) {
  validate(options);
  std::vector<StampedPose> odometry;
  if (truth.empty()) return odometry;
  core::Rng rng(options.seed);
  const double scale = 1.0 + options.scale_bias;
  odometry.push_back(truth.front());
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const core::Pose2 step = core::between(truth[i - 1].pose, truth[i].pose);
    const double distance = step.head<2>().norm();
    const double sigma_xy = options.noise_per_unit * distance;
    const double sigma_theta = options.noise_per_unit * std::abs(step.z());
    // Draw all three every step so the random stream does not depend on which are zero.
    const double noise_x = core::sampleGaussian(rng, 1.0);
    const double noise_y = core::sampleGaussian(rng, 1.0);
    const double noise_theta = core::sampleGaussian(rng, 1.0);
    const core::Pose2 measured(scale * step.x() + sigma_xy * noise_x,
                               scale * step.y() + sigma_xy * noise_y,
                               scale * step.z() + sigma_theta * noise_theta);
    odometry.push_back({truth[i].stamp, core::compose(odometry.back().pose, measured)});
  }
  return odometry;
}

}  // namespace io
}  // namespace rbpf_slam

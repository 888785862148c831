#include "rbpf_slam/io/mrclam.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/io/number_text.h"
#include "rbpf_slam/io/output_file.h"
#include "rbpf_slam/io/plausibility.h"

namespace rbpf_slam {
namespace io {
namespace {

/// The numbers of one data line and where it came from.
struct Row {
  std::vector<double> values;
  std::size_t line = 0;
};

std::runtime_error lineError(const std::string& source, std::size_t line, const std::string& why) {
  return std::runtime_error(source + ":" + std::to_string(line) + ": " + why);
}

// One line's text as exactly `columns` finite numbers appended to rows (blank and '#' lines
// are skipped); `format` names them in errors.
void readRow(const std::string& text, std::size_t line, const std::string& source,
             std::size_t columns, const std::string& format, std::vector<Row>* rows) {
  const std::size_t first = text.find_first_not_of(" \t");
  if (first == std::string::npos || text[first] == '#') return;
  std::istringstream fields(text);
  std::string token;
  Row row;
  row.line = line;
  while (fields >> token) {
    double value = 0.0;
    if (!parseFiniteNumber(token, &value)) {
      throw lineError(source, line,
                      "not a finite number: '" + token + "' (expected " + format + ")");
    }
    row.values.push_back(value);
  }
  if (row.values.size() != columns) {
    throw lineError(source, line,
                    "expected " + std::to_string(columns) + " numbers (" + format + "), got " +
                        std::to_string(row.values.size()));
  }
  rows->push_back(std::move(row));
}

// Every data line of a file, by readRow. Lines end at LF, CRLF or a lone CR (old Mac files);
// CRs right before an LF (CRCRLF: a CRLF file converted once more) end one line with it. A
// UTF-8 byte-order mark at the start is skipped.
std::vector<Row> readRows(std::istream& in, const std::string& source, std::size_t columns,
                          const std::string& format) {
  std::vector<Row> rows;
  std::size_t line = 0;
  std::string raw;
  while (std::getline(in, raw)) {
    if (line == 0 && raw.compare(0, 3, "\xEF\xBB\xBF") == 0) raw.erase(0, 3);
    std::size_t stop = raw.size();
    while (stop > 0 && raw[stop - 1] == '\r') --stop;  // the CR(s) of CRLF end this line
    raw.erase(stop);
    for (std::size_t begin = 0;;) {
      const std::size_t cr = raw.find('\r', begin);
      const std::size_t end = cr == std::string::npos ? raw.size() : cr;
      readRow(raw.substr(begin, end - begin), ++line, source, columns, format, &rows);
      if (cr == std::string::npos) break;
      begin = cr + 1;
    }
  }
  if (in.bad()) throw std::runtime_error(source + ": read error");
  return rows;
}

void requireWithin(const std::string& source, std::size_t line, const char* what, double value,
                   double lo, double hi) {
  if (value < lo || value > hi) {
    std::ostringstream message;
    message << what << " = " << value << " is outside [" << lo << ", " << hi << "]";
    throw lineError(source, line, message.str());
  }
}

void requireStamp(const std::string& source, std::size_t line, double stamp) {
  if (!(stamp > 0.0)) {  // ros::Time starts after 0; the dataset's stamps are Unix times
    std::ostringstream message;
    message << "t = " << stamp << " is not a positive Unix time (stamps counted from 0?)";
    throw lineError(source, line, message.str());
  }
  requireWithin(source, line, "t", stamp, 0.0, kMaxRosStampS);
}

void requireUnique(std::map<int, std::size_t>* line_of, int key, const char* what,
                   const std::string& source, std::size_t line) {
  const auto inserted = line_of->emplace(key, line);
  if (!inserted.second) {
    throw lineError(source, line,
                    std::string(what) + " " + std::to_string(key) +
                        " listed twice (first at line " +
                        std::to_string(inserted.first->second) + ")");
  }
}

int toInteger(double value, const std::string& source, std::size_t line, const char* what) {
  if (value != std::floor(value) || std::abs(value) > 1e9) {
    throw lineError(source, line, std::string(what) + " is not an integer");
  }
  return static_cast<int>(value);
}

std::ifstream openFile(const std::string& path) {
  requireNotADevice(path);
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be opened");
  return in;
}

template <typename Parser>
auto parseFile(const std::string& path, Parser parser) {
  std::ifstream in = openFile(path);
  return parser(in, path);
}

}  // namespace

std::vector<MrclamOdometry> parseMrclamOdometry(std::istream& in, const std::string& source) {
  std::vector<MrclamOdometry> odometry;
  for (const Row& row : readRows(in, source, 3, "t v w")) {
    requireStamp(source, row.line, row.values[0]);
    requireWithin(source, row.line, "v", row.values[1], -kMaxPlausibleSpeed, kMaxPlausibleSpeed);
    requireWithin(source, row.line, "w", row.values[2], -kMaxPlausibleSpeed, kMaxPlausibleSpeed);
    odometry.push_back({row.values[0], row.values[1], row.values[2], row.line});
  }
  return odometry;
}

std::vector<MrclamMeasurement> parseMrclamMeasurements(std::istream& in,
                                                       const std::string& source) {
  std::vector<MrclamMeasurement> measurements;
  for (const Row& row : readRows(in, source, 4, "t barcode range bearing")) {
    MrclamMeasurement m;
    m.stamp = row.values[0];
    m.barcode = toInteger(row.values[1], source, row.line, "barcode");
    m.range_m = row.values[2];
    m.bearing_rad = row.values[3];
    m.line = row.line;
    if (m.range_m < 0.0) throw lineError(source, row.line, "negative range");
    requireStamp(source, row.line, m.stamp);
    requireWithin(source, row.line, "range", m.range_m, 0.0, kMaxPlausibleRangeM);
    requireWithin(source, row.line, "bearing", m.bearing_rad, -2.0 * M_PI, 2.0 * M_PI);
    measurements.push_back(m);
  }
  return measurements;
}

std::map<int, int> parseMrclamBarcodes(std::istream& in, const std::string& source) {
  std::map<int, int> subject_of_barcode;
  std::map<int, std::size_t> line_of_subject, line_of_barcode;
  for (const Row& row : readRows(in, source, 2, "subject barcode")) {
    const int subject = toInteger(row.values[0], source, row.line, "subject");
    const int barcode = toInteger(row.values[1], source, row.line, "barcode");
    if (subject < 1) {
      throw lineError(source, row.line, "subject " + std::to_string(subject) +
                                            " is not a robot (1..5) or landmark (6..) number");
    }
    requireUnique(&line_of_barcode, barcode, "barcode", source, row.line);
    requireUnique(&line_of_subject, subject, "subject", source, row.line);
    subject_of_barcode.emplace(barcode, subject);
  }
  return subject_of_barcode;
}

std::vector<StampedPose> parseMrclamGroundTruth(std::istream& in, const std::string& source,
                                                std::vector<std::size_t>* lines) {
  std::vector<StampedPose> poses;
  if (lines) lines->clear();
  for (const Row& row : readRows(in, source, 4, "t x y theta")) {
    requireStamp(source, row.line, row.values[0]);
    requireWithin(source, row.line, "x", row.values[1], -kMaxPlausibleCoordinateM,
                  kMaxPlausibleCoordinateM);
    requireWithin(source, row.line, "y", row.values[2], -kMaxPlausibleCoordinateM,
                  kMaxPlausibleCoordinateM);
    requireWithin(source, row.line, "theta", row.values[3], -kMaxPlausibleAngleRad,
                  kMaxPlausibleAngleRad);
    StampedPose pose;
    pose.stamp = row.values[0];
    pose.pose = core::Pose2(row.values[1], row.values[2], core::wrapAngle(row.values[3]));
    poses.push_back(pose);
    if (lines) lines->push_back(row.line);
  }
  return poses;
}

std::vector<MrclamLandmark> parseMrclamLandmarks(std::istream& in, const std::string& source) {
  std::vector<MrclamLandmark> landmarks;
  std::map<int, std::size_t> line_of_subject;
  for (const Row& row : readRows(in, source, 5, "subject x y sd_x sd_y")) {
    MrclamLandmark landmark;
    landmark.subject = toInteger(row.values[0], source, row.line, "subject");
    if (landmark.subject < kMrclamFirstLandmarkSubject) {
      throw lineError(source, row.line,
                      "subject " + std::to_string(landmark.subject) +
                          " is not a landmark number (robots are 1-" +
                          std::to_string(kMrclamFirstLandmarkSubject - 1) + ", landmarks from " +
                          std::to_string(kMrclamFirstLandmarkSubject) + ")");
    }
    requireUnique(&line_of_subject, landmark.subject, "subject", source, row.line);
    for (int k : {1, 2}) {
      requireWithin(source, row.line, k == 1 ? "x" : "y", row.values[k],
                    -kMaxPlausibleCoordinateM, kMaxPlausibleCoordinateM);
    }
    for (int k : {3, 4}) {
      requireWithin(source, row.line, k == 3 ? "sd_x" : "sd_y", row.values[k], 0.0,
                    kMaxPlausibleCoordinateM);
    }
    landmark.x_m = row.values[1];
    landmark.y_m = row.values[2];
    landmark.sd_x_m = row.values[3];
    landmark.sd_y_m = row.values[4];
    landmarks.push_back(landmark);
  }
  return landmarks;
}

void resolveSubjects(const std::map<int, int>& subject_of_barcode,
                     std::vector<MrclamMeasurement>* measurements) {
  for (MrclamMeasurement& m : *measurements) {
    const auto found = subject_of_barcode.find(m.barcode);
    m.subject = found == subject_of_barcode.end() ? -1 : found->second;
  }
}

namespace {

// Sorts rows by stamp (stable); when some were stamped before the row above them, warns how
// many, naming the first one's line (line_of(i): row i's line in the file before sorting).
template <typename Row, typename LineOf>
void sortReportingEarlier(const std::string& source, const char* noun, LineOf line_of,
                          std::vector<Row>* rows, std::vector<std::string>* warnings) {
  std::vector<Row>& r = *rows;
  std::size_t earlier = 0, first_earlier_line = 0;
  for (std::size_t i = 1; i < r.size(); ++i) {
    if (r[i].stamp < r[i - 1].stamp && earlier++ == 0) first_earlier_line = line_of(i);
  }
  if (earlier == 0) return;
  std::stable_sort(r.begin(), r.end(),
                   [](const Row& a, const Row& b) { return a.stamp < b.stamp; });
  warnings->push_back(source + ": " + std::to_string(earlier) + " " + noun +
                      "(s) stamped before the line above them (first at line " +
                      std::to_string(first_earlier_line) + "); sorted by time");
}

// Sorts the commands by time (stable), and says how many were out of order or share a stamp.
void reportAndSortOdometry(const std::string& source, MrclamRobot* data) {
  std::vector<MrclamOdometry>& o = data->odometry;
  sortReportingEarlier(source, "command", [&o](std::size_t i) { return o[i].line; }, &o,
                       &data->warnings);
  std::size_t shared = 0, first_shared_line = 0;
  for (std::size_t i = 1; i < o.size(); ++i) {
    if (o[i].stamp == o[i - 1].stamp && shared++ == 0) first_shared_line = o[i].line;
  }
  if (shared > 0) {
    data->warnings.push_back(source + ": " + std::to_string(shared) +
                             " command(s) share the stamp of the one before (first at line " +
                             std::to_string(first_shared_line) +
                             "); the first command at a stamp is the one integrated");
  }
}

// Names the landmark subjects sighted that Landmark_Groundtruth.dat has no position for.
void reportUnsurveyedSubjects(MrclamRobot* data) {
  std::set<int> surveyed, unsurveyed;
  for (const MrclamLandmark& l : data->landmarks) surveyed.insert(l.subject);
  for (const MrclamMeasurement& m : data->measurements) {
    if (m.subject >= kMrclamFirstLandmarkSubject && surveyed.count(m.subject) == 0) {
      unsurveyed.insert(m.subject);
    }
  }
  if (unsurveyed.empty()) return;
  std::ostringstream message;
  message << "Landmark_Groundtruth.dat has no position for sighted landmark subject(s)";
  for (int subject : unsurveyed) message << " " << subject;
  message << ": their estimates will count as spurious";
  data->warnings.push_back(message.str());
}

// Drops a sighting that repeats one of its frame exactly (same stamp, barcode, range and
// bearing: a line written twice would count as two sightings). Measurements sorted by stamp.
void dropRepeatedSightings(const std::string& source, MrclamRobot* data) {
  std::vector<MrclamMeasurement>& m = data->measurements;
  std::vector<MrclamMeasurement> kept;
  kept.reserve(m.size());
  std::size_t repeated = 0, first_line = 0;
  std::size_t frame_begin = 0;  // first of the kept sightings at the current stamp
  for (const MrclamMeasurement& x : m) {
    if (kept.empty() || kept.back().stamp != x.stamp) frame_begin = kept.size();
    const bool seen = std::any_of(kept.begin() + frame_begin, kept.end(), [&](const auto& y) {
      return y.barcode == x.barcode && y.range_m == x.range_m && y.bearing_rad == x.bearing_rad;
    });
    if (!seen) {
      kept.push_back(x);
    } else if (repeated++ == 0) {
      first_line = x.line;
    }
  }
  if (repeated == 0) return;
  m.swap(kept);
  data->warnings.push_back(source + ": " + std::to_string(repeated) +
                           " sighting line(s) repeat one of the same frame exactly (first at "
                           "line " + std::to_string(first_line) + "); each counted once");
}

}  // namespace

MrclamRobot readMrclamRobot(const std::string& directory, int robot) {
  if (robot < 1 || robot > 5) {
    throw std::invalid_argument("robot must be 1..5, got " + std::to_string(robot));
  }
  const std::string prefix = directory + "/Robot" + std::to_string(robot) + "_";
  MrclamRobot data;
  data.robot = robot;
  data.subject_of_barcode = parseFile(directory + "/Barcodes.dat", parseMrclamBarcodes);
  data.landmarks = parseFile(directory + "/Landmark_Groundtruth.dat", parseMrclamLandmarks);
  data.odometry = parseFile(prefix + "Odometry.dat", parseMrclamOdometry);
  data.measurements = parseFile(prefix + "Measurement.dat", parseMrclamMeasurements);
  std::vector<std::size_t> ground_truth_lines;
  data.ground_truth = parseFile(prefix + "Groundtruth.dat",
                                [&ground_truth_lines](std::istream& in, const std::string& source) {
                                  return parseMrclamGroundTruth(in, source, &ground_truth_lines);
                                });
  resolveSubjects(data.subject_of_barcode, &data.measurements);
  if (data.subject_of_barcode.empty()) {
    throw std::runtime_error(directory + "/Barcodes.dat: no data line");
  }
  if (data.landmarks.empty()) {
    throw std::runtime_error(directory + "/Landmark_Groundtruth.dat: no data line");
  }
  if (data.odometry.empty()) throw std::runtime_error(prefix + "Odometry.dat: no data line");
  if (data.ground_truth.empty()) throw std::runtime_error(prefix + "Groundtruth.dat: no data line");
  reportAndSortOdometry(prefix + "Odometry.dat", &data);
  reportUnsurveyedSubjects(&data);
  sortReportingEarlier(prefix + "Groundtruth.dat", "pose",
                       [&ground_truth_lines](std::size_t i) { return ground_truth_lines.at(i); },
                       &data.ground_truth, &data.warnings);
  sortReportingEarlier(prefix + "Measurement.dat", "sighting",
                       [&data](std::size_t i) { return data.measurements[i].line; },
                       &data.measurements, &data.warnings);
  dropRepeatedSightings(prefix + "Measurement.dat", &data);
  return data;
}

void cropMrclamRobot(double skip_s, double duration_s, MrclamRobot* data) {
  if (!std::isfinite(skip_s) || skip_s < 0.0) {
    throw std::invalid_argument("start offset must be finite and >= 0 s, got " +
                                std::to_string(skip_s));
  }
  if (!std::isfinite(duration_s) || duration_s < 0.0) {
    throw std::invalid_argument("duration must be finite and >= 0 s, got " +
                                std::to_string(duration_s));
  }
  if ((skip_s == 0.0 && duration_s == 0.0) || data->odometry.empty()) return;
  const double first = data->odometry.front().stamp;
  double last = first;  // the latest command (the file may hold some out of order)
  for (const MrclamOdometry& command : data->odometry) last = std::max(last, command.stamp);
  const double start = first + skip_s;
  if (start > last) {
    std::ostringstream why;
    why << "start offset " << skip_s << " s is beyond the last odometry command ("
        << (last - first) << " s after the first)";
    throw std::invalid_argument(why.str());
  }
  const double end = duration_s > 0.0 ? start + duration_s
                                       : std::numeric_limits<double>::infinity();
  const auto outside = [&](double stamp) { return stamp < start || stamp > end; };
  if (std::all_of(data->odometry.begin(), data->odometry.end(),
                  [&](const MrclamOdometry& c) { return outside(c.stamp); })) {
    std::ostringstream why;
    why << "no odometry command between " << skip_s << " and " << skip_s + duration_s
        << " s after the first";
    throw std::invalid_argument(why.str());
  }
  auto& o = data->odometry;
  o.erase(
      std::remove_if(o.begin(), o.end(), [&](const MrclamOdometry& x) { return outside(x.stamp); }),
      o.end());
  auto& m = data->measurements;
  m.erase(std::remove_if(m.begin(), m.end(),
                         [&](const MrclamMeasurement& x) { return outside(x.stamp); }),
          m.end());
  auto& g = data->ground_truth;
  g.erase(
      std::remove_if(g.begin(), g.end(), [&](const StampedPose& x) { return outside(x.stamp); }),
      g.end());
}

void reportGroundTruthGaps(const std::string& source, MrclamRobot* data) {
  const std::vector<StampedPose>& g = data->ground_truth;
  std::size_t gaps = 0;
  double widest = 0.0, widest_from = 0.0;
  const auto stretch = [&](double from, double to) {
    if (to - from <= kMrclamGroundTruthGapS) return;
    if (gaps++ == 0 || to - from > widest) {
      widest = to - from;
      widest_from = from;
    }
  };
  for (std::size_t i = 1; i < g.size(); ++i) stretch(g[i - 1].stamp, g[i].stamp);
  // Commands running on after the last pose (the file's end, or where a crop cut it).
  if (!g.empty() && !data->odometry.empty()) stretch(g.back().stamp, data->odometry.back().stamp);
  if (gaps == 0) return;
  std::ostringstream message;
  message << source << ": " << gaps << " stretch(es) of more than " << kMrclamGroundTruthGapS
          << " s without a pose; the longest, " << std::fixed << std::setprecision(3) << widest
          << " s from t = " << widest_from
          << " (a stray stamp, or Vicon lost the robot): the reference has no pose there";
  data->warnings.push_back(message.str());
}

void delayMrclamCommands(double delay_s, MrclamRobot* data) {
  if (!std::isfinite(delay_s) || delay_s < 0.0) {
    throw std::invalid_argument("command delay must be finite and >= 0 s, got " +
                                std::to_string(delay_s));
  }
  for (MrclamOdometry& command : data->odometry) command.stamp += delay_s;
}

core::Pose2 interpolatePose(const std::vector<StampedPose>& trajectory, double stamp) {
  if (trajectory.empty()) throw std::invalid_argument("interpolatePose: empty trajectory");
  if (stamp <= trajectory.front().stamp) return trajectory.front().pose;
  if (stamp >= trajectory.back().stamp) return trajectory.back().pose;
  const auto after =
      std::lower_bound(trajectory.begin(), trajectory.end(), stamp,
                       [](const StampedPose& pose, double t) { return pose.stamp < t; });
  const StampedPose& b = *after;
  const StampedPose& a = *(after - 1);
  const double span = b.stamp - a.stamp;
  const double f = span > 0.0 ? (stamp - a.stamp) / span : 1.0;
  const double dtheta = core::wrapAngle(b.pose.z() - a.pose.z());
  return core::Pose2(a.pose.x() + f * (b.pose.x() - a.pose.x()),
                     a.pose.y() + f * (b.pose.y() - a.pose.y()),
                     core::wrapAngle(a.pose.z() + f * dtheta));
}

std::vector<StampedPose> integrateMrclamOdometry(const std::vector<MrclamOdometry>& odometry,
                                                 const core::Pose2& start, double max_gap_s,
                                                 int* not_integrated) {
  if (not_integrated) *not_integrated = 0;
  std::vector<StampedPose> poses;
  if (odometry.empty()) return poses;
  poses.push_back({odometry.front().stamp, start});
  const MrclamOdometry* previous = &odometry.front();
  for (std::size_t i = 1; i < odometry.size(); ++i) {
    const MrclamOdometry& command = odometry[i];
    const double dt = command.stamp - previous->stamp;
    if (!(dt > 0.0)) continue;
    core::Pose2 pose = poses.back().pose;
    if (dt > max_gap_s && not_integrated) ++*not_integrated;
    if (dt <= max_gap_s) {
      const double v = previous->v_mps;
      const double w = previous->w_radps;
      const double theta = pose.z();
      const double dtheta = w * dt;
      if (std::abs(dtheta) < 1e-9) {
        pose.x() += v * dt * std::cos(theta);
        pose.y() += v * dt * std::sin(theta);
      } else {
        const double radius = v / w;
        pose.x() += radius * (std::sin(theta + dtheta) - std::sin(theta));
        pose.y() += radius * (std::cos(theta) - std::cos(theta + dtheta));
      }
      pose.z() = core::wrapAngle(theta + dtheta);
    }
    poses.push_back({command.stamp, pose});
    previous = &command;
  }
  return poses;
}

std::vector<MrclamMeasurementGroup> groupLandmarkMeasurements(
    const std::vector<MrclamMeasurement>& measurements, int first_landmark_subject) {
  std::vector<MrclamMeasurement> kept;
  for (const MrclamMeasurement& m : measurements) {
    if (m.subject >= first_landmark_subject) kept.push_back(m);
  }
  std::stable_sort(
      kept.begin(), kept.end(),
      [](const MrclamMeasurement& a, const MrclamMeasurement& b) { return a.stamp < b.stamp; });
  std::vector<MrclamMeasurementGroup> groups;
  for (const MrclamMeasurement& m : kept) {
    if (groups.empty() || groups.back().stamp != m.stamp) groups.push_back({m.stamp, {}});
    groups.back().measurements.push_back(m);
  }
  return groups;
}

}  // namespace io
}  // namespace rbpf_slam

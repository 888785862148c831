#pragma once
// The UTIAS Multi-Robot Cooperative Localization and Mapping (MRCLAM) dataset files (Leung et
// al., IJRR 2011): odometry commands, barcode range-bearing measurements, barcode table and
// Vicon ground truth, plus the dead-reckoned odometry and measurement groups derived from them.
// No ROS here: mrclam_to_bag turns the result into messages.

#include <cstddef>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/io/trajectory.h"

namespace rbpf_slam {
namespace io {

/// Subjects 1..5 are the robots, 6 and up the landmarks (every MRCLAM dataset).
constexpr int kMrclamFirstLandmarkSubject = 6;
/// Vicon ground truth comes at 100 Hz (dataset 6: at most 2 s between two poses); a longer
/// stretch without one is reported by reportGroundTruthGaps.
constexpr double kMrclamGroundTruthGapS = 10.0;

/// One velocity command of RobotN_Odometry.dat (`t v w`).
struct MrclamOdometry {
  double stamp = 0.0;    // s, Unix time
  double v_mps = 0.0;    // forward velocity, m/s
  double w_radps = 0.0;  // angular velocity, rad/s
  std::size_t line = 0;  // 1-based line number in the file
};

/// One range-bearing sighting of RobotN_Measurement.dat (`t barcode range bearing`).
struct MrclamMeasurement {
  double stamp = 0.0;  // s, Unix time
  int barcode = 0;     // as logged
  int subject = -1;    // from Barcodes.dat (1..5 robots, 6..20 landmarks); -1 unknown
  double range_m = 0.0;
  double bearing_rad = 0.0;
  std::size_t line = 0;  // 1-based line number in the file
};

/// One surveyed landmark of Landmark_Groundtruth.dat (`subject x y sd_x sd_y`).
struct MrclamLandmark {
  int subject = 0;
  double x_m = 0.0;
  double y_m = 0.0;
  double sd_x_m = 0.0;
  double sd_y_m = 0.0;
};

/// All the files of one robot of one dataset directory.
struct MrclamRobot {
  int robot = 0;                                // 1..5
  std::vector<MrclamOdometry> odometry;         // in file order
  std::vector<MrclamMeasurement> measurements;  // subjects resolved through the barcodes
  std::vector<StampedPose> ground_truth;        // Vicon, map frame
  std::vector<MrclamLandmark> landmarks;        // surveyed, map frame
  std::map<int, int> subject_of_barcode;        // Barcodes.dat, barcode -> subject
  std::vector<std::string> warnings;            // what was read but looks wrong or was repaired
};

/// Measurements taken at one instant (one camera frame).
struct MrclamMeasurementGroup {
  double stamp = 0.0;
  std::vector<MrclamMeasurement> measurements;
};

// Every parser below skips blank lines and lines starting with '#' (after blanks), accepts
// spaces, tabs and CRLF, and throws std::runtime_error "SOURCE:LINE: why" when a line does not
// hold the expected count of finite numbers or an integer field is not an integer.

/// RobotN_Odometry.dat.
std::vector<MrclamOdometry> parseMrclamOdometry(std::istream& in, const std::string& source);

/// RobotN_Measurement.dat; subjects are left at -1 (see resolveSubjects()).
std::vector<MrclamMeasurement> parseMrclamMeasurements(std::istream& in, const std::string& source);

/// Barcodes.dat (`subject barcode`), as barcode -> subject. Also throws on a repeated barcode.
std::map<int, int> parseMrclamBarcodes(std::istream& in, const std::string& source);

/// RobotN_Groundtruth.dat (`t x y theta`); with `lines`, each pose's 1-based line number too.
std::vector<StampedPose> parseMrclamGroundTruth(std::istream& in, const std::string& source,
                                                std::vector<std::size_t>* lines = nullptr);

/// Landmark_Groundtruth.dat; a subject below kMrclamFirstLandmarkSubject (a robot) is an error.
std::vector<MrclamLandmark> parseMrclamLandmarks(std::istream& in, const std::string& source);

/// Sets every measurement's subject from its barcode (-1 when the barcode is not in the table).
void resolveSubjects(const std::map<int, int>& subject_of_barcode,
                     std::vector<MrclamMeasurement>* measurements);

/// Reads DIR/Barcodes.dat, DIR/Landmark_Groundtruth.dat and DIR/RobotN_{Odometry,Measurement,
/// Groundtruth}.dat. Throws std::runtime_error naming the file when one is missing, malformed or
/// holds no data line (the measurements may be empty), std::invalid_argument when robot is not
/// 1..5. Sorts every file by time; commands, sightings and ground-truth poses out of time order,
/// commands sharing a stamp (the first at a stamp is the one integrated), sighting lines
/// repeating one of their frame exactly (kept once) and sighted landmarks without a surveyed
/// position are reported in `warnings`; stretches without ground truth are left to reportGroundTruthGaps()
/// (after a crop, so that only the stretches in the part kept are reported).
MrclamRobot readMrclamRobot(const std::string& directory, int robot);

/// Keeps only what lies in [start, start + duration_s] for odometry, measurements and ground
/// truth, where start is the first odometry stamp plus skip_s (a recording that begins later,
/// somewhere else); duration_s 0 keeps everything from start on. Throws
/// std::invalid_argument, changing nothing, for a negative or non-finite skip_s or duration_s,
/// or when no odometry command would remain.
void cropMrclamRobot(double skip_s, double duration_s, MrclamRobot* data);

/// Adds to `warnings` the stretches of more than kMrclamGroundTruthGapS without a ground-truth
/// pose, between two poses or from the last pose to the last command (their count, the longest
/// and where it starts), naming `source` (the ground-truth file); ground truth and commands
/// sorted by time, as readMrclamRobot() leaves them.
void reportGroundTruthGaps(const std::string& source, MrclamRobot* data);

/// Moves every odometry command `delay_s` later: the logged velocity commands lead the robot's
/// motion (dataset 6, fitted against Vicon: 0.15-0.2 s on all five robots), so a command is
/// applied from its stamp + delay_s. Measurements and ground truth keep their stamps. Throws
/// std::invalid_argument for a negative or non-finite delay.
void delayMrclamCommands(double delay_s, MrclamRobot* data);

/// The ground-truth pose at `stamp`, interpolated linearly (heading along the shorter arc)
/// between the two poses around it; the end pose outside the span. Throws std::invalid_argument
/// on an empty trajectory. `trajectory` must be sorted by stamp.
core::Pose2 interpolatePose(const std::vector<StampedPose>& trajectory, double stamp);

/// Dead reckoning from the velocity commands: one pose per command stamp, starting at `start`
/// at the first stamp; command i holds from its stamp until the next one (exact arcs of a
/// unicycle). Commands with a stamp not after the previous one are skipped, and so is any
/// interval longer than max_gap_s (the robot is assumed to stand still then; *not_integrated
/// counts them). The robots send a command at least every ~1 s while they drive, sometimes a
/// few ms later (dataset 6: up to 1.03 s, with Vicon showing turns of 0.3 rad across them), so
/// the default leaves room above that.
constexpr double kMrclamMaxCommandGapS = 2.0;
std::vector<StampedPose> integrateMrclamOdometry(const std::vector<MrclamOdometry>& odometry,
                                                 const core::Pose2& start,
                                                 double max_gap_s = kMrclamMaxCommandGapS,
                                                 int* not_integrated = nullptr);

/// The landmark sightings (subject >= first_landmark_subject; robots and unknown barcodes are
/// dropped) grouped by equal stamp, in time order.
std::vector<MrclamMeasurementGroup> groupLandmarkMeasurements(
    const std::vector<MrclamMeasurement>& measurements,
    int first_landmark_subject = kMrclamFirstLandmarkSubject);

}  // namespace io
}  // namespace rbpf_slam

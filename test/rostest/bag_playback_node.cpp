// Plays along with a bag (see bag_laser.test): collects what rbpf_slam_node publishes until
// the bag ends, then checks the landmarks, the final map -> base_link pose against a
// reference trajectory, and that nothing non-finite was published.

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <std_srvs/Empty.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "rbpf_slam/MapFile.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/io/evaluation.h"
#include "rbpf_slam/io/landmark_file.h"
#include "rbpf_slam/ros/conversions.h"

namespace rbpf_slam {
namespace {

struct StampedPose {
  double stamp = 0.0;
  core::Pose2 pose = core::Pose2::Zero();
};

std::vector<StampedPose> readTum(const std::string& path) {
  std::vector<StampedPose> poses;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, x, y, z, qx, qy, qz, qw;
    if (!(fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) continue;
    const double yaw = std::atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz));
    poses.push_back({t, core::Pose2(x, y, yaw)});
  }
  return poses;
}

template <typename Array>
bool allFinite(const Array& values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

/// Subscribes to the node's outputs and tf, and remembers what the checks need.
class PlaybackObserver {
 public:
  PlaybackObserver()
      : private_nh_("~"), tf_buffer_(ros::Duration(3600.0)), tf_listener_(tf_buffer_, nh_) {
    private_nh_.param<std::string>("slam_node", slam_node_, "rbpf_slam_node");
    private_nh_.param<std::string>("map_frame", map_frame_, "map");
    private_nh_.param<std::string>("odom_frame", odom_frame_, "odom");
    private_nh_.param<std::string>("base_frame", base_frame_, "base_link");
    const std::string prefix = "/" + slam_node_ + "/";
    landmarks_sub_ = nh_.subscribe(prefix + "landmarks", 100, &PlaybackObserver::onLandmarks, this);
    pose_sub_ = nh_.subscribe(prefix + "pose", 100, &PlaybackObserver::onPose, this);
    path_sub_ = nh_.subscribe(prefix + "trajectory", 10, &PlaybackObserver::onPath, this);
    map_sub_ = nh_.subscribe(prefix + "map", 2, &PlaybackObserver::onMap, this);
    tf_sub_ = nh_.subscribe("/tf", 1000, &PlaybackObserver::onTf, this);
  }

  /// Waits until the clock has passed end_stamp and the node published a pose at or after
  /// last_update_stamp and a path reaching it (or settle_s wall seconds went by); false after
  /// timeout_s.
  bool waitForEnd(double end_stamp, double last_update_stamp, double settle_s, double timeout_s) {
    const ros::WallTime start = ros::WallTime::now();
    ros::WallTime clock_passed_end;
    ros::WallTime clock_changed = start;
    double last_clock = -1.0;
    ros::WallRate rate(20.0);
    while (ros::ok() && (ros::WallTime::now() - start).toSec() < timeout_s) {
      const double now = ros::Time::now().toSec();
      if (now != last_clock) {
        last_clock = now;
        clock_changed = ros::WallTime::now();
      }
      // A bag whose last message is the last reference pose: the player's clock stops just
      // short of it. Stopped within a scan period of the end for settle_s: the bag is over.
      if (now >= last_update_stamp - 0.5 &&
          (ros::WallTime::now() - clock_changed).toSec() > settle_s) {
        return true;
      }
      if (now >= end_stamp) {
        if (clock_passed_end.isZero()) clock_passed_end = ros::WallTime::now();
        std::lock_guard<std::mutex> lock(mutex_);
        // ~trajectory trails ~pose by up to the node's trajectory_publish_period: wait for the
        // path to reach the last pose too.
        const bool path_caught_up =
            !last_path_.poses.empty() &&
            last_path_.poses.back().header.stamp.toSec() >= last_pose_stamp_ - 1e-3;
        if ((last_pose_stamp_ >= last_update_stamp - 1e-3 && path_caught_up) ||
            (ros::WallTime::now() - clock_passed_end).toSec() > settle_s) {
          return true;
        }
      }
      rate.sleep();
    }
    return false;
  }

  tf2_ros::Buffer& tf() { return tf_buffer_; }
  const std::string& slamNode() const { return slam_node_; }
  const std::string& mapFrame() const { return map_frame_; }
  const std::string& odomFrame() const { return odom_frame_; }
  const std::string& baseFrame() const { return base_frame_; }

  std::mutex mutex_;
  int landmark_messages_ = 0;
  int last_adds_ = 0;     // ADD markers in the latest landmarks message
  int last_deletes_ = 0;  // DELETE markers in the latest landmarks message
  int max_line_markers_ = 0;
  int max_point_markers_ = 0;
  int malformed_markers_ = 0;
  int poses_ = 0;
  int non_finite_poses_ = 0;
  double first_pose_sigma_ = -1.0;  // the first ~pose's position sigma, sqrt(var x + var y)
  double last_pose_stamp_ = 0.0;
  nav_msgs::Path last_path_;
  int map_to_odom_ = 0;
  int non_finite_map_to_odom_ = 0;
  long max_occupied_cells_ = 0;  // the most occupied (>= 65) and free (< 20) cells of one ~map
  long max_free_cells_ = 0;

 private:
  void onLandmarks(const visualization_msgs::MarkerArray& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++landmark_messages_;
    int lines = 0, points = 0;
    last_adds_ = last_deletes_ = 0;
    for (const auto& m : msg.markers) {
      if (m.action == visualization_msgs::Marker::DELETE) ++last_deletes_;
      if (m.action != visualization_msgs::Marker::ADD) continue;
      ++last_adds_;
      if (m.ns == "points") ++points;
      if (m.ns == "lines") {
        if (m.type == visualization_msgs::Marker::LINE_LIST && m.points.size() == 2) {
          ++lines;
        } else {
          ++malformed_markers_;
        }
      }
      for (const auto& p : m.points) {
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
          ++malformed_markers_;
        }
      }
    }
    max_line_markers_ = std::max(max_line_markers_, lines);
    max_point_markers_ = std::max(max_point_markers_, points);
  }

  void onPose(const geometry_msgs::PoseWithCovarianceStamped& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++poses_;
    const auto& p = msg.pose.pose;
    const std::vector<double> values{p.position.x,    p.position.y,    p.position.z,
                                     p.orientation.x, p.orientation.y, p.orientation.z,
                                     p.orientation.w};
    if (!allFinite(values) || !allFinite(msg.pose.covariance)) ++non_finite_poses_;
    if (poses_ == 1) first_pose_sigma_ = std::sqrt(msg.pose.covariance[0] + msg.pose.covariance[7]);
    last_pose_stamp_ = std::max(last_pose_stamp_, msg.header.stamp.toSec());
  }

  void onMap(const nav_msgs::OccupancyGrid& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    const long occupied = std::count_if(msg.data.begin(), msg.data.end(),
                                        [](int8_t v) { return v >= 65 && v <= 100; });
    const long free =
        std::count_if(msg.data.begin(), msg.data.end(), [](int8_t v) { return v >= 0 && v < 20; });
    max_occupied_cells_ = std::max(max_occupied_cells_, occupied);
    max_free_cells_ = std::max(max_free_cells_, free);
  }

  void onPath(const nav_msgs::Path& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    last_path_ = msg;
  }

  void onTf(const tf2_msgs::TFMessage& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& t : msg.transforms) {
      if (t.header.frame_id != map_frame_ || t.child_frame_id != odom_frame_) continue;
      ++map_to_odom_;
      const auto& r = t.transform.rotation;
      const auto& x = t.transform.translation;
      const std::vector<double> values{x.x, x.y, x.z, r.x, r.y, r.z, r.w};
      if (!allFinite(values)) ++non_finite_map_to_odom_;
    }
  }

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  std::string slam_node_, map_frame_, odom_frame_, base_frame_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber landmarks_sub_, pose_sub_, path_sub_, map_sub_, tf_sub_;
};

/// Plays the bag once for all tests of the suite.
class BagPlaybackTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ros::NodeHandle private_nh("~");
    private_nh.param<std::string>("reference", reference_path_, "");
    private_nh.param("position_tolerance", position_tolerance_, 1.0);
    private_nh.param("ate_tolerance", ate_tolerance_, 0.0);
    private_nh.param("ate_odometry_ratio", ate_odometry_ratio_, 0.0);
    private_nh.param("yaw_tolerance", yaw_tolerance_, 0.3);
    double end_margin = 1.0, settle = 10.0, timeout = 600.0;
    private_nh.param("end_margin", end_margin, end_margin);
    private_nh.param("settle", settle, settle);
    private_nh.param("timeout", timeout, timeout);
    // Subscribe first: a live simulation writes its ground truth only when its route is done.
    observer_ = std::make_unique<PlaybackObserver>();
    spinner_ = std::make_unique<ros::AsyncSpinner>(1);
    spinner_->start();
    double reference_wait = 0.0;
    private_nh.param("reference_wait", reference_wait, reference_wait);
    const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(reference_wait);
    while (!std::ifstream(reference_path_).good() && ros::WallTime::now() < give_up) {
      ros::WallDuration(0.2).sleep();
    }
    // ~global_localization: no start is given; the node is asked to spread its particles over
    // its map before the player starts: the player waits for ~ready_file, written after the
    // call (play_simulated_bag.sh's READY_FILE).
    private_nh.param("global_localization", global_localization_, false);
    bool call = true;  // false: the node starts globally by its config (global_localization)
    private_nh.param("call_global_localization", call, call);
    if (global_localization_) {
      // Called, or (by config) only waited for: the node is up before the player starts.
      const std::string service = "/" + observer_->slamNode() + "/global_localization";
      std_srvs::Empty request;
      global_localization_accepted_ = ros::service::waitForService(service, ros::Duration(30.0)) &&
                                      (!call || ros::service::call(service, request));
      std::lock_guard<std::mutex> lock(observer_->mutex_);
      poses_before_global_localization_ = observer_->poses_;
    }
    std::string ready_file;
    private_nh.param<std::string>("ready_file", ready_file, "");
    if (!ready_file.empty()) std::ofstream(ready_file) << "ready\n";
    reference_ = readTum(reference_path_);
    if (reference_.empty()) return;
    const double last = reference_.back().stamp;
    ended_ = observer_->waitForEnd(last + end_margin, last, settle, timeout);
  }

  static void TearDownTestSuite() {
    spinner_->stop();
    spinner_.reset();
    observer_.reset();
  }

  static std::string reference_path_;
  static std::vector<StampedPose> reference_;
  static double position_tolerance_, yaw_tolerance_;
  static double ate_tolerance_;       // 0: the ~trajectory's ATE is not checked
  static double ate_odometry_ratio_;  // 0: ... nor compared with odometry's
  static bool ended_;
  static bool global_localization_, global_localization_accepted_;
  static int poses_before_global_localization_;
  static std::unique_ptr<PlaybackObserver> observer_;
  static std::unique_ptr<ros::AsyncSpinner> spinner_;
};

std::string BagPlaybackTest::reference_path_;
std::vector<StampedPose> BagPlaybackTest::reference_;
double BagPlaybackTest::position_tolerance_ = 1.0;
double BagPlaybackTest::ate_tolerance_ = 0.0;
double BagPlaybackTest::ate_odometry_ratio_ = 0.0;
double BagPlaybackTest::yaw_tolerance_ = 0.3;
bool BagPlaybackTest::ended_ = false;
bool BagPlaybackTest::global_localization_ = false;
bool BagPlaybackTest::global_localization_accepted_ = false;
int BagPlaybackTest::poses_before_global_localization_ = 0;
std::unique_ptr<PlaybackObserver> BagPlaybackTest::observer_;
std::unique_ptr<ros::AsyncSpinner> BagPlaybackTest::spinner_;

TEST_F(BagPlaybackTest, BagPlayedToTheEnd) {
  ASSERT_FALSE(reference_.empty()) << "cannot read the reference '" << reference_path_ << "'";
  EXPECT_TRUE(ended_) << "the clock never reached the end of the bag (last reference stamp "
                      << std::fixed << reference_.back().stamp << ", now "
                      << ros::Time::now().toSec() << ")";
}

// ~expected_markers: "lines" (laser configs), "points" (range-bearing landmarks), "both" or
// "none" (grid_pf maps cells: no landmark kind is required, the markers are still checked);
// ~min_line_markers (default 1): the fewest line landmarks one ~landmarks message must show.
TEST_F(BagPlaybackTest, LandmarkMarkersContainTheExpectedKinds) {
  std::string expected = "lines";
  int min_lines = 1;
  ros::NodeHandle("~").param<std::string>("expected_markers", expected, expected);
  ros::NodeHandle("~").param("min_line_markers", min_lines, min_lines);
  std::lock_guard<std::mutex> lock(observer_->mutex_);
  if (expected != "none") {
    EXPECT_GT(observer_->landmark_messages_, 0) << "nothing on ~landmarks";
  }
  if (expected == "lines" || expected == "both") {
    EXPECT_GE(observer_->max_line_markers_, std::max(min_lines, 1))
        << "too few LINE_LIST markers in namespace 'lines'";
  }
  if (expected == "points" || expected == "both") {
    EXPECT_GT(observer_->max_point_markers_, 0) << "no marker in namespace 'points'";
  }
  EXPECT_TRUE(expected == "lines" || expected == "points" || expected == "both" ||
              expected == "none")
      << "~expected_markers = '" << expected << "' is not lines, points, both or none";
  EXPECT_EQ(observer_->malformed_markers_, 0);
  RecordProperty("max_line_markers", observer_->max_line_markers_);
  RecordProperty("max_point_markers", observer_->max_point_markers_);
}

TEST_F(BagPlaybackTest, NothingNonFinitePublished) {
  std::lock_guard<std::mutex> lock(observer_->mutex_);
  EXPECT_GT(observer_->map_to_odom_, 0) << "map -> odom never published on /tf";
  EXPECT_EQ(observer_->non_finite_map_to_odom_, 0) << "non-finite map -> odom on /tf";
  EXPECT_GT(observer_->poses_, 0) << "nothing on ~pose";
  EXPECT_EQ(observer_->non_finite_poses_, 0) << "non-finite values on ~pose";
}

// ~global_localization: the node accepted ~global_localization before the first frame, and its
// first ~pose was spread over the map (position sigma above ~min_first_sigma, default 0.1 m),
// so that a final pose on the truth was found, not given.
TEST_F(BagPlaybackTest, GlobalLocalizationSpreadTheParticles) {
  if (!global_localization_) GTEST_SKIP() << "~global_localization not set by this launch file";
  double min_first_sigma = 0.1;
  ros::NodeHandle("~").param("min_first_sigma", min_first_sigma, min_first_sigma);
  EXPECT_TRUE(global_localization_accepted_)
      << "/" << observer_->slamNode() << "/global_localization was not there or refused";
  EXPECT_EQ(poses_before_global_localization_, 0)
      << "~global_localization was called after the first frame (the player did not wait)";
  std::lock_guard<std::mutex> lock(observer_->mutex_);
  std::cout << "[bag_playback] first ~pose position sigma " << observer_->first_pose_sigma_ << " m"
            << std::endl;
  EXPECT_GT(observer_->first_pose_sigma_, min_first_sigma)
      << "the first ~pose was not spread over the map";
}

// ~reference_in_map_frame: the reference is in the node's map frame (a world on its floor
// plan), compared as it is; otherwise it is aligned on the trajectory's first pose.
// ~mirror_centre [x, y]: the pose turned by half a turn about this point (a symmetric arena's
// look-alike, which no sensor tells apart) counts as well.
TEST_F(BagPlaybackTest, FinalPoseMatchesReference) {
  ASSERT_FALSE(reference_.empty());
  nav_msgs::Path path;
  {
    std::lock_guard<std::mutex> lock(observer_->mutex_);
    path = observer_->last_path_;
  }
  ASSERT_FALSE(path.poses.empty()) << "nothing on ~trajectory";
  // The map frame starts wherever the node's first update put it; align the reference on
  // the trajectory's first pose (same stamp as one reference pose: both are scan times).
  const double first_stamp = path.poses.front().header.stamp.toSec();
  const StampedPose* first_reference = nullptr;
  for (const auto& r : reference_) {
    if (std::fabs(r.stamp - first_stamp) < 0.01) first_reference = &r;
  }
  ASSERT_NE(first_reference, nullptr)
      << "no reference pose at the first trajectory stamp " << std::fixed << first_stamp;
  const core::Pose2 first_map = rosbridge::toPose2(path.poses.front().pose);
  bool in_map_frame = false;
  std::vector<double> mirror_centre;
  ros::NodeHandle("~").param("reference_in_map_frame", in_map_frame, in_map_frame);
  ros::NodeHandle("~").param("mirror_centre", mirror_centre, mirror_centre);
  ASSERT_TRUE(mirror_centre.empty() || mirror_centre.size() == 2)
      << "~mirror_centre must be [x, y]";
  const core::Pose2 reference_to_map =
      in_map_frame ? core::Pose2::Zero()
                   : core::compose(first_map, core::inverse(first_reference->pose));
  const StampedPose& last = reference_.back();
  core::Pose2 expected = core::compose(reference_to_map, last.pose);

  // Final map -> base_link: the latest map -> odom correction applied to odometry at the last
  // reference (scan) time.
  core::Pose2 map_to_odom, odom_to_base, odom_at_first;
  try {
    tf2_ros::Buffer& tf = observer_->tf();
    map_to_odom = rosbridge::toPose2(
        tf.lookupTransform(observer_->mapFrame(), observer_->odomFrame(), ros::Time(0)).transform);
    odom_to_base = rosbridge::toPose2(
        tf.lookupTransform(observer_->odomFrame(), observer_->baseFrame(), ros::Time(last.stamp))
            .transform);
    odom_at_first = rosbridge::toPose2(
        tf.lookupTransform(observer_->odomFrame(), observer_->baseFrame(), ros::Time(first_stamp))
            .transform);
  } catch (const tf2::TransformException& e) {
    FAIL() << "tf lookup failed: " << e.what();
  }
  const core::Pose2 final_pose = core::compose(map_to_odom, odom_to_base);
  bool on_mirror = false;
  if (!mirror_centre.empty()) {
    const core::Pose2 mirror(2.0 * mirror_centre[0] - expected.x(),
                             2.0 * mirror_centre[1] - expected.y(),
                             core::wrapAngle(expected.z() + M_PI));
    on_mirror = (final_pose.head<2>() - mirror.head<2>()).norm() <
                (final_pose.head<2>() - expected.head<2>()).norm();
    if (on_mirror) expected = mirror;
  }
  const double position_error = (final_pose.head<2>() - expected.head<2>()).norm();
  const double yaw_error = std::fabs(core::wrapAngle(final_pose.z() - expected.z()));

  // Odometry alone, aligned the same way, for scale.
  const core::Pose2 odom_expected =
      core::compose(core::compose(odom_at_first, core::inverse(first_reference->pose)), last.pose);
  const double odom_position_error = (odom_to_base.head<2>() - odom_expected.head<2>()).norm();
  const double odom_yaw_error = std::fabs(core::wrapAngle(odom_to_base.z() - odom_expected.z()));

  std::ostringstream summary;
  summary << std::fixed;
  summary.precision(3);
  summary << (on_mirror ? "(on the mirror) " : "") << "final pose error " << position_error
          << " m, " << yaw_error << " rad (tolerance " << position_tolerance_ << " m, "
          << yaw_tolerance_ << " rad); odometry alone " << odom_position_error << " m, "
          << odom_yaw_error << " rad; " << path.poses.size() << " trajectory poses";
  ROS_INFO_STREAM("bag_playback: " << summary.str());
  std::cout << "[bag_playback] " << summary.str() << std::endl;
  RecordProperty("final_position_error_m", std::to_string(position_error));
  RecordProperty("final_yaw_error_rad", std::to_string(yaw_error));
  RecordProperty("odometry_position_error_m", std::to_string(odom_position_error));
  EXPECT_LE(position_error, position_tolerance_) << summary.str();
  EXPECT_LE(yaw_error, yaw_tolerance_) << summary.str();
}

// The whole ~trajectory against the reference (ATE after a rigid 2D alignment): one final
// pose says less than the path, and wanders more from run to run.
// With ~ate_odometry_ratio the ATE must also be at most that fraction of odometry's own ATE
// (odom -> base_link from tf at the same stamps, aligned the same way): a node that ignored its
// sensors and published odometry would pass an absolute bound on a short run.
TEST_F(BagPlaybackTest, TrajectoryAteWithinTolerance) {
  if (ate_tolerance_ <= 0.0 && ate_odometry_ratio_ <= 0.0) {
    GTEST_SKIP() << "neither ~ate_tolerance nor ~ate_odometry_ratio set by this launch file";
  }
  ASSERT_FALSE(reference_.empty());
  nav_msgs::Path path;
  {
    std::lock_guard<std::mutex> lock(observer_->mutex_);
    path = observer_->last_path_;
  }
  ASSERT_FALSE(path.poses.empty()) << "nothing on ~trajectory";
  std::vector<io::StampedPose> estimate, odometry, reference;
  int odometry_missing = 0;
  for (const auto& p : path.poses) {
    estimate.push_back({p.header.stamp.toSec(), rosbridge::toPose2(p.pose)});
    try {
      odometry.push_back(
          {p.header.stamp.toSec(),
           rosbridge::toPose2(
               observer_->tf()
                   .lookupTransform(observer_->odomFrame(), observer_->baseFrame(), p.header.stamp)
                   .transform)});
    } catch (const tf2::TransformException&) {
      ++odometry_missing;
    }
  }
  for (const auto& r : reference_) reference.push_back({r.stamp, r.pose});
  io::EvaluationOptions options;
  const io::EvaluationResult result = io::evaluateTrajectory(estimate, reference, options);
  const io::EvaluationResult odometry_result = io::evaluateTrajectory(odometry, reference, options);
  std::cout << "[bag_playback] trajectory ATE " << result.ate_rmse_m << " m over "
            << result.matched_poses << " poses (tolerance " << ate_tolerance_
            << " m); odometry alone " << odometry_result.ate_rmse_m << " m over "
            << odometry_result.matched_poses << " poses (ratio "
            << result.ate_rmse_m / odometry_result.ate_rmse_m << ", at most " << ate_odometry_ratio_
            << ")" << std::endl;
  RecordProperty("ate_rmse_m", std::to_string(result.ate_rmse_m));
  RecordProperty("odometry_ate_rmse_m", std::to_string(odometry_result.ate_rmse_m));
  EXPECT_GE(result.matched_poses, estimate.size() / 2);
  if (ate_tolerance_ > 0.0) {
    EXPECT_LE(result.ate_rmse_m, ate_tolerance_);
  }
  if (ate_odometry_ratio_ > 0.0) {
    ASSERT_GE(odometry_result.matched_poses, estimate.size() / 2)
        << odometry_missing << " trajectory stamps without odom -> base in tf";
    EXPECT_LE(result.ate_rmse_m, ate_odometry_ratio_ * odometry_result.ate_rmse_m)
        << "the trajectory is not clearly better than odometry alone";
  }
}

// ~save_map_prefix set (a config with smoothing.enabled): ~save_map at the end of the bag
// writes the map smoothed over every frame, says so, and the file loads back, finite.
TEST_F(BagPlaybackTest, SaveMapSmoothsTheMap) {
  std::string prefix;
  ros::NodeHandle("~").param<std::string>("save_map_prefix", prefix, "");
  if (prefix.empty()) GTEST_SKIP() << "no ~save_map_prefix";
  const std::string service = "/" + observer_->slamNode() + "/save_map";
  ASSERT_TRUE(ros::service::waitForService(service, ros::Duration(10.0))) << service;
  MapFile call;
  call.request.path = prefix;
  ASSERT_TRUE(ros::service::call(service, call));
  EXPECT_TRUE(call.response.success) << call.response.message;
  EXPECT_NE(call.response.message.find("(smoothed: "), std::string::npos)
      << call.response.message;
  const std::vector<core::LandmarkEstimate> landmarks =
      io::loadLandmarksYaml(prefix + ".landmarks.yaml");
  EXPECT_GT(landmarks.size(), 3u);
  for (const core::LandmarkEstimate& l : landmarks) {
    EXPECT_TRUE(l.mean.allFinite() && l.covariance.allFinite()) << "landmark " << l.id;
  }
}

// ~min_occupied_cells / ~min_free_cells (grid_pf): one ~map must have held at least that many
// occupied (>= 65) and free (< 20) cells; a node that read only some of its sensors maps less.
// ~max_occupied_cells: no ~map may have held more (localization only on a loaded map).
TEST_F(BagPlaybackTest, GridMapHoldsEnoughCells) {
  int min_occupied = 0, min_free = 0, max_occupied = 0;
  ros::NodeHandle("~").param("min_occupied_cells", min_occupied, 0);
  ros::NodeHandle("~").param("min_free_cells", min_free, 0);
  ros::NodeHandle("~").param("max_occupied_cells", max_occupied, 0);
  if (min_occupied <= 0 && min_free <= 0 && max_occupied <= 0) {
    GTEST_SKIP() << "none of ~min_occupied_cells, ~min_free_cells, ~max_occupied_cells set by "
                    "this launch file";
  }
  std::lock_guard<std::mutex> lock(observer_->mutex_);
  RecordProperty("max_occupied_cells", std::to_string(observer_->max_occupied_cells_));
  RecordProperty("max_free_cells", std::to_string(observer_->max_free_cells_));
  EXPECT_GE(observer_->max_occupied_cells_, min_occupied);
  EXPECT_GE(observer_->max_free_cells_, min_free);
  if (max_occupied > 0) {
    EXPECT_LE(observer_->max_occupied_cells_, max_occupied);
  }
}

// Runs last (gtest keeps the order of definition): it clears the node's map.
TEST_F(BagPlaybackTest, ResetServiceDeletesTheLandmarks) {
  const std::string service = "/" + observer_->slamNode() + "/reset";
  ASSERT_TRUE(ros::service::waitForService(service, ros::Duration(10.0))) << service;
  std_srvs::Empty call;
  ASSERT_TRUE(ros::service::call(service, call));
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  std::string expected = "lines";  // "none" (grid_pf): no landmark, so no DELETE either
  ros::NodeHandle("~").param<std::string>("expected_markers", expected, expected);
  bool cleared = false;
  while (!cleared && ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(observer_->mutex_);
      cleared = observer_->last_adds_ == 0 &&
                (observer_->last_deletes_ > 0 || expected == "none") &&
                observer_->last_path_.poses.empty();
    }
    ros::WallDuration(0.05).sleep();
  }
  EXPECT_TRUE(cleared) << "after ~reset: expected only DELETE markers and an empty trajectory";
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "bag_playback");
  return RUN_ALL_TESTS();
}

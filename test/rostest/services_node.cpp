// The services and topics a user drives rbpf_slam_node with, on a bag simulated at test
// time (services.test): ~pause / ~resume stop and restart the updates, ~save_map writes a
// landmark file that loads back and a map_server picture, ~load_map reports bad paths,
// initialpose moves the estimate to the given pose. Run in this order on one node.

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <rbpf_slam/MapFile.h>
#include <ros/ros.h>
#include <std_srvs/Empty.h>

#include <cmath>
#include <fstream>
#include <mutex>
#include <string>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/io/landmark_file.h"
#include "rbpf_slam/ros/conversions.h"

namespace rbpf_slam {
namespace {

/// Latest ~trajectory and ~pose of the node.
class NodeObserver {
 public:
  NodeObserver() {
    ros::NodeHandle nh;
    path_sub_ = nh.subscribe("/rbpf_slam_node/trajectory", 10, &NodeObserver::onPath, this);
    pose_sub_ = nh.subscribe("/rbpf_slam_node/pose", 10, &NodeObserver::onPose, this);
  }
  size_t trajectorySize() {
    std::lock_guard<std::mutex> lock(mutex_);
    return trajectory_size_;
  }
  /// The first ~pose received after `after` (wall time), if any within timeout_s.
  /// With xx_variance, the x variance ~pose reported with it.
  bool poseAfter(const ros::WallTime& after, double timeout_s, core::Pose2* pose,
                 double* xx_variance = nullptr) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::WallTime::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (pose_received_ > after) {
          *pose = last_pose_;
          if (xx_variance) *xx_variance = last_xx_variance_;
          return true;
        }
      }
      ros::WallDuration(0.02).sleep();
    }
    return false;
  }
  /// Waits until the trajectory has at least n poses.
  bool waitForTrajectory(size_t n, double timeout_s) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::WallTime::now() < deadline) {
      if (trajectorySize() >= n) return true;
      ros::WallDuration(0.05).sleep();
    }
    return false;
  }

 private:
  void onPath(const nav_msgs::Path& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    trajectory_size_ = msg.poses.size();
  }
  void onPose(const geometry_msgs::PoseWithCovarianceStamped& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    last_pose_ = rosbridge::toPose2(msg.pose.pose);
    last_xx_variance_ = msg.pose.covariance[0];
    pose_received_ = ros::WallTime::now();
  }
  std::mutex mutex_;
  size_t trajectory_size_ = 0;
  core::Pose2 last_pose_ = core::Pose2::Zero();
  double last_xx_variance_ = 0.0;
  ros::WallTime pose_received_;
  ros::Subscriber path_sub_, pose_sub_;
};

class ServicesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    observer_ = std::make_unique<NodeObserver>();
    spinner_ = std::make_unique<ros::AsyncSpinner>(1);
    spinner_->start();
    ros::NodeHandle("~").param<std::string>("workdir", workdir_, "/tmp");
  }
  static void TearDownTestSuite() {
    spinner_->stop();
    spinner_.reset();
    observer_.reset();
  }
  static bool call(const std::string& name) {
    const std::string service = "/rbpf_slam_node/" + name;
    if (!ros::service::waitForService(service, ros::Duration(20.0))) return false;
    std_srvs::Empty empty;
    return ros::service::call(service, empty);
  }
  static bool callMapFile(const std::string& name, const std::string& path, MapFile* srv) {
    const std::string service = "/rbpf_slam_node/" + name;
    if (!ros::service::waitForService(service, ros::Duration(20.0))) return false;
    srv->request.path = path;
    return ros::service::call(service, *srv);
  }
  static std::unique_ptr<NodeObserver> observer_;
  static std::unique_ptr<ros::AsyncSpinner> spinner_;
  static std::string workdir_;
};
std::unique_ptr<NodeObserver> ServicesTest::observer_;
std::unique_ptr<ros::AsyncSpinner> ServicesTest::spinner_;
std::string ServicesTest::workdir_;

TEST_F(ServicesTest, PauseStopsUpdatesAndResumeRestartsThem) {
  ASSERT_TRUE(observer_->waitForTrajectory(20, 120.0)) << "the node never mapped 20 frames";
  ASSERT_TRUE(call("pause"));
  // An update in flight may still land, and ~trajectory follows the updates by up to about
  // two of the node's trajectory_publish_period (0.5 s).
  ros::WallDuration(2.0).sleep();
  const size_t paused_at = observer_->trajectorySize();
  ros::WallDuration(2.0).sleep();  // 8 s of bag at rate 4: about 40 scans offered
  EXPECT_EQ(observer_->trajectorySize(), paused_at) << "updates went on while paused";
  ASSERT_TRUE(call("resume"));
  EXPECT_TRUE(observer_->waitForTrajectory(paused_at + 5, 20.0)) << "no update after ~resume";
}

TEST_F(ServicesTest, SaveMapWritesALandmarkFileThatLoadsBack) {
  MapFile srv;
  const std::string prefix = workdir_ + "/saved";
  ASSERT_TRUE(callMapFile("save_map", prefix, &srv));
  EXPECT_TRUE(srv.response.success) << srv.response.message;
  const std::vector<core::LandmarkEstimate> landmarks =
      io::loadLandmarksYaml(prefix + ".landmarks.yaml");
  EXPECT_GT(landmarks.size(), 3u);
  EXPECT_TRUE(std::ifstream(prefix + ".pgm").good());
  std::ifstream yaml(prefix + ".yaml");
  const std::string text((std::istreambuf_iterator<char>(yaml)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("image: \"saved.pgm\""), std::string::npos) << text;

  MapFile load;
  ASSERT_TRUE(callMapFile("load_map", prefix + ".landmarks.yaml", &load));
  EXPECT_TRUE(load.response.success) << load.response.message;
}

TEST_F(ServicesTest, LoadMapReportsAMissingFile) {
  MapFile srv;
  ASSERT_TRUE(callMapFile("load_map", workdir_ + "/no_such_map.yaml", &srv));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("no_such_map.yaml"), std::string::npos)
      << srv.response.message;
}

// ~global_localization (amcl's name) spreads grid_pf's particles over a loaded grid map; a
// landmark variant has none and must refuse the call (offline: grid_localization.sh).
TEST_F(ServicesTest, GlobalLocalizationIsRefusedWithoutAGridMap) {
  const std::string service = "/rbpf_slam_node/global_localization";
  ASSERT_TRUE(ros::service::waitForService(service, ros::Duration(20.0))) << service;
  std_srvs::Empty empty;
  EXPECT_FALSE(ros::service::call(service, empty));
}

TEST_F(ServicesTest, InitialPoseMovesTheEstimate) {
  ros::NodeHandle nh;
  ros::Publisher publisher = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("/initialpose", 1);
  const ros::WallTime connect_deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  while (publisher.getNumSubscribers() == 0 && ros::WallTime::now() < connect_deadline) {
    ros::WallDuration(0.05).sleep();
  }
  ASSERT_GT(publisher.getNumSubscribers(), 0u) << "rbpf_slam_node does not listen to initialpose";
  ASSERT_TRUE(call("pause"));  // no update between the request and the check
  ros::WallDuration(0.3).sleep();
  geometry_msgs::PoseWithCovarianceStamped msg;
  msg.header.frame_id = "map";
  msg.header.stamp = ros::Time::now();
  const core::Pose2 requested(2.0, 3.0, 1.2);
  msg.pose.pose = rosbridge::toPoseMsg(requested);
  msg.pose.covariance[0] = msg.pose.covariance[7] = 1e-4;
  msg.pose.covariance[35] = 1e-5;
  const ros::WallTime sent = ros::WallTime::now();
  publisher.publish(msg);
  core::Pose2 pose;
  ASSERT_TRUE(observer_->poseAfter(sent, 10.0, &pose)) << "no ~pose after initialpose";
  EXPECT_LT((pose.head<2>() - requested.head<2>()).norm(), 0.05) << pose.transpose();
  EXPECT_LT(std::fabs(core::wrapAngle(pose.z() - requested.z())), 0.02) << pose.transpose();
  // An all-zero covariance (unset, as `rostopic pub` sends it) and an indefinite one (a
  // positive diagonal, xy = 1) both get rviz's 0.25 m^2: the particles spread, not collapse.
  for (const bool indefinite : {false, true}) {
    msg.pose.covariance.fill(0.0);
    if (indefinite) {
      msg.pose.covariance[0] = msg.pose.covariance[7] = 0.25;
      msg.pose.covariance[1] = msg.pose.covariance[6] = 1.0;
      msg.pose.covariance[35] = 0.0685;
    }
    const ros::WallTime again = ros::WallTime::now();
    publisher.publish(msg);
    double xx = 0.0;
    ASSERT_TRUE(observer_->poseAfter(again, 10.0, &pose, &xx)) << "indefinite " << indefinite;
    EXPECT_GT(xx, 0.1) << "indefinite " << indefinite;
    EXPECT_LT(xx, 0.5) << "indefinite " << indefinite;
  }
  EXPECT_TRUE(call("resume"));
}

TEST_F(ServicesTest, DiagnosticsReportTheNode) {
  ros::NodeHandle nh;
  std::mutex mutex;
  diagnostic_msgs::DiagnosticStatus last;
  bool received = false;
  ros::Subscriber sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
        for (const auto& status : msg->status) {
          if (status.name != "rbpf_slam_node") continue;
          std::lock_guard<std::mutex> lock(mutex);
          last = status;
          received = true;
        }
      });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(5.0);
  while (ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (received) break;
    }
    ros::WallDuration(0.05).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_TRUE(received) << "no rbpf_slam_node status on /diagnostics";
  long updates = -1;
  for (const auto& kv : last.values) {
    if (kv.key == "updates") updates = std::stol(kv.value);
  }
  EXPECT_GT(updates, 20) << "the report does not count the updates";
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "services_test");
  return RUN_ALL_TESTS();
}

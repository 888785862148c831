// landmark_tracker.test: the landmark_tracker node on a simulated lee_sim_b bag (range-bearing
// landmarks) publishes new-landmark events with increasing steps and stamps, each starting at
// least one landmark, and finite landmark markers in the odometry frame; /diagnostics reports
// its updates. One features message stamped 2 s behind the clock (a late message) is
// dropped (counted on /diagnostics as "dropped: old stamp"): no reset on /diagnostics, and the events' steps keep increasing (a reset used to
// restart them at 1). With it, an odom -> base_link transform on /tf stamped near 2^32 s (a
// driver's -1), which ended the node from tf2_ros's listener thread, is refused and counted
// ("dropped: refused transform") and the events go on.

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <rbpf_slam/FeatureArray.h>
#include <rbpf_slam/TrackerEvent.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <mutex>
#include <set>
#include <string>
#include <utility>

namespace rbpf_slam {
namespace {

struct Seen {
  std::mutex mutex;
  int events = 0, bad_events = 0, out_of_order = 0, non_finite = 0, wrong_frame = 0;
  int last_step = 0;
  double last_stamp = 0.0;
  double first_stamp = 0.0;  // of the first event
  std::set<std::pair<std::string, int>> shown;
  long updates = -1;
  long resets = -1;
  long late_dropped = 0;  // /diagnostics "dropped: old stamp"
  long refused = 0;       // /diagnostics "dropped: refused transform"
  int events_after_late = 0;  // events after the late message went out
  bool late_sent = false;
};

TEST(LandmarkTracker, PublishesEventsAndLandmarks) {
  ros::NodeHandle nh, pnh("~");
  const double timeout = pnh.param("timeout", 150.0);
  const int min_events = pnh.param("min_events", 5);
  Seen seen;
  ros::Subscriber events = nh.subscribe<TrackerEvent>(
      "tracker/events", 100, [&seen](const TrackerEvent::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        ++seen.events;
        if (msg->started < 1 || msg->tracked < msg->started || msg->header.frame_id != "odom")
          ++seen.bad_events;
        if (msg->step <= seen.last_step || msg->header.stamp.toSec() <= seen.last_stamp)
          ++seen.out_of_order;
        if (seen.events == 1) seen.first_stamp = msg->header.stamp.toSec();
        seen.last_step = msg->step;
        seen.last_stamp = msg->header.stamp.toSec();
        if (seen.late_sent) ++seen.events_after_late;
      });
  ros::Subscriber markers = nh.subscribe<visualization_msgs::MarkerArray>(
      "tracker/landmarks", 10, [&seen](const visualization_msgs::MarkerArray::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        for (const auto& m : msg->markers) {
          const auto key = std::make_pair(m.ns, m.id);
          if (m.action == visualization_msgs::Marker::DELETEALL) {
            seen.shown.clear();
            continue;
          }
          if (m.action == visualization_msgs::Marker::DELETE) {
            seen.shown.erase(key);
            continue;
          }
          seen.shown.insert(key);
          if (m.header.frame_id != "odom") ++seen.wrong_frame;
          bool ok = std::isfinite(m.pose.position.x) && std::isfinite(m.pose.position.y);
          for (const auto& p : m.points) ok = ok && std::isfinite(p.x) && std::isfinite(p.y);
          if (!ok) ++seen.non_finite;
        }
      });
  ros::Subscriber diagnostics = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&seen](const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        for (const auto& status : msg->status) {
          if (status.name != "landmark_tracker") continue;
          for (const auto& kv : status.values) {
            if (kv.key == "updates") seen.updates = std::stol(kv.value);
            if (kv.key == "resets") seen.resets = std::stol(kv.value);
            if (kv.key == "dropped: old stamp") seen.late_dropped = std::stol(kv.value);
            if (kv.key == "dropped: refused transform") seen.refused = std::stol(kv.value);
          }
        }
      });
  ros::Publisher late = nh.advertise<FeatureArray>("features", 1);
  ros::Publisher tf = nh.advertise<tf2_msgs::TFMessage>("/tf", 1);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(seen.mutex);
      // 2 s behind the clock must still be after the first frame (else it has no tf and is
      // dropped as such): wait until the clock is 4 s past the first event.
      if (!seen.late_sent && seen.events >= 2 && late.getNumSubscribers() > 0 &&
          tf.getNumSubscribers() > 0 && ros::Time::now().toSec() > seen.first_stamp + 4.0) {
        // One post straight ahead, 2 s behind the (simulated) clock: more than the 1 s of
        // reset_on_time_jump_back behind the tracker's last frame, inside tf's 10 s cache.
        FeatureArray msg;
        msg.header.stamp = ros::Time::now() - ros::Duration(2.0);
        msg.header.frame_id = "base_link";
        PointFeature post;
        post.range = 2.0;
        post.id = -1;
        msg.points.push_back(post);
        late.publish(msg);
        geometry_msgs::TransformStamped far;
        far.header.stamp = ros::Time(4294967295u, 0u);
        far.header.frame_id = "odom";
        far.child_frame_id = "base_link";
        far.transform.rotation.w = 1.0;
        tf2_msgs::TFMessage far_msg;
        far_msg.transforms.push_back(far);
        tf.publish(far_msg);
        seen.late_sent = true;
      }
      if (seen.events >= min_events && seen.events_after_late >= 2 && seen.late_dropped > 0 &&
          seen.refused > 0 && seen.updates > 3 * min_events && !seen.shown.empty()) {
        break;
      }
    }
    ros::WallDuration(0.1).sleep();
  }
  std::lock_guard<std::mutex> lock(seen.mutex);
  EXPECT_GE(seen.events, min_events);
  EXPECT_GT(seen.updates, 3 * min_events) << "most frames bring no new landmark";
  EXPECT_FALSE(seen.shown.empty()) << "no landmark markers";
  EXPECT_EQ(seen.bad_events, 0);
  EXPECT_EQ(seen.out_of_order, 0) << "event steps went back: the late message reset the tracker";
  EXPECT_TRUE(seen.late_sent);
  EXPECT_EQ(seen.late_dropped, 1) << "the late message did not reach the tracker";
  EXPECT_GE(seen.events_after_late, 2);
  EXPECT_EQ(seen.refused, 1) << "the far-stamped transform was not refused and counted";
  EXPECT_EQ(seen.resets, 0) << "a late message is no restarted clock";
  EXPECT_EQ(seen.non_finite, 0);
  EXPECT_EQ(seen.wrong_frame, 0);
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "landmark_tracker_check");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}

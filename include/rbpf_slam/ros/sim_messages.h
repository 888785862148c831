#pragma once
// Turns the simulator's events into the messages and topics of the converted real bags; used
// by the `simulate` bag writer and by the live `sim_node`, so both publish the same thing.

#include <nav_msgs/Odometry.h>
#include <rbpf_slam/FeatureArray.h>
#include <ros/time.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud.h>
#include <sensor_msgs/Range.h>
#include <tf2_msgs/TFMessage.h>

#include <optional>
#include <string>
#include <vector>

#include "rbpf_slam/core/sim/simulator.h"

namespace rbpf_slam {
namespace rosbridge {

/// The messages of one simulator event; each member is filled only when the event has it.
struct SimMessages {
  std::optional<tf2_msgs::TFMessage> tf;                // /tf: odom -> base_link
  std::optional<nav_msgs::Odometry> odom;               // /odom, in odom
  std::optional<nav_msgs::Odometry> ground_truth;       // /ground_truth, in map
  std::optional<sensor_msgs::LaserScan> scan;           // /scan
  std::vector<sensor_msgs::Range> sonar;                // /sonar, one per transducer
  std::optional<sensor_msgs::PointCloud> sonar_cloud;   // /sonar_cloud, echoes in base_link
  std::vector<sensor_msgs::Range> infrared;             // /ir, one per sensor
  std::optional<FeatureArray> features;                 // /features
};

/// Maps simulated seconds since the start to ROS stamps: start + t.
class SimClock {
 public:
  /// 1262304000 (2010-01-01) is the start of the converted real bags.
  explicit SimClock(ros::Time start = ros::Time(1262304000, 0)) : start_(start) {}
  ros::Time stamp(double t) const { return start_ + ros::Duration(t); }
  double seconds(double t) const { return start_.toSec() + t; }

 private:
  ros::Time start_;
};

/// base_link -> laser, sonar_i and ir_i mounting transforms of the enabled sensors.
tf2_msgs::TFMessage simStaticTransforms(const core::sim::Simulator& simulator,
                                        const ros::Time& stamp);

/// The messages of event, stamped by clock.
SimMessages toSimMessages(const core::sim::SimEvent& event,
                          const core::sim::Simulator& simulator, const SimClock& clock);

/// One TUM line (t x y z qx qy qz qw) of the true pose of event.
std::string groundTruthTumLine(const core::sim::SimEvent& event, const SimClock& clock);

}  // namespace rosbridge
}  // namespace rbpf_slam

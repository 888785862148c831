#pragma once
// Drives a robot around a simulated world and produces a time-ordered stream of ground truth,
// noisy odometry and sensor readings. Deterministic for a given seed; time is simulated time
// in seconds from the start, never the wall clock.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/sim/ray_caster.h"
#include "rbpf_slam/core/sim/waypoint_follower.h"
#include "rbpf_slam/core/sim/world.h"

namespace rbpf_slam {
namespace core {
namespace sim {

/// Run-time options that are not part of the world.
struct SimulatorOptions {
  std::uint64_t seed = 0;
  double max_duration_s = 0.0;  // stop earlier than the route's end; 0: world.max_duration_s
};

enum class SimEventType { kOdometry, kLaser, kSonar, kRangeBearing, kInfrared, kWorldChange };

/// One cone reading and the index of the transducer (sonar_i, ir_i) that took it.
struct TransducerReading {
  int index = 0;
  ConeReading reading;
};

/// A landmark that a change moved or removed.
struct LandmarkChange {
  int id = 0;
  Eigen::Vector2d before = Eigen::Vector2d::Zero();
  Eigen::Vector2d after = Eigen::Vector2d::Zero();
  bool removed = false;
};

/// An object that a change moved or removed.
struct ObjectChange {
  std::string name;
  std::vector<Eigen::Vector2d> before;
  std::vector<Eigen::Vector2d> after;
  bool removed = false;
};

/// What one entry of World::changes did when it was applied.
struct AppliedChange {
  int change_index = 0;
  double stamp = 0.0;
  int laps_completed = 0;
  std::vector<LandmarkChange> landmarks;
  std::vector<ObjectChange> objects;
};

/// One item of the stream. Every event carries the robot state at its stamp; the sensor
/// payload matching the type is filled.
struct SimEvent {
  SimEventType type = SimEventType::kOdometry;
  double stamp = 0.0;                                    // s since the start
  Pose2 true_pose = Pose2::Zero();                       // base_link in map (ground truth)
  Pose2 odom_pose = Pose2::Zero();                       // base_link in odom (dead reckoning)
  Eigen::Vector3d odom_twist = Eigen::Vector3d::Zero();  // (vx, vy, wz) of the last increment
  double true_speed_mps = 0.0;
  double true_turn_rate_radps = 0.0;
  int laps_completed = 0;
  std::shared_ptr<const RangeScan> scan;  // kLaser
  std::vector<TransducerReading> cones;   // kSonar, kInfrared
  FeatureSet features;                    // kRangeBearing: points in base_link
  AppliedChange change;                   // kWorldChange
};

/// Simulates the world's robot lap by lap; owns its random generators.
class Simulator {
 public:
  /// Throws std::invalid_argument when the world does not validate.
  Simulator(World world, const SimulatorOptions& options);

  /// The next event, or false when the route is done or the time is up.
  bool next(SimEvent* event);
  /// Every remaining event.
  std::vector<SimEvent> run();

  bool finished() const { return finished_ && pending_next_ >= pending_.size(); }
  double time() const { return tick_ * dt_s_; }
  int lapsCompleted() const { return follower_.lapsCompleted(); }
  /// True once the robot has driven every lap (false when the time limit stopped it).
  bool routeCompleted() const { return follower_.done(); }

  const World& world() const { return world_; }
  /// The landmarks and objects as they are now (after the changes applied so far).
  const std::vector<Landmark>& landmarks() const { return landmarks_; }
  const std::vector<WorldObject>& objects() const { return objects_; }
  const std::vector<AppliedChange>& appliedChanges() const { return applied_; }

  Pose2 laserPose() const;
  const std::vector<Pose2>& sonarPoses() const { return sonar_poses_; }
  const std::vector<Pose2>& infraredPoses() const { return infrared_poses_; }

 private:
  void step();
  void rebuildGeometry();
  void applyDueChanges();
  void applyChange(int index);
  void applyOdometryNoise();
  SimEvent stateEvent(SimEventType type) const;
  std::vector<TransducerReading> senseRing(const RingSensorConfig& config,
                                           const std::vector<Pose2>& poses, Rng* rng) const;

  const World world_;
  const double dt_s_;
  const double max_duration_s_;
  WaypointFollower follower_;
  std::vector<Landmark> landmarks_;
  std::vector<WorldObject> objects_;
  RayCaster caster_;
  std::vector<Pose2> sonar_poses_;
  std::vector<Pose2> infrared_poses_;
  std::vector<bool> change_applied_;
  std::vector<size_t> change_order_;  // changeOrder(world_)
  std::vector<AppliedChange> applied_;

  // One generator per purpose, so that enabling a sensor or a change does not alter the
  // noise drawn for the others.
  Rng motion_rng_, laser_rng_, sonar_rng_, range_bearing_rng_, infrared_rng_, change_rng_;

  long tick_ = 0;
  bool finished_ = false;
  Pose2 true_pose_ = Pose2::Zero();
  Pose2 odom_pose_ = Pose2::Zero();
  Pose2 pending_increment_ = Pose2::Zero();  // dead-reckoned since the last odometry event
  double last_odometry_s_ = 0.0;
  Eigen::Vector3d odom_twist_ = Eigen::Vector3d::Zero();
  Control last_control_;
  long odometry_count_ = 0, laser_count_ = 0, sonar_count_ = 0;  // readings taken so far
  long range_bearing_count_ = 0, infrared_count_ = 0;
  std::vector<SimEvent> pending_;  // produced by the last step, handed out in order
  size_t pending_next_ = 0;
};

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

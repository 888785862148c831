#include "rbpf_slam/core/sim/simulator.h"

#include <algorithm>
#include <cmath>

#include "rbpf_slam/core/sim/sensor_models.h"

namespace rbpf_slam {
namespace core {
namespace sim {
namespace {

constexpr double kTimeEpsilon = 1e-9;

World validated(World world) {
  validate(world);
  return world;
}

Rng makeRng(std::uint64_t seed, std::uint32_t purpose) {
  std::seed_seq sequence{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                         purpose};
  return Rng(sequence);
}

/// True when a sensor running at rate_hz is due at time t; counts the reading.
bool due(double t, double rate_hz, long* count) {
  if (t + kTimeEpsilon < *count / rate_hz) return false;
  while (*count / rate_hz <= t + kTimeEpsilon) ++*count;
  return true;
}

}  // namespace

Simulator::Simulator(World world, const SimulatorOptions& options)
    : world_(validated(std::move(world))),
      dt_s_(1.0 / world_.robot.control_rate_hz),
      max_duration_s_(options.max_duration_s > 0.0 ? options.max_duration_s
                                                   : world_.max_duration_s),
      follower_(world_.robot, world_.waypoints, world_.laps),
      landmarks_(world_.landmarks),
      objects_(world_.objects),
      sonar_poses_(ringPoses(world_.sensors.sonar)),
      infrared_poses_(ringPoses(world_.sensors.infrared)),
      change_applied_(world_.changes.size(), false),
      change_order_(changeOrder(world_)),
      motion_rng_(makeRng(options.seed, 1)),
      laser_rng_(makeRng(options.seed, 2)),
      sonar_rng_(makeRng(options.seed, 3)),
      range_bearing_rng_(makeRng(options.seed, 4)),
      infrared_rng_(makeRng(options.seed, 5)),
      change_rng_(makeRng(options.seed, 6)) {
  rebuildGeometry();
  true_pose_ = follower_.startPose();
  odom_pose_ = true_pose_;
}

Pose2 Simulator::laserPose() const { return laserMountPose(world_.sensors.laser); }

bool Simulator::next(SimEvent* event) {
  while (pending_next_ >= pending_.size()) {
    if (finished_) return false;
    step();
  }
  *event = std::move(pending_[pending_next_++]);
  return true;
}

std::vector<SimEvent> Simulator::run() {
  std::vector<SimEvent> events;
  SimEvent event;
  while (next(&event)) events.push_back(std::move(event));
  return events;
}

void Simulator::step() {
  pending_.clear();
  pending_next_ = 0;
  const double t = time();
  const bool last = follower_.done() || t >= max_duration_s_ - kTimeEpsilon;
  applyDueChanges();

  const SensorsConfig& sensors = world_.sensors;
  const bool laser = sensors.laser.enabled && due(t, sensors.laser.rate_hz, &laser_count_);
  const bool sonar = sensors.sonar.enabled && due(t, sensors.sonar.rate_hz, &sonar_count_);
  const bool range_bearing =
      sensors.range_bearing.enabled && due(t, sensors.range_bearing.rate_hz, &range_bearing_count_);
  const bool infrared =
      sensors.infrared.enabled && due(t, sensors.infrared.rate_hz, &infrared_count_);
  const bool odometry = due(t, world_.odometry.rate_hz, &odometry_count_);
  // Odometry is also published with every reading, so that tf covers each sensor stamp.
  if (odometry || laser || sonar || range_bearing || infrared || last) {
    applyOdometryNoise();
    pending_.push_back(stateEvent(SimEventType::kOdometry));
  }
  if (laser) {
    SimEvent event = stateEvent(SimEventType::kLaser);
    auto scan = std::make_shared<RangeScan>(
        simulateLaserScan(sensors.laser, caster_, true_pose_, &laser_rng_));
    scan->stamp = t;
    event.scan = std::move(scan);
    pending_.push_back(std::move(event));
  }
  if (sonar) {
    SimEvent event = stateEvent(SimEventType::kSonar);
    event.cones = senseRing(sensors.sonar, sonar_poses_, &sonar_rng_);
    pending_.push_back(std::move(event));
  }
  if (range_bearing) {
    SimEvent event = stateEvent(SimEventType::kRangeBearing);
    event.features = observeLandmarks(sensors.range_bearing, landmarks_, caster_, true_pose_,
                                      &range_bearing_rng_);
    event.features.stamp = t;
    pending_.push_back(std::move(event));
  }
  if (infrared) {
    SimEvent event = stateEvent(SimEventType::kInfrared);
    event.cones = senseRing(sensors.infrared, infrared_poses_, &infrared_rng_);
    pending_.push_back(std::move(event));
  }
  if (last) {
    finished_ = true;
    return;
  }

  const RobotConfig& robot = world_.robot;
  const Control control = follower_.control(true_pose_, dt_s_);
  true_pose_ = integrateArc(true_pose_, control.speed_mps, turnRate(robot, control), dt_s_);
  last_control_ = control;
  // The odometry dead-reckons the controls as measured, with control noise when configured.
  Control measured = control;
  if (control.speed_mps != 0.0) {
    measured.speed_mps += sampleGaussian(motion_rng_, world_.odometry.speed_noise_mps);
  }
  measured.steering_rad +=
      sampleGaussian(motion_rng_, world_.odometry.steering_noise_deg * M_PI / 180.0);
  const double measured_turn_rate =
      robot.drive == DriveType::kBicycle ? turnRate(robot, measured) : measured.turn_rate_radps;
  pending_increment_ = compose(pending_increment_, integrateArc(Pose2::Zero(), measured.speed_mps,
                                                                measured_turn_rate, dt_s_));
  ++tick_;
}

void Simulator::applyOdometryNoise() {
  const OdometryConfig& o = world_.odometry;
  const Pose2& d = pending_increment_;
  // rot1-trans-rot2 decomposition of the increment (Thrun et al., Probabilistic Robotics 5.4).
  const double translation = std::hypot(d.x(), d.y());
  const double rot1 = translation > 1e-9 ? std::atan2(d.y(), d.x()) : 0.0;
  const double rot2 = wrapAngle(d.z() - rot1);
  const double noisy_translation =
      translation * (1.0 + o.translation_scale_bias) +
      sampleGaussian(motion_rng_, o.translation_noise_m_per_m * translation);
  const double noisy_rot1 =
      rot1 * (1.0 + o.rotation_scale_bias) +
      sampleGaussian(motion_rng_, o.rotation_noise_rad_per_rad * std::abs(rot1));
  const double rot2_sigma = std::hypot(o.rotation_noise_rad_per_rad * std::abs(rot2),
                                       o.rotation_noise_rad_per_m * translation);
  const double noisy_rot2 =
      rot2 * (1.0 + o.rotation_scale_bias) + sampleGaussian(motion_rng_, rot2_sigma);
  const Pose2 noisy(noisy_translation * std::cos(noisy_rot1),
                    noisy_translation * std::sin(noisy_rot1), wrapAngle(noisy_rot1 + noisy_rot2));
  odom_pose_ = compose(odom_pose_, noisy);
  const double dt = time() - last_odometry_s_;
  odom_twist_ = dt > kTimeEpsilon ? Eigen::Vector3d(noisy / dt) : Eigen::Vector3d::Zero();
  pending_increment_ = Pose2::Zero();
  last_odometry_s_ = time();
}

SimEvent Simulator::stateEvent(SimEventType type) const {
  SimEvent event;
  event.type = type;
  event.stamp = time();
  event.true_pose = true_pose_;
  event.odom_pose = odom_pose_;
  event.odom_twist = odom_twist_;
  event.true_speed_mps = last_control_.speed_mps;
  event.true_turn_rate_radps = turnRate(world_.robot, last_control_);
  event.laps_completed = follower_.lapsCompleted();
  return event;
}

std::vector<TransducerReading> Simulator::senseRing(const RingSensorConfig& config,
                                                    const std::vector<Pose2>& poses,
                                                    Rng* rng) const {
  std::vector<TransducerReading> readings;
  for (size_t i = 0; i < poses.size(); ++i) {
    TransducerReading reading;
    reading.index = static_cast<int>(i);
    reading.reading.stamp = time();
    reading.reading.range = simulateConeRange(config, caster_, compose(true_pose_, poses[i]), rng);
    reading.reading.min_range = config.min_range_m;
    reading.reading.max_range = config.max_range_m;
    reading.reading.field_of_view = config.cone_deg * M_PI / 180.0;
    reading.reading.sensor_pose = poses[i];
    readings.push_back(reading);
  }
  return readings;
}

void Simulator::rebuildGeometry() {
  std::vector<Segment> segments;
  for (size_t i = 0; i < objects_.size(); ++i) {
    const auto object_segments = objectSegments(objects_[i], static_cast<int>(i));
    segments.insert(segments.end(), object_segments.begin(), object_segments.end());
  }
  std::vector<Circle> circles;
  for (const Landmark& landmark : landmarks_) {
    if (landmark.radius_m > 0.0) circles.push_back({landmark.position, landmark.radius_m});
  }
  caster_ = RayCaster(std::move(segments), std::move(circles));
}

void Simulator::applyDueChanges() {
  // In the order validate() replayed them: at one control step, a change due earlier first.
  for (size_t i : change_order_) {
    const WorldChange& change = world_.changes[i];
    if (change_applied_[i]) continue;
    const bool lap_due = change.after_lap > 0 && follower_.lapsCompleted() >= change.after_lap;
    const bool time_due = change.at_time_s >= 0.0 && time() + kTimeEpsilon >= change.at_time_s;
    if (lap_due || time_due) applyChange(static_cast<int>(i));
  }
}

void Simulator::applyChange(int index) {
  const WorldChange& change = world_.changes[index];
  change_applied_[index] = true;
  AppliedChange applied;
  applied.change_index = index;
  applied.stamp = time();
  applied.laps_completed = follower_.lapsCompleted();
  for (const ObjectMove& move : change.objects) {
    auto object = std::find_if(objects_.begin(), objects_.end(),
                               [&move](const WorldObject& o) { return o.name == move.name; });
    if (object == objects_.end()) continue;  // removed by an earlier change
    ObjectChange record{move.name, object->points, {}, move.remove};
    if (move.remove) {
      objects_.erase(object);
    } else {
      *object = movedObject(*object, move);
      record.after = object->points;
    }
    applied.objects.push_back(record);
  }
  auto find_landmark = [this](int id) {
    return std::find_if(landmarks_.begin(), landmarks_.end(),
                        [id](const Landmark& l) { return l.id == id; });
  };
  for (const LandmarkMove& move : change.landmarks) {
    auto landmark = find_landmark(move.id);
    if (landmark == landmarks_.end()) continue;
    LandmarkChange record{move.id, landmark->position,
                          move.remove ? landmark->position : move.position, move.remove};
    if (move.remove) {
      landmarks_.erase(landmark);
    } else {
      landmark->position = move.position;
    }
    applied.landmarks.push_back(record);
  }
  const RandomDisplacement& random = change.random_landmarks;
  if (random.count_max > 0) {
    std::vector<int> pool;
    for (const Landmark& landmark : landmarks_) {
      const bool candidate =
          random.candidate_ids.empty() ||
          std::count(random.candidate_ids.begin(), random.candidate_ids.end(), landmark.id) > 0;
      if (candidate) pool.push_back(landmark.id);
    }
    const int count_max = std::min(random.count_max, static_cast<int>(pool.size()));
    const int count_min = std::min(random.count_min, count_max);
    const int count = std::uniform_int_distribution<int>(count_min, count_max)(change_rng_);
    std::shuffle(pool.begin(), pool.end(), change_rng_);
    pool.resize(count);
    std::sort(pool.begin(), pool.end());
    for (int id : pool) {
      auto landmark = find_landmark(id);
      const Eigen::Vector2d before = landmark->position;
      landmark->position += Eigen::Vector2d(sampleGaussian(change_rng_, random.sigma_m),
                                            sampleGaussian(change_rng_, random.sigma_m));
      applied.landmarks.push_back({id, before, landmark->position, false});
    }
  }
  rebuildGeometry();
  applied_.push_back(applied);
  SimEvent event = stateEvent(SimEventType::kWorldChange);
  event.change = applied;
  pending_.push_back(std::move(event));
}

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam

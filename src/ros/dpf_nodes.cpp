#include "rbpf_slam/ros/dpf_nodes.h"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/ros/param_loader.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

template <typename Array>
core::Pose2 toPose(const Array& a) {
  return core::Pose2(a[0], a[1], a[2]);
}

template <typename Array>
void fromPose(const core::Pose2& p, Array* a) {
  for (int k = 0; k < 3; ++k) (*a)[k] = p[k];
}

template <typename Array>
Eigen::Matrix3d toMatrix(const Array& a) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m(r, c) = a[3 * r + c];
  }
  return m;
}

template <typename Array>
void fromMatrix(const Eigen::Matrix3d& m, Array* a) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) (*a)[3 * r + c] = m(r, c);
  }
}

/// Tells this process from another, or from itself restarted (a DpfStep's run, a
/// DpfLocalEstimate's sender): host, pid and start time mixed (splitmix64). An identifier, not
/// a draw: no filter takes randomness from it.
std::uint64_t processToken() {
  char host[256] = {0};
  gethostname(host, sizeof(host) - 1);
  std::uint64_t x = std::hash<std::string>()(host) ^ (static_cast<std::uint64_t>(getpid()) << 32) ^
                    static_cast<std::uint64_t>(ros::WallTime::now().toNSec());
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace

DpfStep toMsg(const core::DpfStepInput& input, const core::Pose2& initial_pose,
              int injected_index, const core::Pose2& injected) {
  DpfStep msg;
  msg.header.stamp.fromSec(std::max(0.0, input.motion.stamp));
  msg.step = input.step;
  msg.run = input.run;
  fromPose(initial_pose, &msg.initial_pose);
  msg.motion_stamp = input.motion.stamp;
  msg.motion_dt = input.motion.dt;
  fromPose(input.motion.delta, &msg.motion_delta);
  msg.motion_noise_scale = input.motion.noise_scale;
  for (const auto& p : input.features.points) {
    PointFeature f;
    f.range = p.range;
    f.bearing = p.bearing;
    f.covariance = {p.covariance(0, 0), p.covariance(0, 1), p.covariance(1, 0),
                    p.covariance(1, 1)};
    f.id = p.id;
    msg.points.push_back(f);
  }
  msg.feedback_step = input.feedback.step;
  fromPose(input.feedback.mean, &msg.feedback_mean);
  fromMatrix(input.feedback.covariance, &msg.feedback_covariance);
  msg.reinitialise = input.feedback.reinitialise;
  msg.injected_index = injected_index;
  fromPose(injected, &msg.injected);
  return msg;
}

core::DpfStepInput fromMsg(const DpfStep& msg) {
  core::DpfStepInput input;
  input.step = msg.step;
  input.run = msg.run;
  input.motion.stamp = msg.motion_stamp;
  input.motion.dt = msg.motion_dt;
  input.motion.delta = toPose(msg.motion_delta);
  input.motion.noise_scale = msg.motion_noise_scale;
  input.features.stamp = msg.motion_stamp;
  for (const auto& f : msg.points) {
    core::PointFeature p;
    p.range = f.range;
    p.bearing = f.bearing;
    p.covariance << f.covariance[0], f.covariance[1], f.covariance[2], f.covariance[3];
    p.id = f.id;
    input.features.points.push_back(p);
  }
  input.feedback.step = msg.feedback_step;
  input.feedback.mean = toPose(msg.feedback_mean);
  input.feedback.covariance = toMatrix(msg.feedback_covariance);
  input.feedback.reinitialise = msg.reinitialise;
  return input;
}

DpfLocalEstimate toMsg(const core::DpfLocalEstimate& e,
                       const std::vector<core::LandmarkEstimate>& landmarks) {
  DpfLocalEstimate msg;
  msg.index = e.index;
  msg.step = e.step;
  fromPose(e.mean, &msg.mean);
  fromMatrix(e.covariance, &msg.covariance);
  fromPose(e.prior_mean, &msg.prior_mean);
  fromMatrix(e.prior_covariance, &msg.prior_covariance);
  msg.neff = e.neff;
  msg.particles = e.particles;
  msg.nis_sum = e.nis_sum;
  msg.innovations = e.innovations;
  msg.new_landmarks = e.new_landmarks;
  msg.rejected = e.rejected;
  msg.landmarks = e.landmarks;
  for (const auto& l : landmarks) {
    msg.landmark_ids.push_back(l.id);
    msg.landmark_means.push_back(l.mean.x());
    msg.landmark_means.push_back(l.mean.y());
    for (int k = 0; k < 4; ++k) msg.landmark_covariances.push_back(l.covariance(k / 2, k % 2));
    msg.landmark_observations.push_back(l.observations);
  }
  return msg;
}

core::DpfLocalEstimate fromMsg(const DpfLocalEstimate& msg) {
  core::DpfLocalEstimate e;
  e.index = msg.index;
  e.step = msg.step;
  e.mean = toPose(msg.mean);
  e.covariance = toMatrix(msg.covariance);
  e.prior_mean = toPose(msg.prior_mean);
  e.prior_covariance = toMatrix(msg.prior_covariance);
  e.neff = msg.neff;
  e.particles = msg.particles;
  e.nis_sum = msg.nis_sum;
  e.innovations = msg.innovations;
  e.new_landmarks = msg.new_landmarks;
  e.rejected = msg.rejected;
  e.landmarks = msg.landmarks;
  return e;
}

std::vector<core::LandmarkEstimate> landmarksOf(const DpfLocalEstimate& msg) {
  std::vector<core::LandmarkEstimate> out;
  const size_t n = msg.landmark_ids.size();
  if (msg.landmark_means.size() != 2 * n || msg.landmark_covariances.size() != 4 * n ||
      msg.landmark_observations.size() != n) {
    // Malformed: the master keeps no map from it, and says so.
    ROS_WARN_STREAM_THROTTLE(5.0, "dpf_master_node: the estimate of local filter "
                                      << msg.index << " at step " << msg.step << " has "
                                      << n << " landmark ids but " << msg.landmark_means.size()
                                      << " means (2 each), " << msg.landmark_covariances.size()
                                      << " covariance entries (4 each) and "
                                      << msg.landmark_observations.size()
                                      << " observation counts: its map is left out");
    return out;
  }
  for (size_t i = 0; i < n; ++i) {
    core::LandmarkEstimate l;
    l.id = msg.landmark_ids[i];
    l.mean << msg.landmark_means[2 * i], msg.landmark_means[2 * i + 1];
    for (int k = 0; k < 4; ++k) l.covariance(k / 2, k % 2) = msg.landmark_covariances[4 * i + k];
    l.observations = msg.landmark_observations[i];
    out.push_back(l);
  }
  return out;
}

RemoteDpfFilter::RemoteDpfFilter(ros::NodeHandle nh, const core::FilterOptions& options)
    : options_(options),
      nh_(nh),
      coordinator_(options),
      run_(static_cast<std::uint32_t>(processToken())) {
  core::validate(options.dpf);
  ros::NodeHandle queue_nh(nh_);
  queue_nh.setCallbackQueue(&queue_);
  step_publisher_ = nh_.advertise<DpfStep>("dpf/step", 100);
  estimate_subscriber_ =
      queue_nh.subscribe("dpf/estimate", 1000, &RemoteDpfFilter::estimateCallback, this,
                         ros::TransportHints().tcpNoDelay());
  alive_.assign(options.dpf.local_filters, false);
  absent_.assign(options.dpf.local_filters, false);
  landmarks_.assign(options.dpf.local_filters, {});
}

void RemoteDpfFilter::reset(const core::Pose2& initial_pose) {
  coordinator_.reset(initial_pose);
  initial_pose_ = initial_pose;
  landmarks_.assign(options_.dpf.local_filters, {});
  ++run_;  // the locals start over at the next step, even one that misses its step 1
}

void RemoteDpfFilter::estimateCallback(const DpfLocalEstimate::ConstPtr& msg) {
  const int n = options_.dpf.local_filters;
  if (msg->index < 0 || msg->index >= n) {
    ROS_WARN_STREAM_THROTTLE(5.0, "dpf_master_node: an estimate from local filter "
                                      << msg->index << " ignored: dpf.local_filters = " << n);
    return;
  }
  alive_[msg->index] = true;
  if (msg->step <= 0 || msg->run != run_) return;  // a hello, or an answer of an earlier run
  if (absent_[msg->index] && msg->step >= waiting_step_ - 1) {
    // Answering again, and in step (a restarted process after its resynchronisation, a stalled
    // one that caught up): waited for again from the step after the one it answered. A hello
    // is not enough: a new process may not receive the step being waited for, and a stalled
    // one working through old steps would cost a timeout at every step.
    absent_[msg->index] = false;
    ROS_INFO_STREAM("dpf_master_node: local filter " << msg->index << " answered step " << msg->step
                                                     << ": it is fused again");
  }
  if (msg->step != waiting_step_) return;  // an old answer
  const auto known = answers_.find(msg->index);
  if (known == answers_.end()) {
    answers_[msg->index] = msg;
  } else if (known->second->sender != msg->sender) {
    // The same answer twice (a latched message delivered again on a new connection) comes
    // from the same process; two processes with one index are a configuration error.
    ++conflicting_answers_;
    ROS_ERROR_STREAM_THROTTLE(5.0,
                              "dpf_master_node: two dpf_local_node processes answer as "
                              "local filter "
                                  << msg->index << " (step " << msg->step
                                  << "); each needs its own ~index. The first answer is "
                                     "used");
  }
}

template <typename Done>
bool RemoteDpfFilter::spinUntil(Done done, double timeout_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (!done()) {
    if (!ros::ok()) {
      // Live, the node is going down: the step goes on with what came. A bag run stops.
      if (stop_on_shutdown_) throw std::runtime_error("dpf_master_node: ROS is shutting down");
      return false;
    }
    if (ros::WallTime::now() > deadline) return false;
    queue_.callAvailable(ros::WallDuration(0.01));
  }
  return true;
}

std::string RemoteDpfFilter::missing(const std::vector<bool>& present) const {
  std::ostringstream out;
  bool first = true;
  for (size_t i = 0; i < present.size(); ++i) {
    if (present[i]) continue;
    out << (first ? "" : ", ") << i;
    first = false;
  }
  return out.str();
}

bool RemoteDpfFilter::waitForLocals(double timeout_s, std::string* problem) {
  const uint32_t n = static_cast<uint32_t>(options_.dpf.local_filters);
  const bool ok = spinUntil(
      [&] {
        return std::all_of(alive_.begin(), alive_.end(), [](bool a) { return a; }) &&
               step_publisher_.getNumSubscribers() >= n;
      },
      timeout_s);
  locals_ready_ = true;
  if (ok) return true;
  const std::string silent = missing(alive_);
  for (size_t i = 0; i < alive_.size(); ++i) absent_[i] = !alive_[i];
  *problem = "dpf_master_node: no answer from local filter(s) " +
             (silent.empty() ? std::string("(all said hello, but fewer than ") + std::to_string(n) +
                                   " subscribe to dpf/step)"
                             : silent) +
             " within " + std::to_string(timeout_s) +
             " s: start one dpf_local_node per local filter with ~index = 0.." +
             std::to_string(n - 1) + " and the same config";
  return false;
}

core::UpdateStats RemoteDpfFilter::update(const core::FeatureSet& features) {
  if (!locals_ready_) {
    std::string problem;
    if (!waitForLocals(options_.dpf.step_timeout_s, &problem)) {
      ROS_WARN_STREAM(problem << "; going on without the silent ones until they answer");
    }
  }
  std::vector<core::Pose2> injected;
  core::DpfStepInput input = coordinator_.beginStep(features, &injected);
  input.run = run_;
  const int faulted = options_.dpf.fault.local_index;
  answers_.clear();
  waiting_step_ = input.step;
  step_publisher_.publish(toMsg(input, initial_pose_, faulted, injected[faulted]));
  const size_t n = options_.dpf.local_filters;
  // absent_ may change while spinning (a local heard from again is waited for from now on).
  const auto all_expected_answered = [&] {
    for (size_t i = 0; i < n; ++i) {
      if (!absent_[i] && !answers_.count(static_cast<int>(i))) return false;
    }
    return true;
  };
  if (!spinUntil(all_expected_answered, options_.dpf.step_timeout_s)) {
    std::vector<bool> answered(n, true);
    for (size_t i = 0; i < n; ++i) {
      if (absent_[i] || answers_.count(static_cast<int>(i))) continue;
      answered[i] = false;
      absent_[i] = true;
    }
    ROS_WARN_STREAM("dpf_master_node: step " << input.step << ": no estimate from local filter(s) "
                                             << missing(answered) << " within "
                                             << options_.dpf.step_timeout_s
                                             << " s (dpf.step_timeout_s); the step is fused "
                                                "without them, and they are not waited for "
                                                "until they answer again. Is that "
                                                "dpf_local_node still running?");
  }
  const bool none = std::all_of(absent_.begin(), absent_.end(), [](bool a) { return a; });
  if (none) {
    ROS_WARN_STREAM_THROTTLE(10.0,
                             "dpf_master_node: no local filter answers: the master "
                             "predicts from the odometry only");
  }
  std::vector<core::DpfLocalEstimate> estimates;
  for (size_t i = 0; i < n; ++i) {
    const auto answer = answers_.find(static_cast<int>(i));
    if (answer == answers_.end()) {
      estimates.push_back(core::missedEstimate(static_cast<int>(i), input.step));
      continue;
    }
    estimates.push_back(fromMsg(*answer->second));
    landmarks_[i] = landmarksOf(*answer->second);
  }
  return coordinator_.finishStep(input, estimates);
}

std::vector<core::LandmarkEstimate> RemoteDpfFilter::landmarks() const {
  std::vector<core::LandmarkEstimate> out;
  for (const auto& block : landmarks_) out.insert(out.end(), block.begin(), block.end());
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  return out;
}

std::vector<core::WeightedPose> RemoteDpfFilter::particles() const {
  return {{coordinator_.estimate().mean, 1.0}};
}

DpfLocalNode::DpfLocalNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : sender_(processToken()) {
  const io::SlamConfig config = loadConfigFromParams(private_nh, {"index", "crash_at_step"});
  core::FilterOptions options = config.filter;
  options.variant = "dpf";
  core::validate(options.dpf);
  XmlRpc::XmlRpcValue index;
  if (!private_nh.getParam("index", index)) {
    throw std::invalid_argument("dpf_local_node: ~index (0.." +
                                std::to_string(options.dpf.local_filters - 1) + ") is required");
  }
  if (index.getType() != XmlRpc::XmlRpcValue::TypeInt) {
    // getParam(int) would round 1.6 to 2 and take "1" as missing.
    std::ostringstream given;
    if (index.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
      given << static_cast<double>(index);
    } else if (index.getType() == XmlRpc::XmlRpcValue::TypeString) {
      given << "'" << static_cast<std::string>(index) << "'";
    } else {
      given << "a value of XmlRpc type " << index.getType();
    }
    throw std::invalid_argument("dpf_local_node: ~index = " + given.str() +
                                " is not an integer (0.." +
                                std::to_string(options.dpf.local_filters - 1) + ")");
  }
  index_ = static_cast<int>(index);
  if (index_ < 0 || index_ >= options.dpf.local_filters) {
    throw std::invalid_argument("dpf_local_node: ~index = " + std::to_string(index_) +
                                " is out of range [0, " +
                                std::to_string(options.dpf.local_filters - 1) + "]");
  }
  stream_ = std::make_unique<core::DpfLocalStream>(options, index_);
  int crash_at_step = 0;
  private_nh.getParam("crash_at_step", crash_at_step);
  crash_at_step_ = crash_at_step;
  estimate_publisher_ = nh.advertise<DpfLocalEstimate>("dpf/estimate", 100, /*latch=*/true);
  step_subscriber_ = nh.subscribe("dpf/step", 1000, &DpfLocalNode::stepCallback, this,
                                  ros::TransportHints().tcpNoDelay());
  DpfLocalEstimate hello;
  hello.index = index_;
  hello.step = 0;
  hello.sender = sender_;
  estimate_publisher_.publish(hello);
  ROS_INFO_STREAM("dpf_local_node: local filter " << index_ << " of "
                                                  << options.dpf.local_filters << " ready");
}

void DpfLocalNode::stepCallback(const DpfStep::ConstPtr& msg) {
  if (crash_at_step_ > 0 && msg->step == crash_at_step_) {
    ROS_ERROR_STREAM("dpf_local_node " << index_ << ": ~crash_at_step = " << crash_at_step_
                                       << ": exiting without an answer, as a crash would");
    std::_Exit(3);
  }
  const long expected = stream_->expected();
  const core::Pose2 injected = msg->injected_index == index_ ? toPose(msg->injected)
                                                              : core::Pose2::Zero();
  core::DpfLocalEstimate estimate;
  switch (stream_->step(fromMsg(*msg), toPose(msg->initial_pose), injected, &estimate)) {
    case core::DpfLocalStream::Outcome::kRepeated:
      ROS_WARN_STREAM_THROTTLE(5.0, "dpf_local_node " << index_ << ": step " << msg->step
                                                      << " arrived again (expected " << expected
                                                      << "); ignored");
      return;
    case core::DpfLocalStream::Outcome::kNoFeedback:
      ROS_ERROR_STREAM_THROTTLE(5.0, "dpf_local_node " << index_ << ": step " << msg->step
                                                       << " arrived, expected " << expected
                                                       << ", and carries no master estimate "
                                                          "to resynchronise from; ignored");
      return;
    case core::DpfLocalStream::Outcome::kResynchronised:
      ROS_WARN_STREAM("dpf_local_node " << index_ << ": step " << msg->step << " arrived, expected "
                                        << expected
                                        << " (steps lost, or this node started in the middle "
                                           "of a run): resynchronised from the master's "
                                           "estimate of step "
                                        << msg->feedback_step);
      break;
    case core::DpfLocalStream::Outcome::kStepped:
      break;
  }
  DpfLocalEstimate answer = toMsg(estimate, core::localLandmarks(stream_->filter()));
  answer.run = msg->run;
  answer.sender = sender_;
  estimate_publisher_.publish(answer);
}

}  // namespace rosbridge
}  // namespace rbpf_slam

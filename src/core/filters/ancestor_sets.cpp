#include "rbpf_slam/core/filters/ancestor_sets.h"

#include <utility>

#include "rbpf_slam/core/filters/intermediate_path.h"

namespace rbpf_slam {
namespace core {

AncestorMemory::AncestorMemory(int max_sets, int spacing_steps, int window_steps)
    : max_sets_(max_sets), spacing_steps_(spacing_steps), window_steps_(window_steps) {}

void AncestorMemory::clear() {
  sets_.clear();
  records_.clear();
}

void AncestorMemory::record(StepRecord record) {
  const int step = record.step;
  records_.push_back(std::move(record));
  dropOld(step);
}

void propagateOverRecords(const MotionModel& model, const std::vector<const StepRecord*>& records,
                          Pose2* mean, Eigen::Matrix3d* cov) {
  for (const StepRecord* r : records) {
    const Eigen::Matrix3d f = composeJacobianFirst(*mean, r->motion.delta);
    *cov = f * *cov * f.transpose() + model.covariance(*mean, r->motion);
    *mean = model.mean(*mean, r->motion);
    mean->z() = wrapAngle(mean->z() + r->drift_turn_rad);  // as FastSlam2::update turns it
  }
}

void AncestorMemory::setLatestDriftTurn(double turn_rad) {
  if (!records_.empty()) records_.back().drift_turn_rad = turn_rad;
}

bool AncestorMemory::canStore(int step) const {
  return max_sets_ > 0 && (sets_.empty() || step - sets_.back().step >= spacing_steps_);
}

void AncestorMemory::store(AncestorSet set) {
  if (!canStore(set.step)) return;
  const int step = set.step;
  sets_.push_back(std::move(set));
  while (static_cast<int>(sets_.size()) > max_sets_) sets_.pop_front();
  dropOld(step);
}

void AncestorMemory::dropOld(int step) {
  // A record of step r is needed while a set of step r - 1 or later can still be used.
  while (!records_.empty() && step - records_.front().step >= window_steps_) records_.pop_front();
  while (!sets_.empty() && step - sets_.front().step > window_steps_) sets_.pop_front();
}

std::vector<const AncestorSet*> AncestorMemory::usable(int step) const {
  std::vector<const AncestorSet*> out;
  for (auto it = sets_.rbegin(); it != sets_.rend(); ++it) {
    if (it->step >= step || step - it->step > window_steps_) continue;
    if (records(it->step, step).empty()) continue;
    out.push_back(&*it);
  }
  return out;
}

std::vector<const StepRecord*> AncestorMemory::records(int from, int to) const {
  std::vector<const StepRecord*> out;
  if (to <= from) return out;
  for (const StepRecord& r : records_) {
    if (r.step > from && r.step <= to) out.push_back(&r);
  }
  if (static_cast<int>(out.size()) != to - from) out.clear();
  return out;
}

}  // namespace core
}  // namespace rbpf_slam

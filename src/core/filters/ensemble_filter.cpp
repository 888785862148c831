#include "rbpf_slam/core/filters/ensemble_filter.h"

#include <algorithm>
#include <stdexcept>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "rbpf_slam/core/alignment.h"

namespace rbpf_slam {
namespace core {
namespace {

class EnsembleFilter : public SlamFilter {
 public:
  explicit EnsembleFilter(const FilterOptions& options)
      : by_new_landmarks_(options.ensemble.rank_by == "new_landmarks"),
        // Two members cannot agree on anything: with fewer than three the evidence decides.
        by_consensus_(options.ensemble.rank_by == "consensus" && options.ensemble.members >= 3),
        switch_margin_(options.ensemble.switch_margin),
        consensus_period_(options.ensemble.consensus_period),
        consensus_margin_m_(options.ensemble.consensus_margin_m),
        consensus_max_poses_(static_cast<size_t>(options.ensemble.consensus_max_poses)) {
    FilterOptions one = options;
    one.ensemble.members = 1;
    for (int k = 0; k < options.ensemble.members; ++k) {
      one.seed = ensembleMemberSeed(options.seed, k);
      members_.push_back(createFilter(one));
    }
    log_evidence_.assign(members_.size(), 0.0);
    created_.assign(members_.size(), 0);
  }

  std::string variant() const override { return members_[0]->variant(); }
  void reset(const Pose2& initial_pose) override {
    for (auto& m : members_) m->reset(initial_pose);
    log_evidence_.assign(members_.size(), 0.0);
    created_.assign(members_.size(), 0);
    leader_ = 0;
    leader_changes_ = 0;
    updates_ = 0;
  }
  void predict(const MotionInput& motion) override {
    for (auto& m : members_) m->predict(motion);
  }
  UpdateStats update(const FeatureSet& features) override {
    std::vector<UpdateStats> stats;
    stats.reserve(members_.size());
    for (size_t k = 0; k < members_.size(); ++k) {
      stats.push_back(members_[k]->update(features));
      log_evidence_[k] = addLogEvidence(log_evidence_[k], stats.back().log_evidence);
      created_[k] += stats.back().new_landmarks;
    }
    ++updates_;
    int best = leader_;
    if (!by_consensus_) {
      best = evidenceLeader();
    } else if (updates_ % consensus_period_ == 0 || (lost(leader_) && !allLost())) {
      best = consensusLeader();  // a lost leader is replaced at once, not at the period's end
    }
    if (best != leader_) {
      leader_ = best;
      ++leader_changes_;
    }
    return stats[leader_];
  }
  PoseEstimate estimate() const override { return members_[leader_]->estimate(); }
  std::vector<LandmarkEstimate> landmarks() const override {
    return members_[leader_]->landmarks();
  }
  std::vector<WeightedPose> particles() const override { return members_[leader_]->particles(); }
  FilterStats stats() const override {
    FilterStats s = members_[leader_]->stats();
    s.leader_changes = leader_changes_;
    return s;
  }
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override {
    bool ok = true;
    for (auto& m : members_) ok = m->resetPose(pose, covariance) && ok;
    return ok;
  }
  bool loadMap(const std::vector<LandmarkEstimate>& landmarks) override {
    return loadIntoEvery([&](SlamFilter& m) { return m.loadMap(landmarks); });
  }
  bool loadGridMap(const GridMapData& map) override {
    return loadIntoEvery([&](SlamFilter& m) { return m.loadGridMap(map); });
  }
  bool spreadOverMap() override {
    return loadIntoEvery([](SlamFilter& m) { return m.spreadOverMap(); });
  }
  bool canSpreadOverMap(std::string* why) const override {
    for (const auto& m : members_) {
      if (!m->canSpreadOverMap(why)) return false;
    }
    return true;
  }
  // The reported member's, as estimate().
  bool stillSpread() const override { return members_[leader_]->stillSpread(); }
  double gridResolution() const override { return members_[0]->gridResolution(); }
  bool setMapping(bool enabled) override {
    bool ok = true;
    for (auto& m : members_) ok = m->setMapping(enabled) && ok;
    return ok;
  }
  bool occupancyGrid(GridMapData& out) const override {
    return members_[leader_]->occupancyGrid(out);
  }
  std::vector<Pose2> bestPath() const override { return members_[leader_]->bestPath(); }
  std::vector<Pose2> bestPathSample(size_t max_poses, size_t* length) const override {
    return members_[leader_]->bestPathSample(max_poses, length);
  }
  bool usesLandmarkFeatures() const override { return members_[0]->usesLandmarkFeatures(); }
  int members() const override { return static_cast<int>(members_.size()); }
  const SlamFilter& member(int k) const override { return *members_.at(k); }
  int leader() const override { return leader_; }

 private:
  /// Gives every member the same map (load returns whether member m took it); the totals ranked
  /// the maps just replaced, so they start over and the first member leads.
  template <typename Load>
  bool loadIntoEvery(const Load& load) {
    bool ok = true;
    for (auto& m : members_) ok = load(*m) && ok;
    if (!ok) return false;  // refused (every member had the same input): nothing changed
    log_evidence_.assign(members_.size(), 0.0);
    created_.assign(members_.size(), 0);
    if (leader_ != 0) ++leader_changes_;  // the reported member changes like any other time
    leader_ = 0;
    updates_ = 0;  // the next consensus comes a full period after the load
    return true;
  }
  /// The first best member by rank_by (a member at -inf evidence leads only if all are), if
  /// it beats the leader by the margin; else the leader.
  int evidenceLeader() const {
    int best = 0;
    for (int k = 1; k < static_cast<int>(members_.size()); ++k) {
      if (ranksAbove(k, best, 0.0)) best = k;
    }
    return ranksAbove(best, leader_, switch_margin_) ? best : leader_;
  }

  /// consensusChoice over the members' best paths, lost members left out; the evidence's
  /// choice while it has none (fewer than three comparable paths, or lengths that differ).
  int consensusLeader() const {
    std::vector<std::vector<Pose2>> paths;
    std::vector<size_t> lengths(members_.size());
    std::vector<bool> left_out;
    for (int k = 0; k < static_cast<int>(members_.size()); ++k) {
      paths.push_back(members_[k]->bestPathSample(consensus_max_poses_, &lengths[k]));
      left_out.push_back(lost(k));
    }
    const int choice = consensusChoice(paths, lengths, left_out, leader_, consensus_margin_m_);
    return choice >= 0 ? choice : evidenceLeader();
  }

  /// A member whose evidence fell to -inf (an update no particle could explain): lost.
  bool lost(int k) const { return !(log_evidence_[k] > -INFINITY); }
  bool allLost() const {
    for (int k = 0; k < static_cast<int>(members_.size()); ++k) {
      if (!lost(k)) return false;
    }
    return true;
  }

  /// Whether member a ranks above member b, with a's evidence ahead by more than margin. A
  /// lost member never ranks above one that is not (with rank_by new_landmarks either).
  bool ranksAbove(int a, int b, double margin) const {
    if (lost(a) != lost(b)) return lost(b);
    const bool more_evidence = log_evidence_[a] > log_evidence_[b] + margin;
    if (!by_new_landmarks_) return more_evidence;
    return created_[a] < created_[b] || (created_[a] == created_[b] && more_evidence);
  }

  std::vector<std::unique_ptr<SlamFilter>> members_;
  const bool by_new_landmarks_;       // EnsembleOptions::rank_by
  const bool by_consensus_;           // EnsembleOptions::rank_by, with three members or more
  const double switch_margin_;        // EnsembleOptions::switch_margin
  const long consensus_period_;       // EnsembleOptions::consensus_period
  const double consensus_margin_m_;   // EnsembleOptions::consensus_margin_m
  const size_t consensus_max_poses_;  // EnsembleOptions::consensus_max_poses
  std::vector<double> log_evidence_;  // summed UpdateStats::log_evidence per member
  std::vector<long> created_;         // summed UpdateStats::new_landmarks per member
  int leader_ = 0;
  long leader_changes_ = 0;
  long updates_ = 0;  // since the last reset or loaded map (consensus_period counts them)
};

}  // namespace

int consensusChoice(const std::vector<std::vector<Pose2>>& paths,
                    const std::vector<size_t>& lengths, const std::vector<bool>& left_out,
                    int leader, double margin_m) {
  if (lengths.size() != paths.size() || left_out.size() != paths.size()) {
    throw std::invalid_argument("consensusChoice: one length and one left_out flag per path");
  }
  std::vector<std::vector<Pose2>> compared;
  std::vector<int> who;  // member of each compared path
  for (int k = 0; k < static_cast<int>(paths.size()); ++k) {
    // Compared whole lengths: two cut paths of equal size may come from unequal ones.
    if (paths[k].empty() || lengths[k] != lengths[0]) return -1;
    if (left_out[k]) continue;
    const std::vector<Pose2>& p = paths[k];
    if (!std::all_of(p.begin(), p.end(), [](const Pose2& x) { return x.allFinite(); })) continue;
    compared.push_back(p);
    who.push_back(k);
  }
  if (compared.size() < 3) return -1;
  const std::vector<double> d = medianDistancesToOthers(compared);
  const int best = static_cast<int>(std::min_element(d.begin(), d.end()) - d.begin());
  const auto current = std::find(who.begin(), who.end(), leader);
  if (current == who.end()) return who[best];  // the leader itself was left out
  return d[best] < d[current - who.begin()] - margin_m ? who[best] : leader;
}

double addLogEvidence(double total, double update_log_evidence) {
  return std::isfinite(update_log_evidence) ? total + update_log_evidence : -INFINITY;
}

unsigned long ensembleMemberSeed(unsigned long seed, int k) {
  if (k == 0) return seed;
  // splitmix64 of (seed, k).
  std::uint64_t z = static_cast<std::uint64_t>(seed) +
                    0x9E3779B97F4A7C15ULL * static_cast<std::uint64_t>(k);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return static_cast<unsigned long>(z ^ (z >> 31));
}

std::unique_ptr<SlamFilter> createEnsembleFilter(const FilterOptions& options) {
  validate(options);
  return std::make_unique<EnsembleFilter>(options);
}

}  // namespace core
}  // namespace rbpf_slam

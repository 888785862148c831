// An ensemble of independent filters (ensemble_filter.h): each member is exactly the filter of
// its seed, the reported one has the largest summed log evidence, the evidence favours the
// sighting that fits the map, the reported member changes only past ensemble.switch_margin,
// commands reach every member, bad options are named, and the smoother picks the member whose
// map leaves the fewest sightings out, each of its landmarks counted as
// smoothing.member_landmark_cost sightings left out, or with smoothing.member_consensus_margin
// the one among those scoring near the best whose path agrees with the other members'.

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/core/alignment.h"
#include "rbpf_slam/core/filters/ensemble_filter.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/slam/map_smoother.h"
#include "rbpf_slam/core/slam/slam_session.h"

namespace rbpf_slam {
namespace {

using core::Pose2;

const std::vector<Eigen::Vector2d> kPosts{{0.5, 0.5}, {-1.0, 1.0}, {-0.5, -1.5}, {2.0, -0.5}};

Pose2 onCircle(int i, int steps) {
  const double a = 2.0 * M_PI * i / steps;
  return Pose2(3.0 * std::cos(a), 3.0 * std::sin(a), core::wrapAngle(a + M_PI / 2));
}

core::FeatureSet sightings(const Pose2& pose, double stamp) {
  core::FeatureSet set;
  set.stamp = stamp;
  for (const Eigen::Vector2d& p : kPosts) {
    core::PointFeature f;
    const Eigen::Vector2d z = core::predictPoint(pose, p).z;
    f.range = z.x();
    f.bearing = z.y();
    f.covariance = Eigen::Vector2d(0.05 * 0.05, 0.02 * 0.02).asDiagonal();
    set.points.push_back(f);
  }
  return set;
}

core::FilterOptions pointOptions(int members) {
  core::FilterOptions o;
  o.particles = 20;
  o.use_lines = false;
  o.seed = 7;
  o.ensemble.members = members;
  return o;
}

/// Drives a circle with noisy odometry (a fixed draw, sigma per step in m and rad) through
/// every filter given; *leaders (when given) gets filters[0]'s leader after each update, and
/// each (when given) is called with the update's number (1, 2, ...) after it.
void drive(const std::vector<core::SlamFilter*>& filters,
           std::vector<std::vector<core::UpdateStats>>* stats, double sigma = 0.05,
           std::vector<int>* leaders = nullptr,
           const std::function<void(int)>& each = nullptr) {
  core::Rng rng(3);
  const int steps = 40;
  stats->assign(filters.size(), {});
  for (int i = 1; i < steps; ++i) {
    core::MotionInput m;
    m.stamp = i;
    m.dt = 1.0;
    m.delta = core::between(onCircle(i - 1, steps), onCircle(i, steps));
    m.delta += Pose2(core::sampleGaussian(rng, sigma), core::sampleGaussian(rng, sigma),
                     core::sampleGaussian(rng, sigma));
    const core::FeatureSet seen = sightings(onCircle(i, steps), i);
    for (size_t k = 0; k < filters.size(); ++k) {
      filters[k]->predict(m);
      (*stats)[k].push_back(filters[k]->update(seen));
    }
    if (leaders) leaders->push_back(filters[0]->leader());
    if (each) each(i);
  }
}

/// The ensemble followed by each of its members' filters run alone (made into *alone).
std::vector<core::SlamFilter*> withMembersAlone(
    const core::FilterOptions& options, core::SlamFilter* ensemble,
    std::vector<std::unique_ptr<core::SlamFilter>>* alone) {
  std::vector<core::SlamFilter*> all{ensemble};
  for (int k = 0; k < options.ensemble.members; ++k) {
    core::FilterOptions o = options;
    o.ensemble.members = 1;
    o.seed = core::ensembleMemberSeed(options.seed, k);
    alone->push_back(core::createFilter(o));
    all.push_back(alone->back().get());
  }
  return all;
}

TEST(EnsembleFilter, AnEnsembleOfOneIsThePlainFilter) {
  const auto filter = core::createFilter(pointOptions(1));
  EXPECT_EQ(filter->members(), 1);
  EXPECT_EQ(filter->leader(), 0);
  EXPECT_EQ(&filter->member(0), filter.get());
  EXPECT_EQ(core::ensembleMemberSeed(7, 0), 7u);
}

TEST(EnsembleFilter, MemberSeedsDifferAcrossMembersAndNeighbouringRunSeeds) {
  std::set<unsigned long> seen;
  for (unsigned long seed = 1; seed <= 50; ++seed) {
    for (int k = 0; k < 8; ++k) seen.insert(core::ensembleMemberSeed(seed, k));
  }
  EXPECT_EQ(seen.size(), 50u * 8u);  // seed s, member 1 is not seed s + 1, member 0
}

TEST(EnsembleFilter, EachMemberIsTheFilterOfItsSeedAndTheLeaderRanksFirst) {
  const int members = 4;
  std::vector<int> leaders;
  for (const std::string rank_by : {"evidence", "new_landmarks"}) {
    core::FilterOptions options = pointOptions(members);
    options.seed = 5;  // a seed where the two rankings lead with different members, neither 0
    options.ensemble.rank_by = rank_by;
    options.particles = 5;  // few particles: members that differ in what they create
    options.motion.alpha1 = options.motion.alpha3 = 0.3;
    const auto ensemble = core::createFilter(options);
    ASSERT_EQ(ensemble->members(), members);
    std::vector<std::unique_ptr<core::SlamFilter>> alone;
    const std::vector<core::SlamFilter*> all = withMembersAlone(options, ensemble.get(), &alone);
    std::vector<std::vector<core::UpdateStats>> stats;
    drive(all, &stats, 0.25);  // odometry bad enough for some members to map copies
    std::vector<double> evidence(members, 0.0);
    std::vector<int> created(members, 0);
    for (int k = 0; k < members; ++k) {
      for (const core::UpdateStats& u : stats[k + 1]) {
        ASSERT_TRUE(std::isfinite(u.log_evidence));
        evidence[k] += u.log_evidence;
        created[k] += u.new_landmarks;
      }
      // Member k is the filter of its seed, draw for draw.
      const std::vector<Pose2> mine = ensemble->member(k).bestPath(), its = alone[k]->bestPath();
      ASSERT_EQ(mine.size(), its.size());
      for (size_t i = 0; i < mine.size(); ++i) ASSERT_EQ(mine[i], its[i]) << "member " << k;
    }
    // The draws differ, so do the evidences (else this test could not tell the leader).
    EXPECT_NE(evidence[0], evidence[1]);
    EXPECT_NE(evidence[1], evidence[2]);
    int best = 0;
    for (int k = 1; k < members; ++k) {
      const bool more = evidence[k] > evidence[best];
      const bool fewer = created[k] < created[best] || (created[k] == created[best] && more);
      if (rank_by == "evidence" ? more : fewer) {
        best = k;
      }
    }
    SCOPED_TRACE(rank_by + ": created " + std::to_string(created[0]) + " " +
                 std::to_string(created[1]) + " " + std::to_string(created[2]) + " " +
                 std::to_string(created[3]));
    // The counts differ too, so that ranking by them is not ranking by the evidence.
    EXPECT_FALSE(created[0] == created[1] && created[1] == created[2] && created[2] == created[3]);
    EXPECT_EQ(ensemble->leader(), best);
    leaders.push_back(best);
    EXPECT_EQ(ensemble->estimate().mean, alone[best]->estimate().mean);
    EXPECT_EQ(ensemble->bestPath(), alone[best]->bestPath());
    EXPECT_EQ(ensemble->landmarks().size(), alone[best]->landmarks().size());
    // The leader's UpdateStats.
    EXPECT_EQ(stats[0].back().log_evidence, stats[best + 1].back().log_evidence);
  }
  // Neither ranking is "always member 0", and they differ here: each was tested.
  EXPECT_TRUE(leaders[0] != 0 || leaders[1] != 0);
  EXPECT_NE(leaders[0], leaders[1]);
}

// With ensemble.switch_margin the reported member changes only when another leads it by more
// than the margin: fewer changes than without, each one where the running sums say.
TEST(EnsembleFilter, TheLeaderChangesOnlyWhenAnotherLeadsByTheMargin) {
  const int members = 4;
  std::vector<long> changes;
  for (const double margin : {0.0, 3.0}) {
    core::FilterOptions options = pointOptions(members);
    options.seed = 5;
    options.particles = 5;
    options.motion.alpha1 = options.motion.alpha3 = 0.3;
    options.ensemble.switch_margin = margin;
    const auto ensemble = core::createFilter(options);
    std::vector<std::unique_ptr<core::SlamFilter>> alone;
    const std::vector<core::SlamFilter*> all = withMembersAlone(options, ensemble.get(), &alone);
    std::vector<std::vector<core::UpdateStats>> stats;
    std::vector<int> leaders;
    drive(all, &stats, 0.25, &leaders);
    // The leader each update should have, from the members' own evidences.
    std::vector<double> sum(members, 0.0);
    int leader = 0;
    long changed = 0;
    for (size_t t = 0; t < leaders.size(); ++t) {
      int best = 0;
      for (int k = 0; k < members; ++k) {
        sum[k] += stats[k + 1][t].log_evidence;
        if (sum[k] > sum[best]) best = k;
      }
      if (sum[best] > sum[leader] + margin) {
        changed += best != leader;
        leader = best;
      }
      ASSERT_EQ(leaders[t], leader) << "update " << t << ", margin " << margin;
    }
    EXPECT_EQ(ensemble->stats().leader_changes, changed);
    changes.push_back(changed);
    ensemble->reset(Pose2::Zero());  // a new map: its own count
    EXPECT_EQ(ensemble->stats().leader_changes, 0);
  }
  EXPECT_GT(changes[0], changes[1]);  // the margin held back at least one change
  EXPECT_GT(changes[1], 0);           // and let a member that pulled ahead take over
}

// A member whose update gives a non-finite evidence is lost for good, whatever follows: the
// running sum is -inf, never NaN (-inf + inf), so the ranking stays an order.
TEST(EnsembleFilter, NonFiniteEvidenceLosesTheMemberAndNeverGivesNaN) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(core::addLogEvidence(-2.5, 1.0), -1.5);
  for (const double bad : {std::nan(""), inf, -inf}) {
    double total = core::addLogEvidence(-2.5, bad);
    EXPECT_EQ(total, -inf) << bad;
    for (const double next : {3.0, inf, -inf, std::nan("")}) {
      total = core::addLogEvidence(total, next);
      EXPECT_EQ(total, -inf) << bad << " then " << next;
    }
  }
}

/// The options of the consensus tests: members of five particles each, noisy odometry.
core::FilterOptions consensusOptions(int members, int period, double margin) {
  core::FilterOptions options = pointOptions(members);
  options.seed = 5;
  options.particles = 5;
  options.motion.alpha1 = options.motion.alpha3 = 0.3;
  options.ensemble.rank_by = "consensus";
  options.ensemble.consensus_period = period;
  options.ensemble.consensus_margin_m = margin;
  return options;
}

/// The consensus rule recomputed from the members' best paths (max_poses of each) after each
/// update: every period-th update (counted since restart()) the member with the smallest median
/// distance to the others, unless the expected leader's is within the margin. Asserts that the
/// ensemble reports that member.
struct ConsensusCheck {
  const core::SlamFilter& ensemble;
  int period;
  double margin;
  size_t max_poses = 4000;
  int expected = 0;
  long changes = 0;
  long updates = 0;

  void operator()(int /*update*/) {
    if (++updates % period == 0) {
      std::vector<std::vector<Pose2>> paths;
      for (int k = 0; k < ensemble.members(); ++k) {
        paths.push_back(core::evenlySpacedPoses(ensemble.member(k).bestPath(), max_poses));
      }
      const std::vector<double> d = core::medianDistancesToOthers(paths);
      const int best = static_cast<int>(std::min_element(d.begin(), d.end()) - d.begin());
      if (d[best] < d[expected] - margin) {
        changes += best != expected;
        expected = best;
      }
    }
    ASSERT_EQ(ensemble.leader(), expected) << "update " << updates;
    EXPECT_EQ(ensemble.estimate().mean, ensemble.member(expected).estimate().mean);
  }
  /// A loaded map: member 0 is reported (a change if another was) and the period starts again.
  void restart() {
    changes += expected != 0;
    expected = 0;
    updates = 0;
  }
};

// With rank_by consensus the reported member is chosen every consensus_period updates: the one
// whose best path is closest to the others' (median RMS distance after rigid alignment), unless
// the leader's is within consensus_margin_m of it; in between the leader stays. With
// consensus_max_poses below the paths' length, only that many evenly spaced poses count.
TEST(EnsembleFilter, ConsensusReportsTheMemberWhosePathTheOthersAgreeWith) {
  std::vector<std::vector<int>> leaders;
  for (const int max_poses : {4000, 10}) {
    core::FilterOptions options = consensusOptions(5, 3, 0.01);
    options.ensemble.consensus_max_poses = max_poses;
    const auto ensemble = core::createFilter(options);
    ConsensusCheck check{*ensemble, 3, 0.01, static_cast<size_t>(max_poses)};
    std::vector<std::vector<core::UpdateStats>> stats;
    leaders.emplace_back();
    drive({ensemble.get()}, &stats, 0.25, &leaders.back(), std::ref(check));
    EXPECT_EQ(ensemble->stats().leader_changes, check.changes);
    EXPECT_GT(check.changes, 0);  // it moved off member 0: the test tells it from a fixed leader
  }
  EXPECT_NE(leaders[0], leaders[1]);  // the subsampled paths chose otherwise at least once
}

// The consensus rule on its own. Five straight paths, member k bent by 0.1 k m: member 1 is
// closest to the others. A lost member (left out) or one whose path holds a NaN pose takes no
// part: not chosen, and no longer the reason the others' comparison is given up (one NaN pose
// used to hand the choice to the evidence for the rest of the run).
TEST(EnsembleFilter, ConsensusLeavesOutLostMembersAndNonFinitePaths) {
  std::vector<std::vector<Pose2>> paths(5);
  for (int k = 0; k < 5; ++k) {
    for (int i = 0; i < 30; ++i) paths[k].push_back(Pose2(0.2 * i, 0.1 * k * (i > 15), 0.0));
  }
  const std::vector<bool> none(5, false);
  std::vector<size_t> lengths(5, 30);
  EXPECT_EQ(core::consensusChoice(paths, lengths, none, 0, 0.0), 2);  // the middle one
  EXPECT_EQ(core::consensusChoice(paths, lengths, none, 1, 0.2), 1);  // within the margin
  std::vector<bool> lost = none;
  lost[2] = true;
  const int without_2 = core::consensusChoice(paths, lengths, lost, 0, 0.0);
  EXPECT_NE(without_2, 2);
  EXPECT_GE(without_2, 0);
  EXPECT_NE(core::consensusChoice(paths, lengths, lost, 2, 1e9), 2) << "a lost leader is replaced";
  std::vector<std::vector<Pose2>> broken = paths;
  broken[3][7].x() = std::nan("");
  const int with_nan = core::consensusChoice(broken, lengths, none, 0, 0.0);
  EXPECT_GE(with_nan, 0) << "one NaN pose gave up the comparison";
  EXPECT_NE(with_nan, 3);
  lost.assign(5, false);
  lost[0] = lost[1] = true;
  EXPECT_EQ(core::consensusChoice(broken, lengths, lost, 0, 0.0), -1) << "two paths left";
  lengths[4] = 29;
  EXPECT_EQ(core::consensusChoice(broken, lengths, none, 0, 0.0), -1) << "lengths differ";
}

// After resetPose every member's path starts again, equally long, and the consensus goes on
// over them at the same rhythm. A loaded map is every member's: member 0 is reported (counted
// as a change when another led) and the next choice comes a full period after the load; a map
// refused changes nothing.
TEST(EnsembleFilter, ConsensusGoesOnAfterAPoseResetAndRestartsOnALoadedMap) {
  const int period = 4;  // does not divide drive()'s 39 updates: a lost count shows
  const auto ensemble = core::createFilter(consensusOptions(5, period, 0.01));
  ConsensusCheck check{*ensemble, period, 0.01};
  std::vector<std::vector<core::UpdateStats>> stats;
  drive({ensemble.get()}, &stats, 0.25, nullptr, std::ref(check));
  ASSERT_TRUE(ensemble->resetPose(onCircle(0, 40), 1e-4 * Eigen::Matrix3d::Identity()));
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(ensemble->member(k).bestPath().empty()) << k;
  drive({ensemble.get()}, &stats, 0.25, nullptr, std::ref(check));
  ASSERT_GT(check.changes, 0);
  ASSERT_NE(check.expected, 0);  // so that the load below changes the reported member
  const long before_load = check.changes;
  std::vector<core::LandmarkEstimate> broken = ensemble->member(check.expected).landmarks();
  ASSERT_FALSE(broken.empty());
  broken.back().mean.x() = NAN;
  EXPECT_FALSE(ensemble->loadMap(broken));  // refused: the reported member stays
  EXPECT_EQ(ensemble->leader(), check.expected);
  EXPECT_EQ(ensemble->stats().leader_changes, before_load);
  ASSERT_TRUE(ensemble->loadMap(ensemble->member(check.expected).landmarks()));
  check.restart();
  EXPECT_EQ(ensemble->leader(), 0);
  EXPECT_EQ(ensemble->stats().leader_changes, before_load + 1);
  drive({ensemble.get()}, &stats, 0.25, nullptr, std::ref(check));
  EXPECT_EQ(ensemble->stats().leader_changes, check.changes);
}

// Fewer than three members cannot agree on anything: consensus falls back on the evidence, at
// every update whatever the period.
TEST(EnsembleFilter, ConsensusOfTwoMembersFallsBackOnTheEvidence) {
  std::vector<std::vector<int>> leaders(2);
  for (int i = 0; i < 2; ++i) {
    core::FilterOptions options = consensusOptions(2, 7, 0.05);
    if (i == 0) options.ensemble.rank_by = "evidence";
    const auto ensemble = core::createFilter(options);
    std::vector<std::vector<core::UpdateStats>> stats;
    drive({ensemble.get()}, &stats, 0.25, &leaders[i]);
  }
  EXPECT_EQ(leaders[0], leaders[1]);
  EXPECT_NE(std::set<int>(leaders[0].begin(), leaders[0].end()).size(), 1u);  // both led
}

TEST(EnsembleFilter, TheEvidenceFavoursASightingThatFitsTheMap) {
  double fits = 0.0, new_landmark = 0.0;
  for (bool consistent : {true, false}) {
    const auto filter = core::createFilter(pointOptions(1));
    core::FeatureSet first;
    core::PointFeature f;
    f.range = 3.0;
    f.covariance = Eigen::Vector2d(0.05 * 0.05, 0.02 * 0.02).asDiagonal();
    first.points.push_back(f);
    EXPECT_EQ(filter->update(core::FeatureSet()).log_evidence, 0.0);  // nothing seen: no evidence
    filter->update(first);
    core::FeatureSet second = first;
    if (!consistent) second.points[0].bearing = 1.5;  // where the map has nothing
    const double e = filter->update(second).log_evidence;
    ASSERT_TRUE(std::isfinite(e));
    (consistent ? fits : new_landmark) = e;
  }
  EXPECT_GT(fits, new_landmark + 1.0);
}

TEST(EnsembleFilter, ResetsAndLocalizationReachEveryMember) {
  const auto ensemble = core::createFilter(pointOptions(3));
  std::vector<std::vector<core::UpdateStats>> stats;
  drive({ensemble.get()}, &stats);
  std::vector<size_t> mapped;
  for (int k = 0; k < 3; ++k) mapped.push_back(ensemble->member(k).landmarks().size());
  ASSERT_TRUE(ensemble->setMapping(false));
  core::FeatureSet far;
  core::PointFeature f;
  f.range = 4.0;
  f.bearing = 2.5;
  f.covariance = Eigen::Vector2d(0.05 * 0.05, 0.02 * 0.02).asDiagonal();
  far.points.push_back(f);
  ensemble->update(far);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(ensemble->member(k).landmarks().size(), mapped[k]);
  ASSERT_TRUE(ensemble->resetPose(Pose2(1.0, 2.0, 0.5), 1e-6 * Eigen::Matrix3d::Identity()));
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR((ensemble->member(k).estimate().mean - Pose2(1.0, 2.0, 0.5)).norm(), 0.0, 0.01);
  }
  // A loaded map reaches every member.
  std::vector<core::LandmarkEstimate> map(1);
  map[0].mean = Eigen::Vector2d(5.0, 5.0);
  map[0].covariance = 1e-4 * Eigen::Matrix2d::Identity();
  ASSERT_TRUE(ensemble->loadMap(map));
  for (int k = 0; k < 3; ++k) ASSERT_EQ(ensemble->member(k).landmarks().size(), 1u);
  ensemble->reset(Pose2::Zero());
  EXPECT_EQ(ensemble->leader(), 0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(ensemble->member(k).landmarks().empty());
    EXPECT_TRUE(ensemble->member(k).bestPath().empty());
  }
}

TEST(EnsembleFilter, BadOptionsAreNamed) {
  auto message = [](const core::FilterOptions& o) {
    try {
      core::createFilter(o);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  core::FilterOptions o = pointOptions(0);
  EXPECT_NE(message(o).find("ensemble.members"), std::string::npos) << message(o);
  o = pointOptions(65);
  EXPECT_NE(message(o).find("ensemble.members"), std::string::npos) << message(o);
  o = pointOptions(2);
  o.ensemble.rank_by = "weight";
  EXPECT_NE(message(o).find("ensemble.rank_by"), std::string::npos) << message(o);
  o = pointOptions(2);
  o.ensemble.consensus_period = 0;
  EXPECT_NE(message(o).find("ensemble.consensus_period"), std::string::npos) << message(o);
  o = pointOptions(2);
  o.ensemble.consensus_margin_m = -0.1;
  EXPECT_NE(message(o).find("ensemble.consensus_margin_m"), std::string::npos) << message(o);
  o = pointOptions(2);
  o.ensemble.consensus_max_poses = 9;
  EXPECT_NE(message(o).find("ensemble.consensus_max_poses"), std::string::npos) << message(o);
  o = pointOptions(2);
  o.ensemble.switch_margin = -1.0;
  EXPECT_NE(message(o).find("ensemble.switch_margin"), std::string::npos) << message(o);
  o.ensemble.switch_margin = NAN;
  EXPECT_NE(message(o).find("ensemble.switch_margin"), std::string::npos) << message(o);
  o = pointOptions(2);
  o.variant = "ekf_slam";
  EXPECT_NE(message(o).find("ensemble.members > 1 is not implemented for variant 'ekf_slam'"),
            std::string::npos) << message(o);
  o = pointOptions(2);
  o.variant = "robust_fastslam2";
  EXPECT_NE(message(o).find("not implemented for variant 'robust_fastslam2'"), std::string::npos)
      << message(o);
  EXPECT_THROW(core::createEnsembleFilter(pointOptions(0)), std::invalid_argument);
  o = pointOptions(2);
  o.dpf.fault.enabled = true;
  EXPECT_NE(message(o).find("fault.enabled"), std::string::npos) << message(o);
  o = pointOptions(2);
  o.variant = "hinf_fastslam";
  EXPECT_EQ(message(o), "accepted");
}

/// Two (or three) fixed members for the smoother: given paths and maps, no filtering.
class FixedEnsemble : public core::SlamFilter {
 public:
  struct Member : core::SlamFilter {
    std::vector<Pose2> path;
    std::vector<core::LandmarkEstimate> map;
    std::string variant() const override { return "fixed"; }
    void reset(const Pose2&) override {}
    void predict(const core::MotionInput&) override {}
    core::UpdateStats update(const core::FeatureSet&) override { return {}; }
    core::PoseEstimate estimate() const override {
      core::PoseEstimate e;
      e.mean = path.empty() ? Pose2::Zero() : path.back();
      return e;
    }
    std::vector<core::LandmarkEstimate> landmarks() const override { return map; }
    std::vector<core::WeightedPose> particles() const override { return {}; }
    core::FilterStats stats() const override { return {}; }
    std::vector<Pose2> bestPath() const override { return path; }
  };
  Member members_[3];
  int count_ = 2;
  int leader_ = 0;
  // Updates grow both members' paths along the truth; the test then bends member 0's.
  std::string variant() const override { return "fixed"; }
  void reset(const Pose2&) override {}
  void predict(const core::MotionInput&) override {}
  core::UpdateStats update(const core::FeatureSet&) override { return {}; }
  core::PoseEstimate estimate() const override { return members_[leader_].estimate(); }
  std::vector<core::LandmarkEstimate> landmarks() const override { return members_[leader_].map; }
  std::vector<core::WeightedPose> particles() const override { return {}; }
  core::FilterStats stats() const override { return {}; }
  std::vector<Pose2> bestPath() const override { return members_[leader_].path; }
  int members() const override { return count_; }
  const core::SlamFilter& member(int k) const override { return members_[k]; }
  int leader() const override { return leader_; }
};

/// A session of a fixed two-member ensemble driven once round the circle (frames kept), the
/// true path and the posts as a map.
struct FixedSession {
  static constexpr int kSteps = 30;
  static constexpr double kTurn = 0.7;  // rad: how far a member that lost its heading is off
  FixedEnsemble* fixed = nullptr;
  std::unique_ptr<core::SlamSession> session;
  std::vector<Pose2> truth;
  std::vector<core::LandmarkEstimate> map;

  FixedSession() {
    auto owned = std::make_unique<FixedEnsemble>();
    fixed = owned.get();
    core::SessionOptions options;
    options.keep_frames = true;
    options.filter_origin = "odom";  // the fixed paths and maps are in the map frame already
    session = std::make_unique<core::SlamSession>(std::move(owned), options);
    for (int i = 0; i < kSteps; ++i) {
      truth.push_back(onCircle(i, kSteps));
      session->process(1.0 + i, truth.back(), sightings(truth.back(), 1.0 + i));
    }
    for (size_t k = 0; k < kPosts.size(); ++k) {
      core::LandmarkEstimate l;
      l.id = static_cast<int>(k);
      l.mean = kPosts[k];
      l.covariance = 1e-4 * Eigen::Matrix2d::Identity();
      map.push_back(l);
    }
  }
  Pose2 pivot() const { return truth[kSteps / 2]; }
  /// p turned by kTurn about the pivot (where a member turned from there sees it).
  Eigen::Vector2d turned(const Eigen::Vector2d& p) const {
    return pivot().head<2>() + Eigen::Rotation2Dd(kTurn) * (p - pivot().head<2>());
  }
  /// Member k lost its heading half way round (lostPath) and mapped copies of the posts where
  /// its turned half saw them.
  void loseWithCopies(int k) {
    FixedEnsemble::Member& member = fixed->members_[k];
    member.path = lostPath();
    member.map = map;
    for (const core::LandmarkEstimate& l : map) {
      core::LandmarkEstimate copy = l;
      copy.id += 100;
      copy.mean = turned(l.mean);
      member.map.push_back(copy);
    }
  }
  /// The truth with its second half turned by kTurn about the pivot.
  std::vector<Pose2> lostPath() const {
    std::vector<Pose2> path = truth;
    for (int i = kSteps / 2; i < kSteps; ++i) {
      path[i] << turned(truth[i].head<2>()), core::wrapAngle(truth[i].z() + kTurn);
    }
    return path;
  }
};

TEST(EnsembleFilter, TheSmootherTakesTheMemberWhoseMapLeavesFewestSightingsOut) {
  FixedSession s;
  ASSERT_EQ(s.session->frames().size(), static_cast<size_t>(FixedSession::kSteps));
  core::SlamSession& session = *s.session;
  FixedEnsemble* fixed = s.fixed;
  // Member 0 (the leader) lost its heading half way round: its second half is turned by
  // 40 degrees about the pose there, so the sightings of that half miss the posts' gates.
  fixed->members_[0].path = s.lostPath();
  fixed->members_[0].map = s.map;
  fixed->members_[1].path = s.truth;
  fixed->members_[1].map = s.map;
  fixed->leader_ = 0;
  core::FilterOptions filter = pointOptions(1);
  core::SmoothingOptions smoothing;
  smoothing.enabled = true;
  const core::SmoothingResult r = core::smoothSession(session, filter, smoothing);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.member, 1) << r.message;
  EXPECT_EQ(r.sightings_left_out, 0) << r.message;
  EXPECT_NE(r.message.find("member 1 of 2 (the filter's leader 0; 0 sightings left out"),
            std::string::npos)
      << r.message;
  // Member 0 alone leaves sightings out: the choice was not a tie.
  fixed->members_[1].path = fixed->members_[0].path;
  const core::SmoothingResult lost = core::smoothSession(session, filter, smoothing);
  EXPECT_GT(lost.sightings_left_out, 10) << lost.message;
}

// smoothing.member_landmark_cost: a member that lost its way and mapped copies of the posts
// where its turned half saw them explains every sighting, with twice the landmarks; the member
// on the true path missed one post. Without the cost the copies win; with it each landmark
// counts as that many sightings left out, and the member with the smaller map wins.
TEST(EnsembleFilter, EachLandmarkCountsAsSightingsLeftOutWhenChoosingAMember) {
  FixedSession s;
  FixedEnsemble* fixed = s.fixed;
  s.loseWithCopies(0);
  fixed->members_[1].path = s.truth;
  fixed->members_[1].map.assign(s.map.begin(), s.map.end() - 1);  // the last post never mapped
  core::FilterOptions filter = pointOptions(1);
  core::SmoothingOptions smoothing;
  smoothing.enabled = true;
  const core::SmoothingResult copies = core::smoothSession(*s.session, filter, smoothing);
  ASSERT_TRUE(copies.ok) << copies.message;
  EXPECT_EQ(copies.member, 0) << copies.message;
  EXPECT_EQ(copies.sightings_left_out, 0) << copies.message;
  EXPECT_EQ(copies.landmarks_smoothed, 8) << copies.message;

  smoothing.member_landmark_cost = 10.0;  // member 0: 0 + 10 x 8; member 1: 30 + 10 x 3
  const core::SmoothingResult r = core::smoothSession(*s.session, filter, smoothing);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.member, 1) << r.message;
  EXPECT_EQ(r.sightings_left_out, FixedSession::kSteps) << r.message;
  EXPECT_EQ(r.landmarks_smoothed, 3) << r.message;
  EXPECT_NE(r.message.find("30 sightings left out + 10 x 3 landmarks"), std::string::npos)
      << r.message;
  // Every member's sightings left out and landmarks, for a choice that went wrong.
  EXPECT_NE(r.message.find("each smoothed member's sightings left out and landmarks: 0: 0 and 8, "
                           "1: 30 and 3"),
            std::string::npos)
      << r.message;
}

// smoothing.member_consensus_margin in smoothSession: the lost member of the test above, with its
// copies, scores best when a landmark costs little; two members on the true path score a little
// worse. A margin too narrow for them keeps the best score; two members take no consensus.
TEST(EnsembleFilter, TheSmootherAsksForAConsensusOnlyWithinTheMarginAndFromThreeMembers) {
  FixedSession s;
  FixedEnsemble* fixed = s.fixed;
  fixed->count_ = 3;
  s.loseWithCopies(0);
  for (int k : {1, 2}) {
    fixed->members_[k].path = s.truth;
    fixed->members_[k].map.assign(s.map.begin(), s.map.end() - 1);  // the last post never mapped
  }
  core::FilterOptions filter = pointOptions(1);
  core::SmoothingOptions smoothing;
  smoothing.enabled = true;
  smoothing.member_landmark_cost = 3.0;  // member 0: 0 + 3 x 8 = 24; members 1, 2: 30 + 3 x 3 = 39
  const core::SmoothingResult by_score = core::smoothSession(*s.session, filter, smoothing);
  ASSERT_TRUE(by_score.ok) << by_score.message;
  EXPECT_EQ(by_score.member, 0) << by_score.message;

  smoothing.member_consensus_margin = 10.0;  // 39 is not within 24 + 10: member 0 alone
  const core::SmoothingResult narrow = core::smoothSession(*s.session, filter, smoothing);
  ASSERT_TRUE(narrow.ok) << narrow.message;
  EXPECT_EQ(narrow.member, 0) << narrow.message;
  EXPECT_NE(narrow.message.find("of the 1 scoring within 10 of the best"), std::string::npos)
      << narrow.message;

  // (With a wider margin all three are candidates, but the smoother mends the lost path here:
  // the odometry is exact, the copies move onto the posts. The rule itself is tested below.)
  smoothing.member_consensus_margin = 20.0;
  // Two members: no consensus to take, the score rules whatever the margin.
  fixed->count_ = 2;
  const core::SmoothingResult pair = core::smoothSession(*s.session, filter, smoothing);
  ASSERT_TRUE(pair.ok) << pair.message;
  EXPECT_EQ(pair.member, 0) << pair.message;
  EXPECT_EQ(pair.message.find("scoring within"), std::string::npos) << pair.message;
}

/// A smoothing result of a three-pose straight path whose middle pose is bent sideways by bend:
/// two such paths are |bend_a - bend_b| x sqrt(2) / 3 apart after alignment.
core::SmoothingResult bentResult(int member, double bend, int left_out) {
  core::SmoothingResult r;
  r.ok = true;
  r.member = member;
  r.path = {Pose2(0.0, 0.0, 0.0), Pose2(1.0, bend, 0.0), Pose2(2.0, 0.0, 0.0)};
  r.sightings_left_out = left_out;
  return r;
}

// The rule on its own: member 0 lost its way (bent 3 m) but scores best; member 1 (bent 0.1 m)
// is 10 behind, member 3 (0.2 m) 5 behind, member 2 (straight) 90 behind. The medians of the
// distances to the others, in units of sqrt(2) / 3 m: 2.9, 0.1, 0.2, 0.2.
TEST(EnsembleFilter, TheConsensusKeepsTheCandidateWithTheSmallestMedianDistance) {
  const std::vector<core::SmoothingResult> results{bentResult(0, 3.0, 10), bentResult(1, 0.1, 20),
                                                   bentResult(2, 0.0, 100),
                                                   bentResult(3, 0.2, 15)};
  core::SmoothingOptions options;
  std::string note = "stale";
  EXPECT_EQ(core::chooseMember(results, options, &note), 0u);  // no margin: the best score
  EXPECT_EQ(note, "");
  options.member_consensus_margin = 6.0;  // members 0 and 3
  EXPECT_EQ(core::chooseMember(results, options, &note), 3u);
  EXPECT_NE(note.find("of the 2 scoring within 6 of the best"), std::string::npos) << note;
  options.member_consensus_margin = 12.0;  // members 0, 3 and 1
  EXPECT_EQ(core::chooseMember(results, options, &note), 1u);
  EXPECT_NE(note.find("median 0.0471"), std::string::npos) << note;  // 0.1 x sqrt(2) / 3
  options.member_consensus_margin = 1000.0;  // every member: member 1 still
  EXPECT_EQ(core::chooseMember(results, options, &note), 1u);
  EXPECT_NE(note.find("of the 4 scoring within 1000 of the best"), std::string::npos) << note;
  // Without member 1, of three the one between the others: 0.0 has (3.0 + 0.2) / 2 = 1.6, 0.2
  // has (2.8 + 0.2) / 2 = 1.5 (an even count of others: the mean of the middle two).
  const std::vector<core::SmoothingResult> three{results[0], results[2], results[3]};
  EXPECT_EQ(core::chooseMember(three, options), 2u);
  // Five members, four others each: the median is the mean of the middle two. Bends 3.0, 0.1,
  // 0.0, 0.3, 1.0, member 2 not a candidate: member 1 has others 0.1, 0.2, 0.9, 2.9 -> 0.55,
  // member 3 has 0.2, 0.3, 0.7, 2.7 -> 0.5 (the lower middle value alone: 0.2 against 0.3).
  const std::vector<core::SmoothingResult> five{
      bentResult(0, 3.0, 10), bentResult(1, 0.1, 10), bentResult(2, 0.0, 500),
      bentResult(3, 0.3, 10), bentResult(4, 1.0, 10)};
  options.member_consensus_margin = 100.0;
  EXPECT_EQ(core::chooseMember(five, options, &note), 3u);
  EXPECT_NE(note.find("median 0.2357"), std::string::npos) << note;  // 0.5 x sqrt(2) / 3
  // Bends 0.0, 0.1, 0.2, 0.5, 0.9, members 0 and 3 candidates: member 0 has 0.1, 0.2, 0.5, 0.9
  // -> 0.35, member 3 has 0.3, 0.4, 0.4, 0.5 -> 0.4 (the upper middle value alone: 0.5 against
  // 0.4).
  const std::vector<core::SmoothingResult> spread{
      bentResult(0, 0.0, 10), bentResult(1, 0.1, 500), bentResult(2, 0.2, 500),
      bentResult(3, 0.5, 10), bentResult(4, 0.9, 500)};
  EXPECT_EQ(core::chooseMember(spread, options, &note), 0u);
  EXPECT_NE(note.find("median 0.16499"), std::string::npos) << note;  // 0.35 x sqrt(2) / 3
  // Members that found the same path (bends under a millimetre apart): the score decides, not
  // the rounding of the medians.
  const std::vector<core::SmoothingResult> same{bentResult(0, 0.0004, 30), bentResult(1, 0.0, 20),
                                                bentResult(2, 0.0009, 10),
                                                bentResult(3, 0.0002, 40)};
  EXPECT_EQ(core::chooseMember(same, options, &note), 2u) << note;
  EXPECT_THROW(core::chooseMember({}, options), std::invalid_argument);
}

}  // namespace
}  // namespace rbpf_slam

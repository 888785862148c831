// The persistent landmark map: persistence (a copy never sees another copy's writes), the
// containers against plain std models under random operations, the spatial index against
// brute force on random maps, and FastSlam2's indexed association against its full scan.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/landmark_map.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/persistent_containers.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {
namespace {

double uniform(Rng& rng, double lo, double hi) { return lo + (hi - lo) * sampleUniform(rng); }
int uniformInt(Rng& rng, int n) {
  return std::min(n - 1, static_cast<int>(sampleUniform(rng) * n));
}

TEST(PersistentArray, VersionsMatchVectorModelsUnderRandomWrites) {
  Rng rng(1);
  std::vector<PersistentArray<int>> versions(1);
  std::vector<std::vector<int>> models(1);
  for (int step = 0; step < 100000; ++step) {
    const int v = uniformInt(rng, static_cast<int>(versions.size()));
    const double op = sampleUniform(rng);
    if (op < 0.01 && versions.size() < 12) {  // fork a version, as resampling does
      versions.push_back(versions[v]);
      models.push_back(models[v]);
    } else if (op < 0.55 || models[v].empty()) {
      versions[v].push_back(step);
      models[v].push_back(step);
    } else {
      const int i = uniformInt(rng, static_cast<int>(models[v].size()));
      versions[v].set(i, -step);
      models[v][i] = -step;
    }
  }
  int largest = 0;
  for (size_t v = 0; v < versions.size(); ++v) {
    ASSERT_EQ(versions[v].size(), static_cast<int>(models[v].size()));
    for (size_t i = 0; i < models[v].size(); ++i)
      ASSERT_EQ(versions[v][i], models[v][i]) << v << " " << i;
    largest = std::max(largest, versions[v].size());
  }
  EXPECT_GT(largest, 2048);  // deep enough for two branch levels above the leaves
}

TEST(PersistentMultimap, VersionsMatchSetModelsUnderRandomInsertsAndErases) {
  Rng rng(2);
  std::vector<PersistentMultimap> versions(1);
  std::vector<std::set<std::pair<uint64_t, int>>> models(1);
  for (int step = 0; step < 30000; ++step) {
    const int v = uniformInt(rng, static_cast<int>(versions.size()));
    const double op = sampleUniform(rng);
    // Few keys with several values each (cells with several landmarks) and large keys.
    const uint64_t key = uniformInt(rng, 300) * 0x9e3779b97f4a7c15ULL;
    const int value = uniformInt(rng, 12);  // more than a leaf holds under one key
    if (op < 0.03 && versions.size() < 30) {
      versions.push_back(versions[v]);
      models.push_back(models[v]);
    } else if (op < 0.7) {
      versions[v].insert(key, value);
      models[v].insert({key, value});
    } else {
      versions[v].erase(key, value);
      models[v].erase({key, value});
    }
  }
  for (size_t v = 0; v < versions.size(); ++v) {
    EXPECT_EQ(versions[v].size(), static_cast<long>(models[v].size()));
    for (int k = 0; k < 300; ++k) {
      const uint64_t key = k * 0x9e3779b97f4a7c15ULL;
      std::vector<int> got, want;
      versions[v].forEach(key, [&](int value) { got.push_back(value); });
      for (auto it = models[v].lower_bound({key, -1}); it != models[v].end() && it->first == key;
           ++it) {
        want.push_back(it->second);
      }
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, want) << "version " << v << " key " << k;
    }
  }
}

Landmark pointLandmark(int id, double x, double y) {
  Landmark lm;
  lm.id = id;
  lm.type = LandmarkType::kPoint;
  lm.mean << x, y;
  lm.covariance = Eigen::Vector2d(0.01, 0.01).asDiagonal();
  return lm;
}

/// A line landmark through the segment a-b (rho >= 0, extent along the normal's direction).
Landmark lineLandmark(int id, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  Landmark lm;
  lm.id = id;
  lm.type = LandmarkType::kLine;
  const Eigen::Vector2d d = (b - a).normalized();
  Eigen::Vector2d n(-d.y(), d.x());
  double rho = n.dot(a);
  if (rho < 0.0) {
    rho = -rho;
    n = -n;
  }
  lm.mean << rho, std::atan2(n.y(), n.x());
  const double sa = alongLine(lm.mean, a), sb = alongLine(lm.mean, b);
  lm.extent_min = std::min(sa, sb);
  lm.extent_max = std::max(sa, sb);
  lm.covariance = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  return lm;
}

TEST(LandmarkMap, CopiesAreIndependentIncludingTheSpatialIndex) {
  LandmarkMap original;
  for (int i = 0; i < 500; ++i) original.add(pointLandmark(i, i * 2.0, 0.0));
  LandmarkMap copy = original;
  copy.set(7, pointLandmark(7, 500.0, 500.0));  // moved far: filed under another cell
  copy.add(pointLandmark(1000, -50.0, -50.0));
  EXPECT_EQ(original.size(), 500);
  EXPECT_EQ(copy.size(), 501);
  EXPECT_DOUBLE_EQ(original[7].mean.x(), 14.0);
  EXPECT_DOUBLE_EQ(copy[7].mean.x(), 500.0);
  std::vector<int> found;
  original.pointCandidates(Eigen::Vector2d(14.0, 0.0), 0.5, &found);
  EXPECT_NE(std::find(found.begin(), found.end(), 7), found.end());
  copy.pointCandidates(Eigen::Vector2d(14.0, 0.0), 0.5, &found);
  EXPECT_EQ(std::find(found.begin(), found.end(), 7), found.end());
  copy.pointCandidates(Eigen::Vector2d(500.0, 500.0), 0.5, &found);
  EXPECT_EQ(found, std::vector<int>{7});
  original.pointCandidates(Eigen::Vector2d(500.0, 500.0), 0.5, &found);
  EXPECT_TRUE(found.empty());
  original.pointCandidates(Eigen::Vector2d(-50.0, -50.0), 0.5, &found);
  EXPECT_TRUE(found.empty());
  copy.idCandidates(1000, &found);
  EXPECT_EQ(found, std::vector<int>{500});
  original.idCandidates(1000, &found);
  EXPECT_TRUE(found.empty());
  // A write to the original after the copy leaves the copy alone too.
  original.set(3, lineLandmark(3, {0, 1}, {4, 1}));
  EXPECT_EQ(copy[3].type, LandmarkType::kPoint);
  EXPECT_EQ(original[3].type, LandmarkType::kLine);
}

TEST(LandmarkMap, RemoveKeepsOrderIndexAndOtherCopies) {
  Rng rng(9);
  LandmarkMap map;
  std::vector<Landmark> model;
  for (int i = 0; i < 300; ++i) {
    const Landmark lm = i % 3 ? pointLandmark(i, uniform(rng, -30, 30), uniform(rng, -30, 30))
                              : lineLandmark(i, {uniform(rng, -30, 30), uniform(rng, -30, 30)},
                                             {uniform(rng, -30, 30), uniform(rng, -30, 30)});
    map.add(lm);
    model.push_back(lm);
  }
  const LandmarkMap before = map;
  for (int k = 0; k < 120; ++k) {
    // Mostly recent landmarks (existence management's usual case), sometimes any.
    const int n = static_cast<int>(model.size());
    const int i = k % 4 ? n - 1 - uniformInt(rng, 5) : uniformInt(rng, n);
    map.remove(i);
    model.erase(model.begin() + i);
    if (k % 10 == 0) {  // new landmarks after removals reuse the freed slots
      const Landmark lm = pointLandmark(1000 + k, uniform(rng, -30, 30), uniform(rng, -30, 30));
      map.add(lm);
      model.push_back(lm);
    }
  }
  ASSERT_EQ(map.size(), static_cast<int>(model.size()));
  for (int i = 0; i < map.size(); ++i) {
    ASSERT_EQ(map[i].id, model[i].id);
    std::vector<int> found;
    map.idCandidates(model[i].id, &found);
    ASSERT_EQ(found, std::vector<int>{i});
    if (model[i].type == LandmarkType::kPoint) {
      map.pointCandidates(model[i].mean, 0.1, &found);
      ASSERT_TRUE(std::binary_search(found.begin(), found.end(), i));
    }
  }
  // Nothing stale: every point the index offers is a current point near the query.
  std::vector<int> found;
  map.pointCandidates(Eigen::Vector2d(0, 0), 50.0, &found);
  for (int i : found) EXPECT_LT(i, map.size());
  EXPECT_EQ(before.size(), 300);  // the copy taken before the removals is untouched
  for (int i = 0; i < 300; ++i) ASSERT_EQ(before[i].id, i);
}

/// FastSlam2::associate's pre-gate, written out independently: the brute-force reference.
bool passesLinePregate(const Landmark& lm, const LineQuery& q) {
  const Eigen::Vector2d d = lineDifference(q.line, lm.mean);
  if (std::fabs(d.y()) > q.max_angle_rad || std::fabs(d.x()) > q.max_rho_m) return false;
  const double a = alongLine(lm.mean, q.start), b = alongLine(lm.mean, q.end);
  const double gap =
      std::max({std::min(a, b) - lm.extent_max, lm.extent_min - std::max(a, b), 0.0});
  return gap <= q.overlap_margin_m;
}

/// A random map far from the origin (as the Intel log's, ~100 m out) with points and lines
/// in every direction, updated and forked after building so the index has been rewritten.
LandmarkMap randomMap(Rng& rng, int count, const Eigen::Vector2d& center, double half_size) {
  LandmarkMap map;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector2d a = center + Eigen::Vector2d(uniform(rng, -half_size, half_size),
                                                       uniform(rng, -half_size, half_size));
    if (sampleUniform(rng) < 0.4) {
      map.add(pointLandmark(i, a.x(), a.y()));
    } else {
      const double heading = uniform(rng, -M_PI, M_PI), length = uniform(rng, 0.3, 20.0);
      map.add(
          lineLandmark(i, a, a + length * Eigen::Vector2d(std::cos(heading), std::sin(heading))));
    }
  }
  LandmarkMap fork = map;
  for (int k = 0; k < count / 2; ++k) {  // move and grow some landmarks in the fork
    const int i = uniformInt(rng, count);
    Landmark lm = fork[i];
    if (lm.type == LandmarkType::kPoint) {
      lm.mean += Eigen::Vector2d(uniform(rng, -4, 4), uniform(rng, -4, 4));
    } else {
      lm.mean.y() = wrapAngle(lm.mean.y() + uniform(rng, -0.3, 0.3));
      lm.mean.x() = std::fabs(lm.mean.x() + uniform(rng, -2, 2));
      lm.extent_min -= uniform(rng, 0, 5);
      lm.extent_max += uniform(rng, 0, 5);
    }
    fork.set(i, lm);
  }
  return fork;
}

TEST(LandmarkMap, PointLookupFindsEveryPointBruteForceFinds) {
  Rng rng(4);
  long hits = 0, offered = 0, total = 0;
  for (const Eigen::Vector2d& center : {Eigen::Vector2d(0, 0), Eigen::Vector2d(-90, 140)}) {
    const LandmarkMap map = randomMap(rng, 3000, center, 60.0);
    for (int q = 0; q < 2000; ++q) {
      const Eigen::Vector2d at =
          center + Eigen::Vector2d(uniform(rng, -70, 70), uniform(rng, -70, 70));
      const double radius = q % 100 == 0 ? uniform(rng, 20, 200) : uniform(rng, 0.5, 8.0);
      std::vector<int> found;
      map.pointCandidates(at, radius, &found);
      ASSERT_TRUE(std::is_sorted(found.begin(), found.end()));
      ASSERT_EQ(std::adjacent_find(found.begin(), found.end()), found.end());
      for (int i = 0; i < map.size(); ++i) {
        if (map[i].type != LandmarkType::kPoint || (at - map[i].mean).norm() > radius) continue;
        ++hits;
        ASSERT_TRUE(std::binary_search(found.begin(), found.end(), i))
            << "point " << i << " at " << map[i].mean.transpose() << " missed from "
            << at.transpose() << " r " << radius;
      }
      offered += static_cast<long>(found.size());
      total += map.size();
    }
  }
  EXPECT_GT(hits, 1000);           // the queries do find points
  EXPECT_LT(offered, total / 20);  // and the index offers far fewer than all
}

TEST(LandmarkMap, LineLookupFindsEveryLineBruteForceFinds) {
  Rng rng(5);
  long hits = 0, offered = 0, total = 0;
  for (const Eigen::Vector2d& center : {Eigen::Vector2d(0, 0), Eigen::Vector2d(120, -80)}) {
    const LandmarkMap map = randomMap(rng, 3000, center, 60.0);
    for (int q = 0; q < 3000; ++q) {
      // Half the queries re-observe a map line (rotated, shifted, part of it), half anywhere.
      LineQuery query;
      const int i = uniformInt(rng, map.size());
      if (q % 2 == 0 && map[i].type == LandmarkType::kLine) {
        const Landmark& lm = map[i];
        const double s = uniform(rng, lm.extent_min - 2, lm.extent_max + 2);
        const Eigen::Vector2d mid =
            pointOnLine(lm.mean, s) +
            uniform(rng, -2, 2) * Eigen::Vector2d(std::cos(lm.mean.y()), std::sin(lm.mean.y()));
        const double heading = lm.mean.y() + M_PI / 2 + uniform(rng, -0.6, 0.6);
        const double half = uniform(rng, 0.2, 5.0);
        query.start = mid - half * Eigen::Vector2d(std::cos(heading), std::sin(heading));
        query.end = mid + half * Eigen::Vector2d(std::cos(heading), std::sin(heading));
      } else {
        const Eigen::Vector2d mid =
            center + Eigen::Vector2d(uniform(rng, -70, 70), uniform(rng, -70, 70));
        const double heading = uniform(rng, -M_PI, M_PI), half = uniform(rng, 0.2, 8.0);
        query.start = mid - half * Eigen::Vector2d(std::cos(heading), std::sin(heading));
        query.end = mid + half * Eigen::Vector2d(std::cos(heading), std::sin(heading));
      }
      query.line = lineLandmark(-1, query.start, query.end).mean;
      query.overlap_margin_m = q % 7 == 0 ? 0.0 : uniform(rng, 0.2, 3.0);
      std::vector<int> found;
      map.lineCandidates(query, &found);
      ASSERT_TRUE(std::is_sorted(found.begin(), found.end()));
      ASSERT_EQ(std::adjacent_find(found.begin(), found.end()), found.end());
      for (int k = 0; k < map.size(); ++k) {
        if (map[k].type != LandmarkType::kLine || !passesLinePregate(map[k], query)) continue;
        ++hits;
        ASSERT_TRUE(std::binary_search(found.begin(), found.end(), k))
            << "line " << k << " (" << map[k].mean.transpose() << " [" << map[k].extent_min << ", "
            << map[k].extent_max << "]) missed by query " << query.line.transpose();
      }
      offered += static_cast<long>(found.size());
      total += map.size();
    }
  }
  EXPECT_GT(hits, 1500);
  EXPECT_LT(offered, total / 5);
}

/// Exposes FastSlam2's association to compare the indexed lookup with the full scan.
class AssociationProbe : public FastSlam2 {
 public:
  using FastSlam2::associate;
  using FastSlam2::associateByScan;
  using FastSlam2::FastSlam2;
  using FastSlam2::Match;
};

TEST(FastSlam2Association, IndexedLookupEqualsFullScanOnRandomMaps) {
  FilterOptions options;
  AssociationProbe probe(options);
  Rng rng(6);
  int matched = 0, compared = 0;
  for (const Eigen::Vector2d& center : {Eigen::Vector2d(3, -2), Eigen::Vector2d(-40, 110)}) {
    const LandmarkMap map = randomMap(rng, 2500, center, 40.0);
    for (int q = 0; q < 4000; ++q) {
      const Pose2 pose(center.x() + uniform(rng, -40, 40), center.y() + uniform(rng, -40, 40),
                       uniform(rng, -M_PI, M_PI));
      Eigen::Matrix3d pose_cov = Eigen::Vector3d(0.05, 0.05, 0.01).asDiagonal();
      Observation o;
      o.type = q % 2 ? LandmarkType::kLine : LandmarkType::kPoint;
      o.noise = Eigen::Vector2d(0.01, 0.001).asDiagonal();
      if (q % 13 == 0) o.known_id = uniformInt(rng, map.size());
      // Observe a nearby landmark of the right type, slightly off, so that many match.
      const Landmark* target = nullptr;
      for (int tries = 0; tries < 50 && !target; ++tries) {
        const Landmark& lm = map[uniformInt(rng, map.size())];
        if (lm.type == o.type) target = &lm;
      }
      ASSERT_NE(target, nullptr);
      if (o.type == LandmarkType::kPoint) {
        const Pose2 seen(target->mean.x() - uniform(rng, 1, 10),
                         target->mean.y() + uniform(rng, -5, 5), pose.z());
        const Prediction p = predictPoint(
            seen, target->mean + Eigen::Vector2d(uniform(rng, -0.3, 0.3), uniform(rng, -0.3, 0.3)));
        o.z = p.z;
        const AssociationProbe::Match m = probe.associate(map, seen, pose_cov, o),
                                      s = probe.associateByScan(map, seen, pose_cov, o);
        ASSERT_EQ(m.index, s.index);
        ASSERT_EQ(m.distance2, s.distance2);
        matched += m.index >= 0 && m.distance2 < options.association.gate_chi2;
      } else {
        const double s0 = uniform(rng, target->extent_min - 1, target->extent_max);
        const Eigen::Vector2d a = pointOnLine(target->mean, s0);
        const Eigen::Vector2d b = pointOnLine(target->mean, s0 + uniform(rng, 0.5, 4.0));
        const Pose2 seen = pose;
        o.z = predictLine(seen,
                          target->mean +
                              Eigen::Vector2d(uniform(rng, -0.1, 0.1), uniform(rng, -0.03, 0.03)),
                          NAN)
                  .z;
        const Pose2 inv = inverse(seen);
        o.start = transformPoint(inv, a);
        o.end = transformPoint(inv, b);
        const AssociationProbe::Match m = probe.associate(map, seen, pose_cov, o),
                                      s = probe.associateByScan(map, seen, pose_cov, o);
        ASSERT_EQ(m.index, s.index) << "query " << q;
        ASSERT_EQ(m.distance2, s.distance2);
        matched += m.index >= 0 && m.distance2 < options.association.gate_chi2;
      }
      ++compared;
    }
  }
  EXPECT_GT(matched, compared / 4);  // not a comparison of two empty results
}

/// Walls and posts of three rooms along a corridor, 100 m from the map origin.
FeatureSet observeRooms(const Pose2& pose, Rng& rng) {
  const Eigen::Vector2d o(100.0, 60.0);
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls;
  for (int room = 0; room < 3; ++room) {
    const Eigen::Vector2d c = o + Eigen::Vector2d(8.0 * room, 0.0);
    walls.push_back({c + Eigen::Vector2d(0, 0), c + Eigen::Vector2d(7, 0)});
    walls.push_back({c + Eigen::Vector2d(7, 0), c + Eigen::Vector2d(7, 5)});
    walls.push_back({c + Eigen::Vector2d(0, 5), c + Eigen::Vector2d(7, 5)});
    walls.push_back({c + Eigen::Vector2d(2, 2), c + Eigen::Vector2d(3, 3)});  // slanted cabinet
  }
  FeatureSet set;
  const Pose2 inv = inverse(pose);
  for (const auto& [a, b] : walls) {
    const Eigen::Vector2d ra = transformPoint(inv, a), rb = transformPoint(inv, b);
    if (std::min(ra.norm(), rb.norm()) > 12.0) continue;
    const Landmark seen = lineLandmark(-1, ra, rb);
    LineFeature f;
    f.rho = seen.mean.x() + sampleGaussian(rng, 0.02);
    f.theta = seen.mean.y() + sampleGaussian(rng, 0.01);
    f.covariance = Eigen::Vector2d(0.02 * 0.02, 0.01 * 0.01).asDiagonal();
    f.start = ra;
    f.end = rb;
    set.lines.push_back(f);
  }
  for (int room = 0; room < 3; ++room) {
    const Eigen::Vector2d r = transformPoint(inv, o + Eigen::Vector2d(8.0 * room + 5.0, 1.5));
    if (r.norm() > 10.0) continue;
    PointFeature f;
    f.range = r.norm() + sampleGaussian(rng, 0.03);
    f.bearing = std::atan2(r.y(), r.x()) + sampleGaussian(rng, 0.01);
    f.covariance = Eigen::Vector2d(0.03 * 0.03, 0.01 * 0.01).asDiagonal();
    set.points.push_back(f);
  }
  return set;
}

/// A filter whose association can be checked against the full scan on its own maps.
class CheckedFastSlam2 : public FastSlam2 {
 public:
  using FastSlam2::FastSlam2;
  /// Compares associate() with associateByScan() for every particle and observation.
  int check(const FeatureSet& features, int* mismatches) const {
    int rejected = 0, compared = 0;
    for (const Observation& o : prepare(features, &rejected)) {
      for (const Particle& p : particles_) {
        const Eigen::Matrix3d cov = Eigen::Vector3d(0.02, 0.02, 0.005).asDiagonal();
        const Match a = associate(*p.map, p.pose, cov, o),
                    b = associateByScan(*p.map, p.pose, cov, o);
        *mismatches += a.index != b.index || a.distance2 != b.distance2;
        compared += b.index >= 0;
      }
    }
    return compared;
  }
};

TEST(FastSlam2Association, IndexedLookupEqualsFullScanOnTheFiltersOwnMaps) {
  FilterOptions options;
  options.particles = 20;
  options.seed = 3;
  CheckedFastSlam2 filter(options);
  Rng rng(8);
  Pose2 truth(101.0, 62.5, 0.0);
  filter.reset(truth);
  int mismatches = 0, compared = 0;
  for (int step = 0; step < 120; ++step) {
    MotionInput motion;
    motion.delta << ((step / 60) % 2 == 0 ? 0.2 : -0.2), 0.0, 0.05 * std::sin(step * 0.3);
    truth = compose(truth, motion.delta);
    motion.delta.x() *= 1.0 + sampleGaussian(rng, 0.05);
    filter.predict(motion);
    const FeatureSet features = observeRooms(truth, rng);
    compared += filter.check(features, &mismatches);
    filter.update(features);
  }
  EXPECT_EQ(mismatches, 0) << compared;
  EXPECT_GT(compared, 10000);
  EXPECT_GT(filter.landmarks().size(), 8u);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

// Landmark existence management: the counter, the field of view, the probation
// of new landmarks, copy-on-write, and a duplicate landmark removed inside the
// filter.

#include <gtest/gtest.h>

#include <cmath>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/landmark_existence.h"

namespace rbpf_slam {
namespace core {
namespace {

ExistenceOptions viewOptions() {
  ExistenceOptions o;
  o.visible_range_m = 4.0;
  o.visible_min_range_m = 0.5;
  o.visible_fov_rad = 1.0;  // +-0.5 rad
  o.max_count = 3;
  return o;
}

Landmark pointAt(double x, double y, int created, int last_seen, int existence) {
  Landmark lm;
  lm.mean << x, y;
  lm.created_step = created;
  lm.last_seen_step = last_seen;
  lm.existence = existence;
  lm.observations = 5;
  return lm;
}

TEST(LandmarkExistence, FieldOfViewHasRangeAndBearingLimits) {
  const ExistenceOptions o = viewOptions();
  const Pose2 pose(1.0, 1.0, M_PI / 2);  // facing +y
  EXPECT_TRUE(predictedVisible(o, pose, Eigen::Vector2d(1.0, 3.0)));
  EXPECT_FALSE(predictedVisible(o, pose, Eigen::Vector2d(1.0, 5.5)));  // 4.5 m: too far
  EXPECT_FALSE(predictedVisible(o, pose, Eigen::Vector2d(1.0, 1.3)));  // 0.3 m: too close
  EXPECT_FALSE(predictedVisible(o, pose, Eigen::Vector2d(3.0, 1.0)));  // bearing -pi/2
  EXPECT_TRUE(predictedVisible(o, pose, Eigen::Vector2d(1.9, 3.0)));   // bearing -0.42
  EXPECT_FALSE(predictedVisible(o, pose, Eigen::Vector2d(2.2, 3.0)));  // bearing -0.54
  ExistenceOptions off = o;
  off.visible_range_m = 0.0;
  EXPECT_FALSE(predictedVisible(off, pose, Eigen::Vector2d(1.0, 3.0)));
}

TEST(LandmarkExistence, CounterRisesWithSightingsAndFallsWithMisses) {
  const ExistenceOptions o = viewOptions();
  LandmarkMap map;
  map.add(pointAt(2.0, 0.0, 1, 10, 3));   // seen now: capped at max_count 3
  map.add(pointAt(2.0, 0.2, 1, 10, 1));   // seen now: 1 -> 2
  map.add(pointAt(3.0, 0.0, 1, 9, 2));    // in view, missed: 2 -> 1
  map.add(pointAt(2.5, 0.0, 1, 9, 1));    // in view, missed: 1 -> 0, removed
  map.add(pointAt(-2.0, 0.0, 1, 9, 1));   // behind the robot: untouched
  map.add(pointAt(2.0, 0.5, 10, 10, 1));  // created now: keeps its initial count
  std::vector<int> counters;
  const std::vector<int> remove = landmarksToRemove(o, map, Pose2::Zero(), 10, &counters);
  EXPECT_EQ(counters, (std::vector<int>{3, 2, 1, 0, 1, 1}));
  EXPECT_EQ(remove, std::vector<int>{3});
}

TEST(LandmarkExistence, ASightingCanWeighAsSeveralMisses) {
  ExistenceOptions o = viewOptions();
  o.max_count = 10;
  o.sighting_count = 3;
  LandmarkMap map;
  map.add(pointAt(2.0, 0.0, 1, 10, 1));   // seen now: 1 -> 4
  map.add(pointAt(2.0, 0.2, 1, 10, 9));   // seen now: capped at 10
  map.add(pointAt(3.0, 0.0, 1, 9, 4));    // in view, missed: still one count, 4 -> 3
  map.add(pointAt(2.0, 0.5, 10, 10, 1));  // created now: keeps its initial count
  std::vector<int> counters;
  EXPECT_TRUE(landmarksToRemove(o, map, Pose2::Zero(), 10, &counters).empty());
  EXPECT_EQ(counters, (std::vector<int>{4, 10, 3, 1}));
}

TEST(LandmarkExistence, TentativeLandmarksNeedEnoughSightings) {
  ExistenceOptions o;
  o.min_observations = 3;
  o.tentative_updates = 5;
  LandmarkMap map;
  Landmark young = pointAt(2.0, 0.0, 8, 8, 1);
  young.observations = 1;
  Landmark old_unconfirmed = pointAt(2.0, 0.0, 5, 6, 1);
  old_unconfirmed.observations = 2;
  Landmark old_confirmed = pointAt(2.0, 0.0, 1, 6, 1);
  old_confirmed.observations = 3;
  map.add(young);
  map.add(old_unconfirmed);
  map.add(old_confirmed);
  std::vector<int> counters;
  EXPECT_EQ(landmarksToRemove(o, map, Pose2::Zero(), 10, &counters), std::vector<int>{1});
}

TEST(LandmarkExistence, OfTwoCopiesTheLessObservedIsRemoved) {
  ExistenceOptions o;
  o.merge_chi2 = 9.21;
  o.merge_min_observations = 10;
  o.merge_max_distance_m = 0.5;
  const auto point = [](double x, double y, int last_seen, int observations, double sigma) {
    Landmark lm = pointAt(x, y, 1, last_seen, 1);
    lm.observations = observations;
    lm.covariance = Eigen::Matrix2d::Identity() * sigma * sigma;
    return lm;
  };
  LandmarkMap map;
  map.add(point(2.0, 0.0, 10, 150, 0.01));   // 0: seen now
  map.add(point(2.04, 0.0, 9, 170, 0.01));   // 1: its copy, d2 = 0.04^2 / 2e-4 = 8: kept (more seen)
  map.add(point(2.0, 0.17, 10, 200, 0.01));  // 2: a neighbour 0.17 m away, d2 = 144: kept
  map.add(point(5.0, 0.0, 10, 12, 0.1));     // 3: seen now, d2 = 0.05^2 / 0.02 = 0.125 ...
  map.add(point(5.05, 0.0, 9, 5, 0.1));      // 4: ... but this one is too young to merge
  map.add(point(8.0, 0.0, 9, 50, 0.01));     // 5: a copy of 6, but neither was seen now
  map.add(point(8.02, 0.0, 9, 40, 0.01));    // 6
  std::vector<int> counters;
  EXPECT_EQ(landmarksToRemove(o, map, Pose2::Zero(), 10, &counters), std::vector<int>{0});
  // Off (merge_chi2 0), or a tighter gate than the copy's d2: nothing is merged.
  ExistenceOptions off = o;
  off.merge_chi2 = 0.0;
  EXPECT_TRUE(landmarksToRemove(off, map, Pose2::Zero(), 10, &counters).empty());
  off = o;
  off.merge_chi2 = 7.0;
  EXPECT_TRUE(landmarksToRemove(off, map, Pose2::Zero(), 10, &counters).empty());
  off = o;
  off.merge_max_distance_m = 0.03;
  EXPECT_TRUE(landmarksToRemove(off, map, Pose2::Zero(), 10, &counters).empty());
  // Landmarks with a known identity are distinct, however close.
  LandmarkMap identified = map;
  Landmark first = identified[0];
  first.identified = true;
  identified.set(0, first);
  EXPECT_TRUE(landmarksToRemove(o, identified, Pose2::Zero(), 10, &counters).empty());
  // The seen landmark wins against a less observed copy (which goes), and keeps the larger
  // existence counter; on equal sightings the older one wins.
  LandmarkMap pair;
  pair.add(point(2.0, 0.0, 10, 150, 0.01));  // seen now, counter 1 -> 2
  Landmark copy = point(2.04, 0.0, 9, 120, 0.01);
  copy.existence = 5;
  pair.add(copy);
  EXPECT_EQ(landmarksToRemove(o, pair, Pose2(0.0, 0.0, M_PI), 10, &counters),
            std::vector<int>{1});
  EXPECT_EQ(counters[0], 5);
  copy.observations = 150;
  copy.created_step = 0;  // older than the seen one (created at 1)
  pair.set(1, copy);
  EXPECT_EQ(landmarksToRemove(o, pair, Pose2(0.0, 0.0, M_PI), 10, &counters),
            std::vector<int>{0});
  // A chain A-B-C (A-C beyond the gate): B wins against A, and is not removed in the same
  // update for losing against C.
  LandmarkMap chain;
  chain.add(point(2.0, 0.0, 10, 20, 0.01));    // A, seen
  chain.add(point(2.04, 0.0, 9, 30, 0.01));    // B
  chain.add(point(2.08, 0.0, 10, 40, 0.01));   // C, seen (A-C: d2 = 32)
  EXPECT_EQ(landmarksToRemove(o, chain, Pose2(0.0, 0.0, M_PI), 10, &counters),
            std::vector<int>{0});
  // A copy removed by negative evidence in this update (in view, missed, counter 1 -> 0) wins
  // nothing: the seen landmark stays, although less observed.
  LandmarkMap missed;
  missed.add(point(2.0, 0.0, 10, 15, 0.01));   // seen
  missed.add(point(2.04, 0.0, 9, 150, 0.01));  // in view, not seen, counter 1
  ExistenceOptions view = o;
  view.visible_range_m = 4.0;
  view.visible_fov_rad = 1.0;
  EXPECT_EQ(landmarksToRemove(view, missed, Pose2::Zero(), 10, &counters), std::vector<int>{1});
  // Merging alone switches existence management on.
  EXPECT_TRUE(existenceEnabled(o));
  o.merge_chi2 = -1.0;
  EXPECT_THROW(validate(o), std::invalid_argument);
}

TEST(LandmarkExistence, SharedMapIsCopiedOnlyWhenSomethingChanges) {
  const ExistenceOptions o = viewOptions();
  auto map = std::make_shared<LandmarkMap>();
  map->add(pointAt(-2.0, 0.0, 1, 1, 1));  // out of view
  std::shared_ptr<LandmarkMap> other = map;
  EXPECT_EQ(manageExistence(o, &map, Pose2::Zero(), 2), 0);
  EXPECT_EQ(map.get(), other.get());  // nothing changed: still shared
  EXPECT_EQ(manageExistence(o, &map, Pose2(0, 0, M_PI), 3),
            1);  // now in view and missed
  EXPECT_NE(map.get(), other.get());
  EXPECT_EQ(map->size(), 0);
  EXPECT_EQ(other->size(), 1);  // the other particle's map is untouched
}

TEST(LandmarkExistence, FilterDropsALandmarkThatIsNeverSeenAgain) {
  FilterOptions options;
  options.particles = 10;
  options.use_lines = false;
  options.existence = viewOptions();
  FastSlam2 filter(options);
  FeatureSet first;
  PointFeature real, ghost;
  real.range = 2.0;
  real.bearing = 0.0;
  real.covariance << 0.01, 0, 0, 0.001;
  ghost = real;
  ghost.range = 3.0;
  ghost.bearing = 0.3;
  first.points = {real, ghost};
  filter.update(first);
  EXPECT_EQ(filter.landmarks().size(), 2u);
  FeatureSet later;
  later.points = {real};
  for (int i = 0; i < 2; ++i) {
    filter.predict(MotionInput());
    filter.update(later);
  }
  ASSERT_EQ(filter.landmarks().size(), 1u);
  EXPECT_NEAR(filter.landmarks()[0].mean.x(), 2.0, 0.1);
  // Without existence management both stay.
  options.existence = ExistenceOptions();
  FastSlam2 plain(options);
  plain.update(first);
  for (int i = 0; i < 2; ++i) {
    plain.predict(MotionInput());
    plain.update(later);
  }
  EXPECT_EQ(plain.landmarks().size(), 2u);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

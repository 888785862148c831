// Google Benchmark: FastSlam2::update against the number of particles (map of 100 point
// landmarks) and against the number of landmarks in the map (100 particles, up to 50,000),
// with the same ten range-bearing observations every step; resampleLowVariance against the
// particle count; and one consensus choice of an ensemble of eight (ensemble.rank_by:
// consensus: every pair of members' paths aligned) against the paths' length, whole or cut to
// ensemble.consensus_max_poses. Not a pass/fail test: ./scripts/bench.sh runs it and writes
// docs/benchmarks.md.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "bench_support.h"
#include "rbpf_slam/core/alignment.h"
#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/resampling.h"
#include "rbpf_slam/core/random.h"

namespace {

namespace core = rbpf_slam::core;

constexpr int kObservedLandmarks = 10;  // features per update
constexpr double kGridSpacingM = 2.0;   // landmarks far apart compared with their noise

/// Options shared by the map builder and the benchmarked filters: tight noise, so that the
/// grid landmarks stay distinct even 100 m away.
core::FilterOptions benchOptions(int particles) {
  return rbpf_slam::bench::pointLandmarkOptions(particles, 1e-4, 1e-5);
}

using BenchFastSlam2 = rbpf_slam::bench::PrebuiltMapFastSlam2;

/// Grid positions around the origin, nearest first.
std::vector<Eigen::Vector2d> gridPositions(int count) {
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count))));
  std::vector<Eigen::Vector2d> positions =
      rbpf_slam::bench::landmarkGrid(side * side, kGridSpacingM);
  std::sort(positions.begin(), positions.end(),
            [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.norm() < b.norm(); });
  positions.resize(count);
  return positions;
}

core::PointFeature observe(const Eigen::Vector2d& p, double range_error, double bearing_error) {
  core::PointFeature f;
  f.range = p.norm() + range_error;
  f.bearing = std::atan2(p.y(), p.x()) + bearing_error;
  return f;
}

/// A map of `count` distinct point landmarks on the grid, each with the covariance its first
/// exact observation from the origin gives (what the filter itself would create).
std::shared_ptr<core::LandmarkMap> buildMap(int count) {
  const core::FilterOptions options = benchOptions(1);
  const Eigen::Matrix2d noise = Eigen::Vector2d(std::pow(options.measurement.sigma_range_m, 2),
                                                std::pow(options.measurement.sigma_bearing_rad, 2))
                                    .asDiagonal();
  auto map = std::make_shared<core::LandmarkMap>();
  const std::vector<Eigen::Vector2d> positions = gridPositions(count);
  for (size_t i = 0; i < positions.size(); ++i) {
    const core::PointFeature f = observe(positions[i], 0.0, 0.0);
    core::Landmark lm;
    lm.id = static_cast<int>(i);
    Eigen::Matrix2d g;
    lm.mean =
        core::pointFromObservation(core::Pose2::Zero(), Eigen::Vector2d(f.range, f.bearing), &g);
    lm.covariance = g * noise * g.transpose();
    map->add(lm);
  }
  return map;
}

/// The nearest kObservedLandmarks landmarks, observed with small fixed errors.
core::FeatureSet observedFeatures() {
  core::FeatureSet features;
  const std::vector<Eigen::Vector2d> positions = gridPositions(kObservedLandmarks);
  for (size_t i = 0; i < positions.size(); ++i) {
    const double sign = i % 2 == 0 ? 1.0 : -1.0;
    features.points.push_back(observe(positions[i], 0.01 * sign, -0.001 * sign));
  }
  return features;
}

/// Times update() of a filter with `particles` particles over a prebuilt map of `landmarks`.
void runUpdates(benchmark::State& state, int particles, int landmarks) {
  BenchFastSlam2 filter(benchOptions(particles));
  const std::shared_ptr<core::LandmarkMap> map = buildMap(landmarks);
  if (map->size() != landmarks) {
    state.SkipWithError("map building merged landmarks");
    return;
  }
  filter.shareMap(map);
  const core::FeatureSet features = observedFeatures();
  long associated = 0, created = 0, resampled = 0;
  for (auto _ : state) {
    const core::UpdateStats stats = filter.update(features);
    associated += stats.associated;
    created += stats.new_landmarks;
    resampled += stats.resampled ? 1 : 0;
  }
  const double iterations = static_cast<double>(state.iterations());
  state.counters["particles"] = particles;
  state.counters["landmarks"] = map->size();
  state.counters["assoc/update"] = associated / iterations;
  state.counters["new/update"] = created / iterations;
  state.counters["resample_rate"] = resampled / iterations;
  state.counters["updates/s"] = benchmark::Counter(iterations, benchmark::Counter::kIsRate);
}

void BM_FastSlam2UpdateVsParticles(benchmark::State& state) {
  runUpdates(state, static_cast<int>(state.range(0)), 100);
}
BENCHMARK(BM_FastSlam2UpdateVsParticles)
    ->Arg(10)
    ->Arg(30)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond);

void BM_FastSlam2UpdateVsLandmarks(benchmark::State& state) {
  runUpdates(state, 100, static_cast<int>(state.range(0)));
}
BENCHMARK(BM_FastSlam2UpdateVsLandmarks)
    ->Arg(10)
    ->Arg(100)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond);

void BM_ResampleLowVariance(benchmark::State& state) {
  const int count = static_cast<int>(state.range(0));
  core::Rng rng(3);
  std::vector<double> log_weights(count);
  for (double& w : log_weights) w = core::sampleGaussian(rng, 3.0);
  std::vector<double> weights;
  core::normalizeLogWeights(log_weights, &weights);
  for (auto _ : state) {
    std::vector<int> indices = core::resampleLowVariance(weights, count, rng);
    benchmark::DoNotOptimize(indices.data());
  }
  state.counters["particles"] = count;
  state.counters["particles/s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * count, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ResampleLowVariance)
    ->Arg(10)
    ->Arg(100)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(100000)
    ->Unit(benchmark::kMicrosecond);

/// One consensus choice among eight members whose paths hold range(0) poses (a random walk
/// each), every path first cut to range(1) evenly spaced poses (0: compared whole), as
/// EnsembleFilter does every consensus_period updates. Not timed: EnsembleFilter's walk and
/// copy of each member's whole best path (a linked list) before the cut.
void BM_ConsensusChoice(benchmark::State& state) {
  const size_t poses = static_cast<size_t>(state.range(0));
  const size_t max_poses = state.range(1) > 0 ? static_cast<size_t>(state.range(1)) : poses;
  core::Rng rng(5);
  std::vector<std::vector<core::Pose2>> paths(8);
  for (auto& path : paths) {
    core::Pose2 pose = core::Pose2::Zero();
    for (size_t i = 0; i < poses; ++i) {
      pose = core::compose(pose, core::Pose2(0.1, 0.0, core::sampleGaussian(rng, 0.1)));
      path.push_back(pose);
    }
  }
  size_t compared = 0;
  for (auto _ : state) {
    std::vector<std::vector<core::Pose2>> cut;
    for (const auto& path : paths) cut.push_back(core::evenlySpacedPoses(path, max_poses));
    compared = cut[0].size();
    std::vector<double> d = core::medianDistancesToOthers(cut);
    benchmark::DoNotOptimize(d.data());
  }
  state.counters["poses"] = static_cast<double>(poses);
  state.counters["compared"] = static_cast<double>(compared);
}
BENCHMARK(BM_ConsensusChoice)
    ->Args({1000, 0})
    ->Args({4000, 0})
    ->Args({16000, 0})
    ->Args({64000, 0})
    ->Args({64000, 4000})
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();

// Google Benchmark: memory of FastSLAM 2.0 maps shared between particles. A filter with 100
// particles over a map of 50,000 point landmarks drives across the map for 500 updates,
// observing the ten nearest landmarks each time (so every particle rewrites a different part
// of its map, and resampling shares and drops the rewritten parts); reports the resident set
// before and after, its peak, and the time per update. Its own binary, so that the peak
// resident set is this case's alone. Not a pass/fail test: ./scripts/bench.sh runs it.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bench_support.h"
#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/measurement_models.h"

namespace {

namespace core = rbpf_slam::core;

constexpr double kGridSpacingM = 2.0;
constexpr int kObserved = 10;
constexpr int kUpdates = 500;

using rbpf_slam::bench::residentMb;

void BM_MapMemory(benchmark::State& state) {
  const int landmarks = static_cast<int>(state.range(0));
  const int particles = static_cast<int>(state.range(1));
  for (auto _ : state) {
    state.PauseTiming();
    const double rss_start = residentMb("VmRSS");
    const std::vector<Eigen::Vector2d> positions =
        rbpf_slam::bench::landmarkGrid(landmarks, kGridSpacingM);
    auto map = std::make_shared<core::LandmarkMap>();
    for (size_t i = 0; i < positions.size(); ++i) {
      core::Landmark lm;
      lm.id = static_cast<int>(i);
      lm.mean = positions[i];
      lm.covariance = Eigen::Vector2d(1e-3, 1e-3).asDiagonal();
      map->add(lm);
    }
    rbpf_slam::bench::PrebuiltMapFastSlam2 filter(
        rbpf_slam::bench::pointLandmarkOptions(particles, 1e-3, 1e-4));
    filter.shareMap(map);
    map.reset();
    const double rss_map = residentMb("VmRSS");
    // Drive along x through the middle of the map, one grid spacing per update.
    const double x0 = positions.front().x();
    core::Pose2 truth(x0, 0.0, 0.0);
    std::vector<int> order(positions.size());
    double update_s = 0.0;
    state.ResumeTiming();
    for (int step = 0; step < kUpdates; ++step) {
      state.PauseTiming();
      core::MotionInput motion;
      motion.delta << kGridSpacingM * 0.5, 0.0, 0.0;
      truth = core::compose(truth, motion.delta);
      for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
      std::partial_sort(order.begin(), order.begin() + kObserved, order.end(), [&](int a, int b) {
        return (positions[a] - truth.head<2>()).squaredNorm() <
               (positions[b] - truth.head<2>()).squaredNorm();
      });
      core::FeatureSet features;
      for (int k = 0; k < kObserved; ++k) {
        const core::Prediction p = core::predictPoint(truth, positions[order[k]]);
        core::PointFeature f;
        f.range = p.z.x();
        f.bearing = p.z.y();
        features.points.push_back(f);
      }
      state.ResumeTiming();
      const auto t0 = std::chrono::steady_clock::now();
      filter.predict(motion);
      filter.update(features);
      update_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    state.PauseTiming();
    state.counters["landmarks"] = landmarks;
    state.counters["particles"] = particles;
    state.counters["updates"] = kUpdates;
    state.counters["map_MB"] = rss_map - rss_start;
    state.counters["after_updates_MB"] = residentMb("VmRSS") - rss_start;
    state.counters["peak_rss_MB"] = residentMb("VmHWM");
    state.counters["update_ms"] = 1e3 * update_s / kUpdates;  // mean, wall clock
    state.counters["resamples"] = static_cast<double>(filter.stats().resamples);
    state.ResumeTiming();
  }
}
// One run only: a repetition in the same process would reuse the memory the first one freed.
BENCHMARK(BM_MapMemory)
    ->Args({50000, 100})
    ->Iterations(1)
    ->Repetitions(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();

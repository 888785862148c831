// Google Benchmark: memory of grid_pf's copy-on-write tiled grids. 500 particles map a
// 20 m x 20 m room (posts inside) at 5 cm with a 180-beam, 10 m laser while driving a circle of
// 4 m radius, 100 updates; reports the peak resident set of the process, the distinct tiles
// all particles hold (shared ones once) against particles x tiles of one map, and the time per
// update. Its own binary, so that the peak resident set is this case's alone. Not a pass/fail
// test: ./scripts/bench.sh runs it (the requirement is a peak under 1.5 GB).

#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bench_support.h"
#include "rbpf_slam/core/grid/grid_pf.h"

namespace {

namespace core = rbpf_slam::core;

constexpr int kUpdates = 100;
constexpr double kHalfSideM = 9.9;   // walls at +-9.9 m: inside the 20 m grid centred on the start
constexpr double kPostRadiusM = 0.3;
constexpr double kMaxRangeM = 10.0;

using rbpf_slam::bench::residentMb;

/// Distance along a ray from p at angle a to the room's walls or a post (inf past max range).
double castRay(const Eigen::Vector2d& p, double a) {
  const Eigen::Vector2d d(std::cos(a), std::sin(a));
  double best = kMaxRangeM + 1.0;
  for (int axis = 0; axis < 2; ++axis) {
    if (std::fabs(d[axis]) < 1e-12) continue;
    for (double wall : {-kHalfSideM, kHalfSideM}) {
      const double t = (wall - p[axis]) / d[axis];
      if (t > 0.0) best = std::min(best, t);
    }
  }
  for (double x = -6.0; x <= 6.0; x += 4.0) {
    for (double y = -6.0; y <= 6.0; y += 4.0) {
      const Eigen::Vector2d oc = p - Eigen::Vector2d(x, y);
      const double b = oc.dot(d), c = oc.squaredNorm() - kPostRadiusM * kPostRadiusM;
      const double disc = b * b - c;
      if (disc >= 0.0) {
        const double t = -b - std::sqrt(disc);
        if (t > 0.0) best = std::min(best, t);
      }
    }
  }
  return best;
}

core::FeatureSet scanAt(const core::Pose2& pose) {
  auto scan = std::make_shared<core::RangeScan>();
  scan->angle_min = -M_PI / 2;
  scan->angle_increment = M_PI / 179;
  scan->range_min = 0.05;
  scan->range_max = kMaxRangeM;
  for (int i = 0; i < 180; ++i) {
    const double angle = pose.z() + scan->angle_min + i * scan->angle_increment;
    const double r = castRay(pose.head<2>(), angle);
    scan->ranges.push_back(r > kMaxRangeM ? INFINITY : static_cast<float>(r));
  }
  core::FeatureSet f;
  f.scan = scan;
  return f;
}

void BM_GridMemory(benchmark::State& state) {
  const int particles = static_cast<int>(state.range(0));
  for (auto _ : state) {
    state.PauseTiming();
    const double rss_start = residentMb("VmRSS");
    core::FilterOptions o;
    o.variant = "grid_pf";
    o.particles = particles;
    o.seed = 1;
    o.motion.model = "diff_drive";
    o.motion.wheel_base_m = 0.4;
    o.motion.wheel_alpha1 = 0.02;
    o.motion.wheel_alpha2 = 0.05;
    o.motion.min_sigma_xy_m = 0.01;
    o.motion.min_sigma_theta_rad = 0.005;
    o.grid.resolution_m = 0.05;
    o.grid.size_x_m = 20.0;
    o.grid.size_y_m = 20.0;
    o.grid.tile_cells = 64;
    o.grid.laser_max_range_m = kMaxRangeM;
    core::GridParticleFilter filter(o);
    filter.reset(core::Pose2::Zero());
    // A circle of radius 4 m around (0, 4), inside the walls: 0.3 m per update.
    const double radius = 4.0, step = 0.3;
    core::Pose2 truth(0.0, 0.0, 0.0);
    core::MotionInput motion;
    motion.delta = core::Pose2(radius * std::sin(step / radius),
                               radius * (1.0 - std::cos(step / radius)), step / radius);
    double update_s = 0.0;
    long peak_tiles = 0;
    state.ResumeTiming();
    for (int k = 0; k < kUpdates; ++k) {
      state.PauseTiming();
      if (k > 0) truth = core::compose(truth, motion.delta);
      const core::FeatureSet features = scanAt(truth);
      state.ResumeTiming();
      const auto t0 = std::chrono::steady_clock::now();
      if (k > 0) filter.predict(motion);
      filter.update(features);
      update_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      state.PauseTiming();
      peak_tiles = std::max(peak_tiles, filter.distinctTiles());
      state.ResumeTiming();
    }
    state.PauseTiming();
    const double tile_mb = filter.bestGrid().tileBytes() / 1048576.0;
    state.counters["particles"] = particles;
    state.counters["updates"] = kUpdates;
    state.counters["tiles_one_map"] = filter.bestGrid().allocatedTiles();
    state.counters["tiles_all_particles"] = static_cast<double>(filter.distinctTiles());
    state.counters["tiles_all_peak"] = static_cast<double>(peak_tiles);
    state.counters["grid_MB_peak"] = peak_tiles * tile_mb;
    state.counters["unshared_MB"] = particles * filter.bestGrid().allocatedTiles() * tile_mb;
    state.counters["after_updates_MB"] = residentMb("VmRSS") - rss_start;
    state.counters["peak_rss_MB"] = residentMb("VmHWM");
    state.counters["update_ms"] = 1e3 * update_s / kUpdates;  // mean, wall clock
    state.counters["resamples"] = static_cast<double>(filter.stats().resamples);
    const core::Pose2 error = filter.estimate().mean - truth;
    state.counters["final_error_m"] = error.head<2>().norm();
    state.ResumeTiming();
  }
}
// One run only: a repetition in the same process would reuse the memory the first one freed.
BENCHMARK(BM_GridMemory)->Arg(500)->Iterations(1)->Repetitions(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();

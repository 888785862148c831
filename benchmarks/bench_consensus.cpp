// Google Benchmark: the cost of one consensus choice's input (ensemble.rank_by consensus) on
// long runs. Eight FastSLAM 2.0 members (5 particles, no features) driven T updates, then the
// best paths' consensus_max_poses (4000) evenly spaced poses are taken from every member:
// through the paths' jump pointers (SlamFilter::bestPathSample, what the ensemble does), and
// by walking each whole path (bestPath, then evenlySpacedPoses; what it did before session 39).
// Not a pass/fail test.

#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <vector>

#include "rbpf_slam/core/alignment.h"
#include "rbpf_slam/core/filters/slam_filter.h"

namespace {

namespace core = rbpf_slam::core;

constexpr std::size_t kMaxPoses = 4000;

/// An ensemble of eight driven `updates` updates along a slow curve (built once per length).
const core::SlamFilter& drivenEnsemble(int updates) {
  static std::map<int, std::unique_ptr<core::SlamFilter>> built;
  auto& filter = built[updates];
  if (filter) return *filter;
  core::FilterOptions o;
  o.particles = 5;
  o.use_lines = false;
  o.ensemble.members = 8;
  o.ensemble.rank_by = "evidence";  // the choice itself is what is timed here
  filter = core::createFilter(o);
  filter->reset(core::Pose2::Zero());
  for (int i = 1; i <= updates; ++i) {
    core::MotionInput m;
    m.stamp = i;
    m.dt = 0.5;
    m.delta = core::Pose2(0.1, 0.0, 0.01);
    filter->predict(m);
    core::FeatureSet none;
    none.stamp = i;
    filter->update(none);
  }
  return *filter;
}

void BM_ConsensusInputJumpPointers(benchmark::State& state) {
  const core::SlamFilter& ensemble = drivenEnsemble(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    std::size_t poses = 0;
    for (int k = 0; k < ensemble.members(); ++k) {
      std::size_t length = 0;
      poses += ensemble.member(k).bestPathSample(kMaxPoses, &length).size();
    }
    benchmark::DoNotOptimize(poses);
  }
}

void BM_ConsensusInputWholePaths(benchmark::State& state) {
  const core::SlamFilter& ensemble = drivenEnsemble(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    std::size_t poses = 0;
    for (int k = 0; k < ensemble.members(); ++k) {
      poses += core::evenlySpacedPoses(ensemble.member(k).bestPath(), kMaxPoses).size();
    }
    benchmark::DoNotOptimize(poses);
  }
}

BENCHMARK(BM_ConsensusInputJumpPointers)
    ->Arg(2000)->Arg(20000)->Arg(120000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ConsensusInputWholePaths)
    ->Arg(2000)->Arg(20000)->Arg(120000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();

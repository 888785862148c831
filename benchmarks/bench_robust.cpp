// Google Benchmark: update time of the robust RBPF-SLAM (M particles x K ancestor sets)
// against FastSLAM 2.0, on the landmark stream of a simulated world (worlds/lee_sim_b.yaml,
// seed 1: three laps, landmarks displaced after the first), with the shipped configs
// config/landmarks_robust.yaml and config/landmarks_fastslam2.yaml. One iteration runs the
// whole stream; the reported time per update is the mean over all steps, robust steps
// (M x K candidates, intermediate paths) included. Not a pass/fail test.

#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/robust_fastslam2.h"
#include "rbpf_slam/core/sim/simulator.h"
#include "rbpf_slam/io/slam_config.h"
#include "rbpf_slam/io/world_yaml.h"

namespace {

namespace core = rbpf_slam::core;
namespace io = rbpf_slam::io;

struct Step {
  core::MotionInput motion;
  core::FeatureSet features;
};

/// The range-bearing frames of a simulated world, each with the odometry increment since the
/// previous frame.
const std::vector<Step>& stream(const std::string& world_name) {
  static std::vector<Step> steps;
  static std::string loaded;
  if (loaded == world_name) return steps;
  steps.clear();
  core::sim::SimulatorOptions options;
  options.seed = 1;
  core::sim::Simulator simulator(
      io::loadWorld(std::string(RBPF_SOURCE_DIR) + "/worlds/" + world_name + ".yaml"), options);
  core::sim::SimEvent event;
  core::Pose2 last_odom = core::Pose2::Zero();
  double last_stamp = 0.0;
  while (simulator.next(&event)) {
    if (event.type != core::sim::SimEventType::kRangeBearing) continue;
    Step step;
    step.motion.delta = core::between(last_odom, event.odom_pose);
    step.motion.dt = event.stamp - last_stamp;
    step.motion.stamp = event.stamp;
    step.features = event.features;
    steps.push_back(step);
    last_odom = event.odom_pose;
    last_stamp = event.stamp;
  }
  loaded = world_name;
  return steps;
}

core::FilterOptions configOptions(const std::string& config, int particles) {
  core::FilterOptions options =
      io::loadSlamConfig(std::string(RBPF_SOURCE_DIR) + "/config/" + config + ".yaml").filter;
  options.particles = particles;
  options.seed = 3;
  options.ensemble.members = 1;  // one filter against one (landmarks_fastslam2.yaml runs eight)
  return options;
}

void runStream(benchmark::State& state, const core::FilterOptions& options) {
  const std::vector<Step>& steps = stream("lee_sim_b");
  long updates = 0, robust_steps = 0;
  for (auto _ : state) {
    std::unique_ptr<core::SlamFilter> filter = core::createFilter(options);
    for (const Step& step : steps) {
      filter->predict(step.motion);
      benchmark::DoNotOptimize(filter->update(step.features));
    }
    updates += static_cast<long>(steps.size());
    if (auto* robust = dynamic_cast<core::RobustFastSlam2*>(filter.get())) {
      robust_steps += robust->stats().robust_steps;
    }
  }
  const double iterations = static_cast<double>(state.iterations());
  state.counters["particles"] = options.particles;
  state.counters["sets"] = options.variant == "robust_fastslam2" ? options.robust.ancestor_sets : 1;
  state.counters["updates"] = updates / iterations;
  state.counters["robust_steps"] = robust_steps / iterations;
  // CPU seconds per update (printed with an SI prefix: 1.2m = 1.2 ms).
  state.counters["s/update"] = benchmark::Counter(
      static_cast<double>(updates), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

/// FastSLAM 2.0 with N particles (range(0)).
void BM_FastSlam2Stream(benchmark::State& state) {
  core::FilterOptions options =
      configOptions("landmarks_fastslam2", static_cast<int>(state.range(0)));
  // The robust config's motion noise, landmark existence and association (landmarks_fastslam2
  // .yaml's were set for MRCLAM in sessions 15, 17 and 19), so that both filters do the same
  // work per particle.
  const core::FilterOptions robust = configOptions("landmarks_robust", 1);
  options.motion = robust.motion;
  options.existence = robust.existence;
  options.association = robust.association;
  runStream(state, options);
}
BENCHMARK(BM_FastSlam2Stream)
    ->Arg(100)
    ->Arg(200)
    ->Arg(500)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

/// Robust with M = range(0) particles per set and K = range(1) sets.
void BM_RobustStream(benchmark::State& state) {
  core::FilterOptions options = configOptions("landmarks_robust", static_cast<int>(state.range(0)));
  options.robust.ancestor_sets = static_cast<int>(state.range(1));
  runStream(state, options);
}
BENCHMARK(BM_RobustStream)
    ->Args({100, 5})
    ->Args({40, 5})
    ->Args({100, 2})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();

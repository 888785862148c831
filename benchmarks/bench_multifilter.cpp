// Google Benchmark: one update of the multi-filter SMC (Yuen and MacDonald; 2000 robot
// particles, 200 per line) and of EKF-SLAM against the number of line landmarks in the map
// (10 to 500), with the same ten observed lines every step. The paper's claim: SMC linear in
// the lines, EKF super-linear (here O(n^2) per matched feature). Not a pass/fail test.

#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace {

namespace core = rbpf_slam::core;

constexpr int kObservedLines = 10;
constexpr int kNormalDirections = 8;  // 45 deg apart: WAD > 1 between directions

/// Line k of a map where every two lines differ by more than h_similar_feature in WAD.
Eigen::Vector2d mapLine(int k) {
  return Eigen::Vector2d(2.0 + 1.2 * (k / kNormalDirections),
                         core::wrapAngle((k % kNormalDirections) * 2.0 * M_PI / kNormalDirections));
}

std::vector<core::LandmarkEstimate> lineMap(int count) {
  std::vector<core::LandmarkEstimate> map;
  for (int k = 0; k < count; ++k) {
    core::LandmarkEstimate l;
    l.id = k;
    l.type = core::LandmarkType::kLine;
    l.mean = mapLine(k);
    l.covariance = Eigen::Vector2d(1e-4, 1e-5).asDiagonal();
    const Eigen::Vector2d n(std::cos(l.mean.y()), std::sin(l.mean.y())), d(-n.y(), n.x());
    l.start = l.mean.x() * n - d;
    l.end = l.mean.x() * n + d;
    map.push_back(l);
  }
  return map;
}

/// The first kObservedLines map lines seen from the origin (robot frame = map frame).
core::FeatureSet observation() {
  core::FeatureSet set;
  for (const auto& l : lineMap(kObservedLines)) {
    core::LineFeature f;
    f.rho = l.mean.x();
    f.theta = l.mean.y();
    f.covariance = l.covariance;
    f.start = l.start;
    f.end = l.end;
    set.lines.push_back(f);
  }
  return set;
}

void updateWithLines(benchmark::State& state, const std::string& variant) {
  core::FilterOptions options;
  options.variant = variant;
  options.particles = variant == "multifilter_smc" ? 2000 : 1;
  options.seed = 1;
  options.use_points = false;
  options.motion.min_sigma_xy_m = 1e-3;
  options.motion.min_sigma_theta_rad = 1e-4;
  std::unique_ptr<core::SlamFilter> filter = core::createFilter(options);
  filter->reset(core::Pose2::Zero());
  filter->loadMap(lineMap(state.range(0)));
  const core::FeatureSet features = observation();
  core::MotionInput motion;
  motion.dt = 0.2;
  int associated = 0;
  for (auto _ : state) {
    filter->predict(motion);
    associated = filter->update(features).associated;
    benchmark::DoNotOptimize(associated);
  }
  state.counters["lines"] = state.range(0);
  state.counters["associated"] = associated;
  state.counters["landmarks"] = filter->stats().landmarks;
}

void BM_MultiFilterSmcUpdateVsLines(benchmark::State& state) {
  updateWithLines(state, "multifilter_smc");
}
void BM_EkfSlamUpdateVsLines(benchmark::State& state) { updateWithLines(state, "ekf_slam"); }

void lineCounts(benchmark::internal::Benchmark* b) {
  for (int lines : {10, 20, 50, 100, 200, 300, 500}) b->Arg(lines);
  b->Unit(benchmark::kMillisecond);
}
BENCHMARK(BM_MultiFilterSmcUpdateVsLines)->Apply(lineCounts);
BENCHMARK(BM_EkfSlamUpdateVsLines)->Apply(lineCounts);

}  // namespace

BENCHMARK_MAIN();

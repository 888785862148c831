// Google Benchmark: LaserLineExtractor::extract on simulated scans of a furnished room with
// 181, 361 and 721 beams (180 deg field of view), for both extraction methods. Reports the
// time per scan and the features extracted per second. Not a pass/fail test:
// ./scripts/bench.sh runs it and writes docs/benchmarks.md.

#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "rbpf_slam/core/features/laser_line_extractor.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/sim/ray_caster.h"
#include "rbpf_slam/core/sim/sensor_models.h"
#include "rbpf_slam/core/sim/world.h"

namespace {

namespace core = rbpf_slam::core;
namespace sim = rbpf_slam::core::sim;

constexpr int kScanCount = 16;  // distinct scans cycled through, so no single layout dominates

/// A 12 m x 9 m room with an inner wall stub, two tables, a cabinet and four posts.
sim::RayCaster roomCaster() {
  std::vector<sim::WorldObject> objects = {
      {"walls", sim::ShapeType::kPolyline, {{0, 0}, {12, 0}, {12, 9}, {0, 9}, {0, 0}}, false},
      {"stub", sim::ShapeType::kPolyline, {{6, 9}, {6, 6}}, false},
      {"table_a", sim::ShapeType::kPolygon, {{2, 2}, {3.5, 2}, {3.5, 3}, {2, 3}}, true},
      {"table_b", sim::ShapeType::kPolygon, {{8, 5}, {9.2, 5}, {9.2, 6.4}, {8, 6.4}}, true},
      {"cabinet",
       sim::ShapeType::kPolygon,
       {{11.3, 0.3}, {11.8, 0.3}, {11.8, 1.8}, {11.3, 1.8}},
       true},
  };
  std::vector<sim::Segment> segments;
  for (size_t i = 0; i < objects.size(); ++i) {
    const std::vector<sim::Segment> s = sim::objectSegments(objects[i], static_cast<int>(i));
    segments.insert(segments.end(), s.begin(), s.end());
  }
  std::vector<sim::Circle> posts;
  for (const Eigen::Vector2d& c : {Eigen::Vector2d(4.5, 6.5), Eigen::Vector2d(9.5, 2.5),
                                   Eigen::Vector2d(2.0, 7.5), Eigen::Vector2d(7.0, 1.5)}) {
    posts.push_back({c, 0.1});
  }
  return sim::RayCaster(segments, posts);
}

/// kScanCount noisy scans with `beams` beams over 180 deg, taken along a loop in the room.
std::vector<core::RangeScan> roomScans(int beams) {
  sim::LaserConfig laser;
  laser.enabled = true;
  laser.fov_deg = 180.0;
  laser.resolution_deg = 180.0 / (beams - 1);
  laser.max_range_m = 8.2;
  laser.range_noise_m = 0.01;
  const sim::RayCaster caster = roomCaster();
  core::Rng rng(7);
  std::vector<core::RangeScan> scans;
  for (int i = 0; i < kScanCount; ++i) {
    const double t = 2.0 * M_PI * i / kScanCount;
    const core::Pose2 pose(6.0 + 4.0 * std::cos(t), 4.0 + 2.8 * std::sin(t), t + 0.5 * M_PI);
    scans.push_back(sim::simulateLaserScan(laser, caster, pose, &rng));
  }
  return scans;
}

void BM_LaserExtraction(benchmark::State& state, const std::string& method) {
  const int beams = static_cast<int>(state.range(0));
  const std::vector<core::RangeScan> scans = roomScans(beams);
  core::LaserExtractorOptions options;
  options.method = method;
  const core::LaserLineExtractor extractor(options);
  size_t next = 0;
  double features = 0.0, lines = 0.0;
  for (auto _ : state) {
    const core::FeatureSet set = extractor.extract(scans[next]);
    benchmark::DoNotOptimize(set);
    features += static_cast<double>(set.lines.size() + set.points.size());
    lines += static_cast<double>(set.lines.size());
    next = (next + 1) % scans.size();
  }
  const double iterations = static_cast<double>(state.iterations());
  state.counters["features/s"] = benchmark::Counter(features, benchmark::Counter::kIsRate);
  state.counters["features/scan"] = features / iterations;
  state.counters["lines/scan"] = lines / iterations;
  state.counters["beams"] = beams;
}

BENCHMARK_CAPTURE(BM_LaserExtraction, incremental, std::string("incremental"))
    ->Arg(181)
    ->Arg(361)
    ->Arg(721)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_LaserExtraction, split_and_merge, std::string("split_and_merge"))
    ->Arg(181)
    ->Arg(361)
    ->Arg(721)
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();

// libFuzzer target: arbitrary LaserScan headers and ranges through both line extractors and
// the scan matcher. Findings: crashes, sanitizer reports, non-finite features or matches.

#include <cmath>

#include "fuzz_common.h"
#include "rbpf_slam/core/features/laser_line_extractor.h"
#include "rbpf_slam/core/features/scan_matcher.h"

using namespace rbpf_slam;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::ByteReader in(data, size);
  core::RangeScan scan;
  scan.angle_min = in.take<float>();
  scan.angle_increment = in.take<float>();
  scan.range_min = in.take<float>();
  scan.range_max = in.take<float>();
  scan.sensor_pose = core::Pose2(in.take<int8_t>() * 0.01, in.take<int8_t>() * 0.01,
                                 in.take<int8_t>() * 0.03);
  const uint8_t mode = in.take<uint8_t>();
  while (!in.empty() && scan.ranges.size() < 2000) {
    // Mostly plausible ranges (a byte in cm) with raw floats mixed in: NaN, inf, negatives.
    const uint8_t tag = in.take<uint8_t>();
    scan.ranges.push_back(tag < 200 ? tag * 0.05f : in.take<float>());
  }
  core::LaserExtractorOptions options;
  options.method = (mode & 1) ? "split_and_merge" : "incremental";
  const core::LaserLineExtractor extractor(options);
  const core::FeatureSet features = extractor.extract(scan);
  for (const auto& l : features.lines) {
    fuzz::require(std::isfinite(l.rho) && std::isfinite(l.theta) && l.rho >= 0.0);
    fuzz::require(l.covariance.allFinite() && l.start.allFinite() && l.end.allFinite());
  }
  for (const auto& p : features.points) {
    fuzz::require(std::isfinite(p.range) && std::isfinite(p.bearing) && p.covariance.allFinite());
  }
  core::ScanMatcherOptions matcher_options;
  matcher_options.enabled = true;
  const core::ScanMatcher matcher(matcher_options);
  const auto points = core::scanPointsInBase(scan, 30.0);
  for (const auto& p : points) fuzz::require(p.allFinite());
  if (points.size() > 1) {
    std::vector<Eigen::Vector2d> shifted = points;
    for (auto& p : shifted) p += Eigen::Vector2d(0.05, -0.02);
    const core::ScanMatchResult r = matcher.match(points, shifted, core::Pose2(0.05, 0.0, 0.0));
    if (r.ok) fuzz::require(r.delta.allFinite());
  }
  return 0;
}

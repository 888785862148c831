// libFuzzer target: arbitrary sonar rings (ranges, cone widths, mounts, NaN/inf included) and
// odometry poses through the sonar feature extractor. Findings: crashes, sanitizer reports,
// non-finite features.

#include <cmath>
#include <vector>

#include "fuzz_common.h"
#include "rbpf_slam/core/features/sonar_feature_extractor.h"

using namespace rbpf_slam;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::ByteReader in(data, size);
  core::SonarFeatureExtractor extractor{core::SonarExtractorOptions()};
  core::Pose2 odom = core::Pose2::Zero();
  double stamp = 1.0;
  for (int ring = 0; ring < 64 && !in.empty(); ++ring) {
    // Mostly plausible motion (bytes in cm / 0.01 rad), sometimes raw doubles.
    const uint8_t tag = in.take<uint8_t>();
    if (tag < 240) {
      odom = core::compose(odom, core::Pose2(in.take<int8_t>() * 0.01, in.take<int8_t>() * 0.005,
                                             in.take<int8_t>() * 0.01));
    } else {
      odom = core::Pose2(in.take<double>(), in.take<double>(), in.take<double>());
    }
    stamp += 0.25;
    std::vector<core::ConeReading> readings;
    const int count = in.take<uint8_t>() % 17;
    for (int i = 0; i < count; ++i) {
      core::ConeReading r;
      r.stamp = stamp;
      const uint8_t kind = in.take<uint8_t>();
      r.range = kind < 220 ? in.take<uint8_t>() * 0.025 : in.take<double>();
      r.min_range = 0.1;
      r.max_range = kind == 255 ? in.take<double>() : 5.0;
      r.field_of_view = kind == 254 ? in.take<double>() : 30.0 * M_PI / 180.0;
      const double angle = (i * 360.0 / 16.0 - 90.0) * M_PI / 180.0;
      r.sensor_pose = core::Pose2(0.15 * std::cos(angle), 0.15 * std::sin(angle), angle);
      readings.push_back(r);
    }
    extractor.addReadings(readings, odom, stamp);
    if (!extractor.extractionDue(odom)) continue;
    const core::FeatureSet features = extractor.extract(odom, stamp);
    for (const auto& l : features.lines) {
      fuzz::require(std::isfinite(l.rho) && std::isfinite(l.theta) && l.covariance.allFinite());
    }
    for (const auto& p : features.points) {
      fuzz::require(std::isfinite(p.range) && std::isfinite(p.bearing) && p.covariance.allFinite());
    }
  }
  return 0;
}

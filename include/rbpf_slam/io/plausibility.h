#pragma once
// Limits beyond which a finite number read from a log is corrupt data rather than a
// measurement: shared by the converters (MRCLAM, CARMEN), which would otherwise dead-reckon
// it into poses of 1e228 m or fail in ros::Time.

#include "rbpf_slam/core/plausibility.h"

namespace rbpf_slam {
namespace io {

constexpr double kMaxPlausibleCoordinateM = 1e6;  // poses and landmarks
constexpr double kMaxPlausibleSpeed = 100.0;      // m/s and rad/s
constexpr double kMaxPlausibleRangeM = core::kMaxPlausibleRangeM;  // a range sensor's reading
constexpr double kMaxPlausibleAngleRad = 1000.0;  // a logged heading, even if never wrapped
constexpr double kMaxRosStampS = 4294967295.0;    // ros::Time holds 32-bit seconds

}  // namespace io
}  // namespace rbpf_slam

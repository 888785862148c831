#pragma once
// Limits beyond which a finite number is corrupt data rather than a measurement, for the core
// (io/plausibility.h holds the converters' limits and takes this one from here).

namespace rbpf_slam {
namespace core {

constexpr double kMaxPlausibleRangeM = 1000.0;  // a range sensor's reading

}  // namespace core
}  // namespace rbpf_slam

#pragma once
// Order statistics shared by the evaluation (ATE median) and the smoother's choice among
// ensemble members (the median distance of one member's path to the others').

#include <vector>

namespace rbpf_slam {
namespace core {

/// The median: the middle value, or the mean of the two middle values of an even count. NaN
/// when values is empty.
double median(std::vector<double> values);

}  // namespace core
}  // namespace rbpf_slam

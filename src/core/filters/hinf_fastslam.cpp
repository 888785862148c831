#include "rbpf_slam/core/filters/hinf_fastslam.h"

namespace rbpf_slam {
namespace core {

HinfFastSlam::HinfFastSlam(const FilterOptions& options)
    : FastSlam2(options, std::make_unique<HinfRule>(options.hinf)) {}

}  // namespace core
}  // namespace rbpf_slam

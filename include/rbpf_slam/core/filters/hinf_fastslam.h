#pragma once
// H-infinity FastSLAM (Havangi, Nekoui, Taghirad, Teshnehlab): FastSLAM 2.0
// whose pose proposal (eqs. 18-24) and landmark filters (eqs. 28-34) are
// H-infinity filters with attenuation gamma, weighted by eq. 36 and resampled
// at Neff < 3/4 M (eqs. 38, 39) when `resample_threshold` is 0.75, as in
// config/landmarks_hinf.yaml (the option's default, shared by every variant,
// is 0.5), for noise
// statistics that are not known. Shares particles, association, landmark
// initialisation (eq. 35), existence management and resampling with FastSlam2.

#include "rbpf_slam/core/filters/fastslam2.h"

namespace rbpf_slam {
namespace core {

class HinfFastSlam : public FastSlam2 {
 public:
  /// Uses options.hinf; throws std::invalid_argument when it does not validate.
  explicit HinfFastSlam(const FilterOptions& options);
  std::string variant() const override { return "hinf_fastslam"; }
};

}  // namespace core
}  // namespace rbpf_slam

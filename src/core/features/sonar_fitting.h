#pragma once
// Internal to the sonar extractor: echoes in the base frame and the two fitting passes.

#include <Eigen/Core>
#include <vector>

#include "rbpf_slam/core/features/sonar_feature_extractor.h"

namespace rbpf_slam {
namespace core {
namespace sonar {

/// One echo expressed in the base frame of the extraction pose.
struct LocalEcho {
  Eigen::Vector2d sensor = Eigen::Vector2d::Zero();
  double axis = 0.0;
  double half_cone = 0.0;
  double range = 0.0;
  int transducer = 0;
  bool used = false;  // already explains a feature
};

inline Eigen::Vector2d unitVector(double angle) {
  return Eigen::Vector2d(std::cos(angle), std::sin(angle));
}

/// True when direction (rad, base frame) lies inside the echo's cone widened by margin.
inline bool insideCone(const LocalEcho& echo, double direction, double margin) {
  return std::abs(wrapAngle(direction - echo.axis)) <= echo.half_cone + margin;
}

/// Walls: Hough vote of every arc's tangent lines over (rho, theta), peaks refined by least
/// squares over the echoes tangent to them. Marks the echoes it explains as used.
std::vector<LineFeature> extractLines(const SonarExtractorOptions& options,
                                      std::vector<LocalEcho>* echoes);

/// Corners, edges and posts: vote of every unused arc over a grid of positions, peaks refined
/// by least-squares triangulation, rejected when ill-determined or contradicted by echoes
/// that looked through them. Marks the echoes it explains as used.
std::vector<PointFeature> extractPoints(const SonarExtractorOptions& options,
                                        std::vector<LocalEcho>* echoes);

}  // namespace sonar
}  // namespace core
}  // namespace rbpf_slam

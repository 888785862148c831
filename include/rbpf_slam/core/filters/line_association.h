#pragma once
// Pure functions of the line-based SMC SLAM (Yuen and MacDonald): ToGlobalFrame, the
// weighted absolute difference (WAD), the Hausdorff distance over it, and the association of
// current features to map landmarks with new-obstacle detection. Shared with the EKF baseline.

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/filters/line_slam_options.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

/// A line segment seen in the robot frame, in the map frame for the robot at `pose`:
/// normal form (rho >= 0, theta in [-pi, pi)) through the transformed end points (the
/// paper's eqs. 9 to 12, written without slopes so vertical lines need no special case).
/// A degenerate segment (end points closer than 1 mm) uses the feature's (rho, theta).
Eigen::Vector2d toGlobalFrame(const LineFeature& line, const Pose2& pose);

/// Eq. 13: the smaller angle between two directions, in [0, pi].
double angleDifference(double theta1, double theta2);

/// Eq. 14: c_w1 |rho1 - rho2| + c_w2 |delta theta| of two (rho, theta) lines.
double weightedAbsoluteDifference(const Eigen::Vector2d& line1, const Eigen::Vector2d& line2,
                                  double c_w1, double c_w2);

/// Eq. 15: max over a in A of min over b in B of d(a, b). 0 when A is empty, +inf when A is
/// not empty and B is.
double hausdorffDistance(
    const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b,
    const std::function<double(const Eigen::Vector2d&, const Eigen::Vector2d&)>& distance);

/// A feature of the current scan in the map frame (one robot pose), ready to associate.
struct GlobalFeature {
  LandmarkType type = LandmarkType::kLine;
  Eigen::Vector2d value = Eigen::Vector2d::Zero();  // line (rho, theta) or point (x, y)
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // line extent (map frame); point: itself
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  int source = -1;  // index into the caller's observation list
};

/// A feature seen from `at`, in the map frame: a line by ToGlobalFrame with its observed
/// extent, a point from its (range, bearing). Shared by the multi-filter SMC and the EKF.
GlobalFeature globalFeature(LandmarkType type, const LineFeature& line,
                            const Eigen::Vector2d& range_bearing, const Pose2& at, int source);

/// WAD between two lines as sets of points: the smaller of the WAD to (rho2, theta2) and to
/// its other normal form (-rho2, theta2 + pi). They differ only for lines passing near the
/// origin, where rho ~ 0 and the normal's direction flips between sightings.
double lineWad(const Eigen::Vector2d& line1, const Eigen::Vector2d& line2, double c_w1,
               double c_w2);

/// The line (rho, theta) with its rho measured from centre instead of the origin (signed: the
/// normal keeps its direction).
Eigen::Vector2d lineSeenFrom(const Eigen::Vector2d& line, const Eigen::Vector2d& centre);

/// Where the WAD measures a line's rho for a robot at `position`: there with
/// options.compare_at "robot", else the map origin (zero).
Eigen::Vector2d wadCentre(const WadAssociationOptions& options, const Eigen::Vector2d& position);

/// lineWad for lines, both rho measured from centre (lineSeenFrom; a zero centre is the map
/// origin: the paper's WAD), Euclidean distance for points.
double featureDissimilarity(LandmarkType type, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                            const WadAssociationOptions& options, const Eigen::Vector2d& centre);

/// The outcome of FeatureAssociation() and FoundNewObstacle() for one scan.
struct WadAssociation {
  std::vector<int> map_to_feature;  // M_phi_z: per map landmark, feature index or -1
  std::vector<int> feature_to_map;  // per feature, the most similar landmark or -1
  std::vector<int> new_features;    // features farther than h_similar from every landmark
  double hausdorff = 0.0;           // H(features, map) over the dissimilarity
};

/// Associates features to map landmarks (their centroids): a landmark's entry is its most
/// similar feature when closer than h_similar_feature; a new obstacle is detected when the
/// Hausdorff distance from the features to the map exceeds h_similar_feature, and then every
/// feature farther than that from every landmark is new. O(features x landmarks).
/// centre: where lines' rho is measured (wadCentre).
WadAssociation associateByWad(const std::vector<GlobalFeature>& features,
                              const std::vector<LandmarkType>& map_types,
                              const std::vector<Eigen::Vector2d>& map_values,
                              const WadAssociationOptions& options, const Eigen::Vector2d& centre);

}  // namespace core
}  // namespace rbpf_slam

#include "rbpf_slam/core/filters/line_association.h"

#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/require_range.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rbpf_slam {
namespace core {
namespace {

}  // namespace

void validate(const WadAssociationOptions& o) {
  requireRange("line_association.h_similar_feature", o.h_similar_feature, 1e-6, 100.0);
  requireRange("line_association.c_w1", o.c_w1, 0.0, 1000.0);
  requireRange("line_association.c_w2", o.c_w2, 0.0, 1000.0);
  requireOneOf("line_association.compare_at", o.compare_at, {"origin", "robot"});
  if (o.c_w1 + o.c_w2 <= 0.0) {
    throw std::invalid_argument("line_association.c_w1 and c_w2 are both 0: WAD is always 0");
  }
}

void validate(const MultiFilterOptions& o) {
  requireRange("multifilter.line_particles", o.line_particles, 1, 100000);
  requireRange("multifilter.c_m1", o.c_m1, 1e-6, 1000.0);
  requireRange("multifilter.c_m2", o.c_m2, 1e-6, 1000.0);
  requireRange("multifilter.init_sigma_m", o.init_sigma_m, 0.0, 100.0);
  requireRange("multifilter.init_sigma_rad", o.init_sigma_rad, 0.0, M_PI);
  requireRange("multifilter.roughening_m", o.roughening_m, 0.0, 10.0);
  requireRange("multifilter.roughening_rad", o.roughening_rad, 0.0, 1.0);
}

void validate(const EkfSlamOptions& o) {
  requireRange("ekf.innovation_gate_chi2", o.innovation_gate_chi2, 0.0, 1e6);
}

GlobalFeature globalFeature(LandmarkType type, const LineFeature& line,
                            const Eigen::Vector2d& range_bearing, const Pose2& at, int source) {
  GlobalFeature g;
  g.type = type;
  g.source = source;
  if (type == LandmarkType::kLine) {
    g.value = toGlobalFrame(line, at);
    g.start = transformPoint(at, line.start);
    g.end = transformPoint(at, line.end);
  } else {
    g.value = pointFromObservation(at, range_bearing, nullptr);
    g.start = g.end = g.value;
  }
  return g;
}

Eigen::Vector2d toGlobalFrame(const LineFeature& line, const Pose2& pose) {
  const Eigen::Vector2d a = transformPoint(pose, line.start);
  const Eigen::Vector2d b = transformPoint(pose, line.end);
  const Eigen::Vector2d d = b - a;
  double rho, theta;
  if (d.norm() >= 1e-3) {
    const Eigen::Vector2d normal = Eigen::Vector2d(-d.y(), d.x()).normalized();
    rho = normal.dot(a);
    theta = std::atan2(normal.y(), normal.x());
  } else {
    theta = line.theta + pose.z();
    rho = line.rho + pose.x() * std::cos(theta) + pose.y() * std::sin(theta);
  }
  normalizeLine(rho, theta);
  return Eigen::Vector2d(rho, theta);
}

double angleDifference(double theta1, double theta2) {
  const double d = std::fabs(std::fmod(theta1 - theta2, 2.0 * M_PI));
  return std::min(d, 2.0 * M_PI - d);
}

double weightedAbsoluteDifference(const Eigen::Vector2d& line1, const Eigen::Vector2d& line2,
                                  double c_w1, double c_w2) {
  return c_w1 * std::fabs(line1.x() - line2.x()) + c_w2 * angleDifference(line1.y(), line2.y());
}

double lineWad(const Eigen::Vector2d& line1, const Eigen::Vector2d& line2, double c_w1,
               double c_w2) {
  const Eigen::Vector2d flipped(-line2.x(), line2.y() + M_PI);
  return std::min(weightedAbsoluteDifference(line1, line2, c_w1, c_w2),
                  weightedAbsoluteDifference(line1, flipped, c_w1, c_w2));
}

double hausdorffDistance(
    const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b,
    const std::function<double(const Eigen::Vector2d&, const Eigen::Vector2d&)>& distance) {
  double worst = 0.0;
  for (const auto& x : a) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& y : b) nearest = std::min(nearest, distance(x, y));
    worst = std::max(worst, nearest);
  }
  return worst;
}

Eigen::Vector2d lineSeenFrom(const Eigen::Vector2d& line, const Eigen::Vector2d& centre) {
  return Eigen::Vector2d(
      line.x() - centre.x() * std::cos(line.y()) - centre.y() * std::sin(line.y()), line.y());
}

Eigen::Vector2d wadCentre(const WadAssociationOptions& options, const Eigen::Vector2d& position) {
  if (options.compare_at == "robot") return position;
  if (options.compare_at == "origin") return Eigen::Vector2d::Zero();
  throw std::invalid_argument("line_association.compare_at = '" + options.compare_at +
                              "' is not one of: origin, robot");
}

double featureDissimilarity(LandmarkType type, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                            const WadAssociationOptions& options, const Eigen::Vector2d& centre) {
  if (type == LandmarkType::kLine) {
    if (centre.x() != 0.0 || centre.y() != 0.0) {
      return lineWad(lineSeenFrom(a, centre), lineSeenFrom(b, centre), options.c_w1,
                     options.c_w2);
    }
    return lineWad(a, b, options.c_w1, options.c_w2);
  }
  return (a - b).norm();
}

WadAssociation associateByWad(const std::vector<GlobalFeature>& features,
                              const std::vector<LandmarkType>& map_types,
                              const std::vector<Eigen::Vector2d>& map_values,
                              const WadAssociationOptions& options, const Eigen::Vector2d& centre) {
  const double inf = std::numeric_limits<double>::infinity();
  const int n_features = features.size(), n_map = map_values.size();
  WadAssociation out;
  out.map_to_feature.assign(n_map, -1);
  out.feature_to_map.assign(n_features, -1);
  std::vector<double> map_best(n_map, inf);
  for (int j = 0; j < n_features; ++j) {
    double feature_best = inf;
    for (int i = 0; i < n_map; ++i) {
      if (map_types[i] != features[j].type) continue;
      const double d =
          featureDissimilarity(features[j].type, features[j].value, map_values[i], options, centre);
      if (d < feature_best) {
        feature_best = d;
        out.feature_to_map[j] = i;
      }
      if (d < map_best[i]) {
        map_best[i] = d;
        out.map_to_feature[i] = j;
      }
    }
    // Eq. 15 with the min over the map taken here, the max over features below.
    out.hausdorff = std::max(out.hausdorff, feature_best);
    if (!(feature_best < options.h_similar_feature)) {
      out.feature_to_map[j] = -1;
      out.new_features.push_back(j);
    }
  }
  for (int i = 0; i < n_map; ++i) {
    if (!(map_best[i] < options.h_similar_feature)) out.map_to_feature[i] = -1;
  }
  if (!(out.hausdorff > options.h_similar_feature)) out.new_features.clear();
  return out;
}

}  // namespace core
}  // namespace rbpf_slam

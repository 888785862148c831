#include "rbpf_slam/ros/markers.h"

#include <algorithm>
#include <cmath>

#include "rbpf_slam/ros/conversions.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

constexpr double kLineWidthM = 0.05;
constexpr double kPointDiameterM = 0.15;
constexpr double kEllipseWidthM = 0.02;
constexpr double kUnseenLineHalfLengthM = 1.0;  // drawn extent of a line with no seen extent
constexpr int kEllipseSegments = 32;

std_msgs::ColorRGBA colour(float r, float g, float b, float a = 1.0f) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

geometry_msgs::Point point(const Eigen::Vector2d& p) {
  geometry_msgs::Point out;
  out.x = p.x();
  out.y = p.y();
  return out;
}

visualization_msgs::Marker baseMarker(const std_msgs::Header& header, const std::string& ns, int id,
                                      int type) {
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  return m;
}

bool isFinite(const core::LandmarkEstimate& l) {
  return l.mean.allFinite() && l.covariance.allFinite() &&
         (l.type != core::LandmarkType::kLine || (l.start.allFinite() && l.end.allFinite()));
}

visualization_msgs::Marker lineMarker(const core::LandmarkEstimate& l,
                                      const std_msgs::Header& header) {
  visualization_msgs::Marker m =
      baseMarker(header, LandmarkMarkers::kLinesNs, l.id, visualization_msgs::Marker::LINE_LIST);
  m.scale.x = kLineWidthM;
  m.color = colour(0.1f, 0.4f, 1.0f);
  Eigen::Vector2d start = l.start, end = l.end;
  if ((end - start).norm() < 1e-6) {  // no extent yet: a short piece around the foot point
    const double rho = l.mean.x(), theta = l.mean.y();
    const Eigen::Vector2d foot(rho * std::cos(theta), rho * std::sin(theta));
    const Eigen::Vector2d along(-std::sin(theta), std::cos(theta));
    start = foot - kUnseenLineHalfLengthM * along;
    end = foot + kUnseenLineHalfLengthM * along;
  }
  m.points = {point(start), point(end)};
  return m;
}

visualization_msgs::Marker pointMarker(const core::LandmarkEstimate& l,
                                       const std_msgs::Header& header) {
  visualization_msgs::Marker m =
      baseMarker(header, LandmarkMarkers::kPointsNs, l.id, visualization_msgs::Marker::SPHERE);
  m.pose.position = point(l.mean);
  m.scale.x = m.scale.y = m.scale.z = kPointDiameterM;
  m.color = colour(1.0f, 0.5f, 0.0f);
  return m;
}

visualization_msgs::Marker ellipseMarker(const core::LandmarkEstimate& l,
                                         const std::vector<Eigen::Vector2d>& ellipse,
                                         const std_msgs::Header& header) {
  visualization_msgs::Marker m = baseMarker(header, LandmarkMarkers::kPointCovarianceNs, l.id,
                                            visualization_msgs::Marker::LINE_STRIP);
  m.scale.x = kEllipseWidthM;
  m.color = colour(1.0f, 0.8f, 0.0f, 0.8f);
  for (const auto& p : ellipse) m.points.push_back(point(p));
  return m;
}

}  // namespace

std::vector<Eigen::Vector2d> covarianceEllipse(const Eigen::Vector2d& mean,
                                               const Eigen::Matrix2d& covariance, double n_sigma,
                                               int segments) {
  std::vector<Eigen::Vector2d> points;
  if (!mean.allFinite() || !covariance.allFinite() || segments < 3) return points;
  // Closed-form eigen decomposition of the symmetric part [a b; b c].
  const double a = covariance(0, 0), c = covariance(1, 1);
  const double b = 0.5 * (covariance(0, 1) + covariance(1, 0));
  const double half_sum = 0.5 * (a + c);
  const double spread = std::hypot(0.5 * (a - c), b);
  const double angle = 0.5 * std::atan2(2.0 * b, a - c);  // of the major axis
  // Negative eigenvalues (a not quite positive semi-definite matrix) are drawn as zero.
  const Eigen::Vector2d radii(n_sigma * std::sqrt(std::max(half_sum + spread, 0.0)),
                              n_sigma * std::sqrt(std::max(half_sum - spread, 0.0)));
  Eigen::Matrix2d axes;
  axes << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  for (int i = 0; i <= segments; ++i) {
    const double t = 2.0 * M_PI * (i % segments) / segments;
    points.push_back(mean + axes.col(0) * radii(0) * std::cos(t) +
                     axes.col(1) * radii(1) * std::sin(t));
  }
  return points;
}

visualization_msgs::MarkerArray LandmarkMarkers::update(
    const std::vector<core::LandmarkEstimate>& landmarks, const std_msgs::Header& header) {
  visualization_msgs::MarkerArray array;
  if (delete_all_) {
    array.markers.push_back(baseMarker(header, "", 0, visualization_msgs::Marker::SPHERE));
    array.markers.back().action = visualization_msgs::Marker::DELETEALL;
    delete_all_ = false;
  }
  std::set<std::pair<std::string, int>> now;
  for (const auto& l : landmarks) {
    if (!isFinite(l)) continue;
    if (l.type == core::LandmarkType::kLine) {
      array.markers.push_back(lineMarker(l, header));
      now.emplace(kLinesNs, l.id);
      continue;
    }
    array.markers.push_back(pointMarker(l, header));
    now.emplace(kPointsNs, l.id);
    const auto ellipse = covarianceEllipse(l.mean, l.covariance, 2.0, kEllipseSegments);
    if (!ellipse.empty()) {
      array.markers.push_back(ellipseMarker(l, ellipse, header));
      now.emplace(kPointCovarianceNs, l.id);
    }
  }
  for (const auto& [ns, id] : published_) {
    if (now.count({ns, id})) continue;
    visualization_msgs::Marker m = baseMarker(header, ns, id, visualization_msgs::Marker::SPHERE);
    m.action = visualization_msgs::Marker::DELETE;
    array.markers.push_back(m);
  }
  published_ = std::move(now);
  return array;
}

geometry_msgs::PoseArray toPoseArray(const std::vector<core::WeightedPose>& particles,
                                     const std_msgs::Header& header) {
  geometry_msgs::PoseArray array;
  array.header = header;
  array.poses.reserve(particles.size());
  for (const auto& p : particles) {
    if (p.pose.allFinite()) array.poses.push_back(toPoseMsg(p.pose));
  }
  return array;
}

nav_msgs::Path toPath(const std::vector<core::TrajectoryPoint>& trajectory,
                      const std::string& frame_id) {
  nav_msgs::Path path;
  path.header.frame_id = frame_id;
  path.poses.reserve(trajectory.size());
  for (const auto& point : trajectory) {
    if (!point.pose.allFinite() || !std::isfinite(point.stamp) || point.stamp <= 0.0) continue;
    geometry_msgs::PoseStamped pose;
    pose.header.frame_id = frame_id;
    pose.header.stamp.fromSec(point.stamp);
    pose.pose = toPoseMsg(point.pose);
    path.poses.push_back(pose);
  }
  if (!path.poses.empty()) path.header.stamp = path.poses.back().header.stamp;
  return path;
}

}  // namespace rosbridge
}  // namespace rbpf_slam

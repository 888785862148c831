#pragma once
// Visualisation messages for the filter's state: landmark markers, particle poses, trajectory.

#include <geometry_msgs/PoseArray.h>
#include <nav_msgs/Path.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include <set>
#include <string>
#include <utility>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/slam/slam_session.h"

namespace rbpf_slam {
namespace rosbridge {

/// Turns successive landmark lists into MarkerArrays with stable ids, deleting markers of
/// landmarks that disappeared since the previous call. The first array (and the first after
/// clear()) starts with a DELETEALL: rviz keeps the markers of an earlier run of the node
/// (a restart, a bag played again) otherwise, for every id the new run does not reuse.
class LandmarkMarkers {
 public:
  /// Marker namespaces: one marker per landmark in each, id = landmark id.
  static constexpr const char* kLinesNs = "lines";
  static constexpr const char* kPointsNs = "points";
  static constexpr const char* kPointCovarianceNs = "point_covariance";

  /// Lines as LINE_LIST segments, points as spheres plus 2-sigma covariance ellipses
  /// (LINE_STRIP), DELETE for every (namespace, id) published last time but not now.
  /// Landmarks with non-finite values are left out.
  visualization_msgs::MarkerArray update(const std::vector<core::LandmarkEstimate>& landmarks,
                                         const std_msgs::Header& header);
  /// Forgets what was published; the next array starts with a DELETEALL.
  void clear() {
    published_.clear();
    delete_all_ = true;
  }

 private:
  std::set<std::pair<std::string, int>> published_;
  bool delete_all_ = true;
};

/// The (finite) particle poses in header.frame_id.
geometry_msgs::PoseArray toPoseArray(const std::vector<core::WeightedPose>& particles,
                                     const std_msgs::Header& header);

/// The trajectory (base in map) as a Path in frame_id, stamped with the last point's time.
nav_msgs::Path toPath(const std::vector<core::TrajectoryPoint>& trajectory,
                      const std::string& frame_id);

/// Points of a closed ellipse at n_sigma standard deviations of a 2D Gaussian (segments + 1
/// points, the first repeated last). Empty if the covariance is not finite.
std::vector<Eigen::Vector2d> covarianceEllipse(const Eigen::Vector2d& mean,
                                               const Eigen::Matrix2d& covariance, double n_sigma,
                                               int segments);

}  // namespace rosbridge
}  // namespace rbpf_slam

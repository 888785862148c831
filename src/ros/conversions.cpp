#include "rbpf_slam/ros/conversions.h"

#include <tf2/LinearMath/Quaternion.h>
#include <tf2/utils.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "rbpf_slam/core/filters/observation.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

Eigen::Matrix2d toMatrix(const boost::array<double, 4>& c) {
  Eigen::Matrix2d m;
  m << c[0], c[1], c[2], c[3];
  return m;
}

void fromMatrix(const Eigen::Matrix2d& m, boost::array<double, 4>* c) {
  (*c)[0] = m(0, 0);
  (*c)[1] = m(0, 1);
  (*c)[2] = m(1, 0);
  (*c)[3] = m(1, 1);
}

}  // namespace

core::Pose2 toPose2(const geometry_msgs::Transform& t) {
  return core::Pose2(t.translation.x, t.translation.y, tf2::getYaw(t.rotation));
}

core::Pose2 toPose2(const geometry_msgs::Pose& p) {
  return core::Pose2(p.position.x, p.position.y, tf2::getYaw(p.orientation));
}

std::string fromInitialPose(const geometry_msgs::PoseWithCovarianceStamped& msg,
                            const std::string& map_frame, core::Pose2* pose,
                            Eigen::Matrix3d* covariance, std::string* note) {
  note->clear();
  if (!msg.header.frame_id.empty() && stripSlash(msg.header.frame_id) != stripSlash(map_frame)) {
    return "in frame '" + msg.header.frame_id + "': expected the map frame '" + map_frame + "'";
  }
  *pose = toPose2(msg.pose.pose);
  if (!pose->allFinite()) return "whose position or orientation is not finite";
  const int index[3] = {0, 1, 5};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) (*covariance)(i, j) = msg.pose.covariance[index[i] * 6 + index[j]];
  }
  // rviz sends 0.25 m^2 and 0.0685 rad^2; an all-zero (unset) covariance gets those, and so
  // does a broken one, with a note naming what is wrong with it.
  const bool unset = covariance->isZero(0.0);
  const std::string problem = core::poseCovarianceProblem(*covariance);
  if (!unset && !problem.empty()) {
    *note = "(x, y, yaw rows of pose.covariance) " + problem +
            "; using rviz's 0.25 m^2, 0.25 m^2, 0.0685 rad^2 instead";
  }
  if (unset || !problem.empty()) *covariance = core::defaultStartCovariance();
  return "";
}

std::string stripSlash(const std::string& name) {
  return !name.empty() && name[0] == '/' ? name.substr(1) : name;
}

std::string farStampProblem(const ros::Time& stamp) {
  if (!(stamp.toSec() > kFarStampS)) return "";
  char text[128];
  std::snprintf(text, sizeof(text),
                "stamp %.3f s is near 2^32 s (a driver's -1?), beyond what tf2 can handle",
                stamp.toSec());
  return text;
}

std::string transformProblem(const geometry_msgs::TransformStamped& t) {
  const std::string parent = stripSlash(t.header.frame_id), child = stripSlash(t.child_frame_id);
  if (parent.empty()) return "no frame_id";
  if (child.empty()) return "no child_frame_id";
  if (parent == child) return "frame_id and child_frame_id are both '" + child + "'";
  const std::string far = farStampProblem(t.header.stamp);
  if (!far.empty()) return far;
  const auto& p = t.transform.translation;
  const auto& q = t.transform.rotation;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
    return "a translation that is not finite";
  }
  if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w)) {
    return "a rotation that is not finite";
  }
  const double norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  if (std::abs(norm2 - 1.0) >= 0.01) {
    char text[96];
    std::snprintf(text, sizeof(text), "a quaternion that is not normalised (norm %.4g)",
                  std::sqrt(norm2));
    return text;
  }
  return "";
}

SensorMount toSensorMount(const geometry_msgs::Transform& t) {
  SensorMount mount;
  mount.pose = toPose2(t);
  const geometry_msgs::Quaternion& q = t.rotation;
  const double norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  if (!(norm2 > 0.0) || !std::isfinite(norm2)) return mount;
  // R(2, 2), the z component of the frame's z axis, of the normalised quaternion.
  const double up = 1.0 - 2.0 * (q.x * q.x + q.y * q.y) / norm2;
  mount.upside_down = up < 0.0;
  mount.tilt_rad = std::acos(std::min(1.0, std::fabs(up)));
  return mount;
}

std::string tiltWarning(const std::string& frame, const SensorMount& mount) {
  char angle[32];
  std::snprintf(angle, sizeof(angle), "%.1f", mount.tilt_rad * 180.0 / M_PI);
  return "Sensor frame " + frame + " is tilted " + angle + " deg from " +
         (mount.upside_down ? "upside down" : "level") +
         ": its readings are used as if level (rbpf_slam maps in 2D)";
}

geometry_msgs::Transform toTransform(const core::Pose2& pose) {
  geometry_msgs::Transform t;
  t.translation.x = pose.x();
  t.translation.y = pose.y();
  tf2::Quaternion q;
  q.setRPY(0.0, 0.0, pose.z());
  t.rotation.x = q.x();
  t.rotation.y = q.y();
  t.rotation.z = q.z();
  t.rotation.w = q.w();
  return t;
}

geometry_msgs::Pose toPoseMsg(const core::Pose2& pose) {
  const geometry_msgs::Transform t = toTransform(pose);
  geometry_msgs::Pose p;
  p.position.x = t.translation.x;
  p.position.y = t.translation.y;
  p.orientation = t.rotation;
  return p;
}

boost::array<double, 36> toPoseCovariance(const Eigen::Matrix3d& c) {
  boost::array<double, 36> out{};
  const int index[3] = {0, 1, 5};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out[index[i] * 6 + index[j]] = c(i, j);
  }
  return out;
}

geometry_msgs::TransformStamped toTransformStamped(const core::Pose2& pose, const std::string& parent,
                                                   const std::string& child, const ros::Time& stamp) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform = toTransform(pose);
  return t;
}

nav_msgs::Odometry toOdometryMsg(const core::Pose2& pose, const Eigen::Vector3d& twist,
                                 const std::string& frame, const std::string& child,
                                 const ros::Time& stamp) {
  nav_msgs::Odometry odometry;
  odometry.header.stamp = stamp;
  odometry.header.frame_id = frame;
  odometry.child_frame_id = child;
  odometry.pose.pose = toPoseMsg(pose);
  odometry.twist.twist.linear.x = twist.x();
  odometry.twist.twist.linear.y = twist.y();
  odometry.twist.twist.angular.z = twist.z();
  return odometry;
}

bool toRangeScan(const sensor_msgs::LaserScan& msg, const core::Pose2& sensor_in_base,
                 core::RangeScan* scan, std::string* error, bool upside_down) {
  if (!std::isfinite(msg.angle_min) || !std::isfinite(msg.angle_increment) ||
      msg.angle_increment == 0.0f) {
    *error = "angle_min/angle_increment not finite or increment zero";
    return false;
  }
  if (msg.ranges.size() > 1 && std::isfinite(msg.angle_max)) {
    const double expected = msg.angle_min + msg.angle_increment * (msg.ranges.size() - 1);
    // Tolerate rounding and drivers that count one beam more or less than they send.
    if (std::fabs(expected - msg.angle_max) > 2.0 * std::fabs(msg.angle_increment) + 1e-3) {
      *error = "angle_increment * (beams - 1) does not span angle_min..angle_max; bearings are "
               "taken from angle_min + i * angle_increment";
    }
  }
  scan->stamp = msg.header.stamp.toSec();
  // Upside down, a beam at angle b in the sensor frame points at -b seen from above.
  scan->angle_min = upside_down ? -msg.angle_min : msg.angle_min;
  scan->angle_increment = upside_down ? -msg.angle_increment : msg.angle_increment;
  scan->range_min = std::isfinite(msg.range_min) && msg.range_min > 0.0f ? msg.range_min : 0.0;
  scan->range_max = std::isfinite(msg.range_max) && msg.range_max > 0.0f
                        ? msg.range_max
                        : std::numeric_limits<double>::infinity();
  scan->ranges = msg.ranges;
  scan->sensor_pose = sensor_in_base;
  return true;
}

bool toConeReading(const sensor_msgs::Range& msg, const core::Pose2& sensor_in_base,
                   core::ConeReading* reading, std::string* error) {
  if (!std::isfinite(msg.field_of_view) || msg.field_of_view <= 0.0f ||
      msg.field_of_view >= static_cast<float>(M_PI)) {
    *error = "field_of_view " + std::to_string(msg.field_of_view) + " is not in (0, pi)";
    return false;
  }
  reading->stamp = msg.header.stamp.toSec();
  reading->range = msg.range;
  reading->min_range = std::isfinite(msg.min_range) ? msg.min_range : 0.0;
  reading->max_range = std::isfinite(msg.max_range) && msg.max_range > 0.0f
                           ? msg.max_range
                           : std::numeric_limits<double>::infinity();
  reading->field_of_view = msg.field_of_view;
  reading->sensor_pose = sensor_in_base;
  return true;
}

bool toPointCloud(const sensor_msgs::PointCloud2& msg, sensor_msgs::PointCloud* out,
                  std::string* error) {
  // Offset and width of a float field, or -1 when the cloud has none.
  auto field = [&msg](const std::string& name, int* bytes) {
    for (const auto& f : msg.fields) {
      if (f.name != name || f.count < 1) continue;
      if (f.datatype == sensor_msgs::PointField::FLOAT32)
        *bytes = 4;
      else if (f.datatype == sensor_msgs::PointField::FLOAT64)
        *bytes = 8;
      else
        return -1;
      return f.offset + *bytes <= msg.point_step ? static_cast<int>(f.offset) : -1;
    }
    return -1;
  };
  int x_bytes = 0, y_bytes = 0, z_bytes = 0;
  const int x = field("x", &x_bytes), y = field("y", &y_bytes), z = field("z", &z_bytes);
  if (x < 0 || y < 0) {
    *error = "no float32/float64 x and y fields within point_step";
    return false;
  }
  if (msg.is_bigendian) {
    *error = "big-endian clouds are not supported";
    return false;
  }
  // Rows of row_step bytes (width points each, maybe padded); sizes checked by division so
  // that no product can overflow.
  const uint64_t width = msg.width, height = msg.height, step = msg.point_step;
  const uint64_t row_step = msg.row_step, size = msg.data.size();
  bool fits = true;
  if (width > 0 && height > 0) {
    fits = step > 0 && size / step >= width;  // one row's points
    if (fits && height > 1) {
      fits = row_step / step >= width && size / row_step >= height - 1 &&
             size - (height - 1) * row_step >= width * step;
    }
  }
  if (!fits && height > 1 && step > 0 && row_step / step < width) {
    *error = "row_step " + std::to_string(row_step) + " is shorter than " + std::to_string(width) +
             " points of " + std::to_string(step) + " bytes";
    return false;
  }
  if (!fits) {
    *error = "data holds " + std::to_string(size) + " bytes, too few for " + std::to_string(width) +
             " x " + std::to_string(height) + " points of " + std::to_string(step) +
             " bytes (row_step " + std::to_string(row_step) + ")";
    return false;
  }
  const uint64_t points = width * height;  // at most size: checked above
  auto read = [&msg](uint64_t at, int bytes) {
    if (bytes == 4) {
      float v;
      std::memcpy(&v, &msg.data[at], 4);
      return static_cast<double>(v);
    }
    double v;
    std::memcpy(&v, &msg.data[at], 8);
    return v;
  };
  out->header = msg.header;
  out->channels.clear();
  out->points.resize(points);
  for (uint64_t i = 0; i < points; ++i) {
    const uint64_t base = (i / width) * row_step + (i % width) * step;
    out->points[i].x = static_cast<float>(read(base + x, x_bytes));
    out->points[i].y = static_cast<float>(read(base + y, y_bytes));
    out->points[i].z = z >= 0 ? static_cast<float>(read(base + z, z_bytes)) : 0.0f;
  }
  return true;
}

std::vector<Eigen::Vector2d> toBasePoints(const sensor_msgs::PointCloud& msg,
                                          const core::Pose2& frame_in_base, bool upside_down) {
  std::vector<Eigen::Vector2d> points;
  points.reserve(msg.points.size());
  const double mirror = upside_down ? -1.0 : 1.0;
  for (const auto& p : msg.points) {
    points.push_back(core::transformPoint(frame_in_base, Eigen::Vector2d(p.x, mirror * p.y)));
  }
  return points;
}

int countUnusableCovariances(const core::FeatureSet& set) {
  auto unusable = [](const Eigen::Matrix2d& c) {
    return !c.isZero(0.0) && !core::finitePositiveDefinite(0.5 * (c + c.transpose()));
  };
  int count = 0;
  for (const core::PointFeature& p : set.points) count += unusable(p.covariance) ? 1 : 0;
  for (const core::LineFeature& l : set.lines) count += unusable(l.covariance) ? 1 : 0;
  return count;
}

std::string unusableCovarianceWarning(int count, const std::string& topic) {
  return std::to_string(count) + " feature(s) on " + topic +
         " carry a covariance that is not positive definite (all zero means unset and is "
         "fine): the configured measurement noise is used for them";
}

core::FeatureSet toFeatureSet(const FeatureArray& msg, const core::Pose2& frame_in_base,
                              int* dropped, bool upside_down) {
  core::FeatureSet set;
  set.stamp = msg.header.stamp.toSec();
  *dropped = 0;
  const bool identity = frame_in_base.isZero(0.0);
  for (const auto& p : msg.points) {
    core::PointFeature f;
    f.range = p.range;
    f.bearing = p.bearing;
    f.covariance = toMatrix(p.covariance);
    f.id = p.id;
    if (!std::isfinite(f.range) || !std::isfinite(f.bearing) || f.range < 0.0 ||
        !f.covariance.allFinite()) {
      ++*dropped;
      continue;
    }
    if (upside_down) {  // y of the frame is -y of a level one: bearings turn the other way
      f.bearing = -f.bearing;
      f.covariance(0, 1) = -f.covariance(0, 1);
      f.covariance(1, 0) = -f.covariance(1, 0);
    }
    if (!identity) {  // re-express in the base frame (covariance kept: a small offset)
      const Eigen::Vector2d in_frame(f.range * std::cos(f.bearing), f.range * std::sin(f.bearing));
      const Eigen::Vector2d in_base = core::transformPoint(frame_in_base, in_frame);
      f.range = in_base.norm();
      f.bearing = std::atan2(in_base.y(), in_base.x());
      if (!std::isfinite(f.range)) {  // a finite but absurd range can overflow on the way
        ++*dropped;
        continue;
      }
    }
    set.points.push_back(f);
  }
  for (const auto& l : msg.lines) {
    core::LineFeature f;
    f.rho = l.rho;
    f.theta = l.theta;
    f.covariance = toMatrix(l.covariance);
    f.start << l.start.x, l.start.y;
    f.end << l.end.x, l.end.y;
    if (!std::isfinite(f.rho) || !std::isfinite(f.theta) || !f.covariance.allFinite() ||
        !f.start.allFinite() || !f.end.allFinite()) {
      ++*dropped;
      continue;
    }
    if (upside_down) {  // mirrored about the frame's x axis: the normal's angle turns over
      f.theta = -f.theta;
      f.covariance(0, 1) = -f.covariance(0, 1);
      f.covariance(1, 0) = -f.covariance(1, 0);
      f.start.y() = -f.start.y();
      f.end.y() = -f.end.y();
    }
    if (!identity) {
      const double theta = f.theta + frame_in_base.z();
      f.rho += frame_in_base.x() * std::cos(theta) + frame_in_base.y() * std::sin(theta);
      f.theta = theta;
      f.start = core::transformPoint(frame_in_base, f.start);
      f.end = core::transformPoint(frame_in_base, f.end);
      if (!std::isfinite(f.rho) || !f.start.allFinite() || !f.end.allFinite()) {
        ++*dropped;  // a finite but absurd value overflowed in the transform
        continue;
      }
    }
    core::normalizeLine(f.rho, f.theta);
    set.lines.push_back(f);
  }
  return set;
}

FeatureArray toMsg(const core::FeatureSet& features, const std_msgs::Header& header) {
  FeatureArray msg;
  msg.header = header;
  for (const auto& p : features.points) {
    PointFeature out;
    out.range = p.range;
    out.bearing = p.bearing;
    fromMatrix(p.covariance, &out.covariance);
    out.id = p.id;
    msg.points.push_back(out);
  }
  for (const auto& l : features.lines) {
    LineFeature out;
    out.rho = l.rho;
    out.theta = l.theta;
    fromMatrix(l.covariance, &out.covariance);
    out.start.x = l.start.x();
    out.start.y = l.start.y();
    out.end.x = l.end.x();
    out.end.y = l.end.y();
    msg.lines.push_back(out);
  }
  return msg;
}

nav_msgs::OccupancyGrid toOccupancyGrid(const core::GridMapData& grid, const std::string& frame,
                                        const ros::Time& stamp) {
  nav_msgs::OccupancyGrid msg;
  msg.header.frame_id = frame;
  msg.header.stamp = stamp;
  msg.info.map_load_time = stamp;
  msg.info.resolution = static_cast<float>(grid.resolution_m);
  msg.info.width = static_cast<uint32_t>(std::max(grid.width, 0));
  msg.info.height = static_cast<uint32_t>(std::max(grid.height, 0));
  msg.info.origin = toPoseMsg(core::Pose2(grid.origin_x_m, grid.origin_y_m, 0.0));
  msg.data.assign(grid.cells.begin(), grid.cells.end());
  return msg;
}

}  // namespace rosbridge
}  // namespace rbpf_slam

#include "panotrack/pose/pose2.h"

#include <cmath>

namespace pano {

Eigen::Vector3d SensorFromWorld(const Pose2& pose, double sensor_height, const Eigen::Vector3d& pw) {
  return SensorFromWorld(pose, Eigen::Vector2d(std::cos(pose.theta), std::sin(pose.theta)), sensor_height, pw);
}

Eigen::Vector3d SensorFromWorld(const Pose2& pose, const Eigen::Vector2d& cos_sin, double sensor_height,
                                const Eigen::Vector3d& pw) {
  const double c = cos_sin.x(), s = cos_sin.y();
  const double dx = pw.x() - pose.x, dy = pw.y() - pose.y;
  return {c * dx + s * dy, -s * dx + c * dy, pw.z() - sensor_height};
}

Eigen::Vector3d WorldFromSensor(const Pose2& pose, double sensor_height, const Eigen::Vector3d& ps) {
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  return {pose.x + c * ps.x() - s * ps.y(), pose.y + s * ps.x() + c * ps.y(),
          ps.z() + sensor_height};
}

Eigen::Vector3d WorldDirection(const Pose2& pose, const Eigen::Vector3d& d) {
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  return {c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z()};
}

}  // namespace pano

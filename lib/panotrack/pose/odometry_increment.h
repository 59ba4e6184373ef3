// A relative motion of the robot between two times, as wheel odometry gives
// it: the control input of the motion model (track/motion_model.h), read from
// an odometry log by io/odometry.h. Shared here so that neither of those
// libraries depends on the other.
#pragma once

#include <Eigen/Core>

namespace pano {

struct OdometryIncrement {
  // Translation in the robot frame at the start of the interval (+x ahead
  // along the sensor's +x, +y to its left), in map units.
  double dx = 0.0;
  double dy = 0.0;
  // Heading change, counter-clockwise, radians; not wrapped (a whole turn
  // between two frames stays a whole turn).
  double dtheta = 0.0;
  // Covariance of (dx, dy, dtheta).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

}  // namespace pano

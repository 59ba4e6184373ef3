// The robot's pose on the floor, and the frames it relates: the world's and
// the sensor's (its origin the pinhole, its z axis the mirror's).
#pragma once

#include <Eigen/Core>

namespace pano {

// Robot pose on the floor: the pinhole's world (x, y) and the angle from world
// +x to sensor +x, counter-clockwise (README, "Files and conventions").
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;
};

// A world point in the sensor frame of a robot at `pose` whose pinhole is
// `sensor_height` above the floor.
Eigen::Vector3d SensorFromWorld(const Pose2& pose, double sensor_height, const Eigen::Vector3d& point_world);
// ... for many points seen from one pose: cos_sin = (cos, sin) of pose.theta.
Eigen::Vector3d SensorFromWorld(const Pose2& pose, const Eigen::Vector2d& cos_sin, double sensor_height,
                                const Eigen::Vector3d& point_world);
// A sensor-frame point in the world frame.
Eigen::Vector3d WorldFromSensor(const Pose2& pose, double sensor_height, const Eigen::Vector3d& point_sensor);
// Rotates a sensor-frame direction into the world frame.
Eigen::Vector3d WorldDirection(const Pose2& pose, const Eigen::Vector3d& dir_sensor);

}  // namespace pano

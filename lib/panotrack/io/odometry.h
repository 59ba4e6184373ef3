// Wheel odometry: the robot's dead-reckoned pose in its own odometry frame,
// read from a CSV log, and the increments between two frame times that the
// motion model (track/motion_model.h) takes as its control input.
//
// The CSV has the header `time,x,y,theta` and one sample a row: the time in
// seconds on the video's clock (strictly increasing), the position in the
// odometry's length unit (metres, or the map's units: OdometryOptions scales
// them) and the heading in radians, counter-clockwise. The odometry frame's
// origin and heading are arbitrary: only differences between samples are used.
#pragma once

#include <string>
#include <vector>

#include "panotrack/pose/odometry_increment.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

struct OdometrySample {
  double time_s = 0.0;
  Pose2 pose;
};

extern const char* const kOdometryCsvHeader;  // "time,x,y,theta"

// Reads an odometry CSV; a bad file throws pano::Error naming the file, the
// line and the problem. A file without samples is an error.
std::vector<OdometrySample> ReadOdometryCsv(const std::string& path);

// The increment's noise grows like a random walk, so that the covariances of
// consecutive increments add up to that of the whole: its variances are
// proportional to the distance travelled and the angle turned in between.
// The defaults suit wheel odometry in metres (5 cm after 1 m, 3 degrees after
// a radian of turning); scale the two length-based ones with the units.
struct OdometryOptions {
  // Map units per unit of the log's positions (100 for a log in metres and a
  // map in centimetres).
  double map_units_per_odometry_unit = 1.0;
  // Position variance (map units^2), along each robot axis, per map unit
  // travelled.
  double position_variance_per_distance = 0.05 * 0.05;
  // Heading variance (rad^2) per radian turned and per map unit travelled.
  double heading_variance_per_turn = 0.05 * 0.05;
  double heading_variance_per_distance = 0.01 * 0.01;
  // Throws pano::Error naming the first field that is negative or not finite
  // (or not positive, for the scale).
  void Check() const;
};

// The odometry pose at time t, interpolated linearly between the samples
// around it (the heading along the shorter arc). Throws pano::Error when t is
// outside the samples' times.
Pose2 OdometryPoseAt(const std::vector<OdometrySample>& samples, double t);

// The motion from t0 to t1 >= t0 in the robot frame at t0, in map units: the
// translation between the interpolated poses and the heading change summed
// over the samples in between (unwrapped: more than half a turn between two
// frames is kept). Throws pano::Error when t0 or t1 is outside the samples'
// times or t1 < t0.
OdometryIncrement Between(const std::vector<OdometrySample>& samples, double t0, double t1,
                          const OdometryOptions& options = {});

}  // namespace pano

// Trajectory files of the renderer's inputs: a robot's poses, one per
// frame, and a calibration board's poses, one per image.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

// Poses from a pose CSV (docs/panoloc.md, e.g. a gt.csv; every row must be
// ok) or a CSV with the header `x,y,theta` (radians) and one pose per line.
// Throws pano::Error naming the file and line.
std::vector<Pose2> ReadTrajectory(const std::string& path);

// Board poses from `rx,ry,rz,tx,ty,tz` lines after that header (angle-axis
// rotation, translation: board to sensor). Throws pano::Error naming the
// file and line.
std::vector<std::array<double, 6>> ReadBoardPoseRows(const std::string& path);

}  // namespace pano

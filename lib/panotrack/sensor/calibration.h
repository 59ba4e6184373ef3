// A calibrated sensor as the tools exchange it: the model, the map units and
// the E(D,Z) lookup table that belongs to it. io/calibration.h reads and
// writes it (README, "Files and conventions").
#pragma once

#include <Eigen/Core>

#include <map>
#include <string>
#include <vector>

#include "panotrack/sensor/sensor.h"

namespace pano {

// One calibration image's result, as panocalib writes it: how its board was
// found, how well the fit reprojects it, and the board's fitted pose.
struct CalibrationImage {
  std::string file;                 // as the target file names it (or "video.mp4#120")
  std::string method;               // "raw", "unwarped" (found in a virtual view) or "given"
  int corners = 0;                  // corners used
  double rms_px = 0.0;              // Euclidean RMS reprojection error of its corners
  Eigen::Vector3d rvec = Eigen::Vector3d::Zero();  // X_sensor = R(rvec) X_board + tvec
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
};

struct Calibration {
  Sensor sensor;
  std::string units = "cm";
  // Path of the E(D,Z) lookup table as written in the file ("" when absent),
  // and resolved against the calibration file's folder.
  std::string lut;
  std::string lut_resolved;
  // Optional extra keys written by panocalib (standard deviations, RMS...),
  // kept in order of name. Readers ignore keys they do not know.
  std::map<std::string, double> extras;
  // Per-image results keyed by file name (in the target file's order), the
  // images without a board, and what made the file.
  std::vector<CalibrationImage> images;
  std::vector<std::string> images_not_found;
  int images_total = 0;     // images given to the calibration (0: not recorded)
  std::string software;     // "panotrack 0.1.0"
  std::string command_line; // the command that wrote the file, shell-quoted
  std::string comment;      // written as a leading comment
};

}  // namespace pano

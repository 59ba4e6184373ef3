// Calibration file (spec section 3): the sensor model, written by panocalib,
// read by panoloc, panosim and the tests.
#pragma once

#include <map>
#include <string>

#include "sensor/sensor.h"

namespace pano {

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
  std::string comment;  // written as a leading comment
};

// Reads and checks a calibration file; throws pano::Error naming the file,
// the key and what was expected.
Calibration ReadCalibration(const std::string& path);
// Writes it atomically (temporary file renamed into place).
void WriteCalibration(const std::string& path, const Calibration& calib);
std::string CalibrationToYaml(const Calibration& calib);

}  // namespace pano

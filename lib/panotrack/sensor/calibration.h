// A calibrated sensor as the tools exchange it: the model, the map units and
// the E(D,Z) lookup table that belongs to it. io/calibration.h reads and
// writes it (spec section 3).
#pragma once

#include <map>
#include <string>

#include "panotrack/sensor/sensor.h"

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

}  // namespace pano

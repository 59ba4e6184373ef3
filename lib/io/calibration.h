// Calibration file (spec section 3): reads and writes sensor/calibration.h's
// Calibration (panocalib writes it; panoloc, panosim and the tests read it).
#pragma once

#include <string>

#include "sensor/calibration.h"

namespace pano {

// Reads and checks a calibration file; throws pano::Error naming the file,
// the key and what was expected.
Calibration ReadCalibration(const std::string& path);
// Writes it atomically (temporary file renamed into place).
void WriteCalibration(const std::string& path, const Calibration& calib);
std::string CalibrationToYaml(const Calibration& calib);

}  // namespace pano

// Calibration file (README, "Files and conventions"): reads and writes sensor/calibration.h's
// Calibration (panocalib writes it; panoloc, panosim and the tests read it).
#pragma once

#include <string>

#include "panotrack/sensor/calibration.h"

namespace pano {

// Image sizes a calibration may declare: each side 1..kMaxImageSide pixels
// and at most kMaxImagePixels in all (a 16384 x 16384 image); larger ones are
// taken for corrupt files rather than allocated.
constexpr int kMaxImageSide = 32768;
constexpr long long kMaxImagePixels = 16384LL * 16384LL;

// Reads and checks a calibration file; throws pano::Error naming the file,
// the key and what was expected.
Calibration ReadCalibration(const std::string& path);
// Writes it atomically (temporary file renamed into place).
void WriteCalibration(const std::string& path, const Calibration& calib);
std::string CalibrationToYaml(const Calibration& calib);

}  // namespace pano

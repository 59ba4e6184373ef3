// Calibration YAML (io/calibration.h), as panoloc --calib reads it.
#include "fuzz_input.h"
#include "panotrack/io/calibration.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pano::fuzz::ReadAsFile(data, size, ".yaml", [](const std::string& path) {
    const pano::Calibration c = pano::ReadCalibration(path);
    // What is read back must write out again.
    (void)pano::CalibrationToYaml(c);
  });
}

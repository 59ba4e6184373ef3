// Wheel odometry CSV (io/odometry.h), as panoloc --odometry reads it.
#include "fuzz_input.h"
#include "panotrack/io/odometry.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pano::fuzz::ReadAsFile(data, size, ".csv",
                                [](const std::string& path) { (void)pano::ReadOdometryCsv(path); });
}

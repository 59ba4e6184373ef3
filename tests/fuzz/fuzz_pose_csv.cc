// Pose CSV files (io/pose_csv.h): panoloc --gt, panomap --poses.
#include "fuzz_input.h"
#include "panotrack/io/pose_csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pano::fuzz::ReadAsFile(data, size, ".csv", [](const std::string& path) { (void)pano::ReadPoseCsv(path); });
}

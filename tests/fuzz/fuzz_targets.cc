// Calibration target files (io/targets.h), as panocalib calibrate reads them.
#include "fuzz_input.h"
#include "panotrack/io/targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pano::fuzz::ReadAsFile(data, size, ".yaml", [](const std::string& path) {
    const pano::TargetSet t = pano::ReadTargets(path);
    (void)pano::TargetsToYaml(t);
  });
}

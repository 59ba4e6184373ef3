// case.yaml's initial pose (io/case_file.h), read beside every panoloc input.
#include "fuzz_input.h"
#include "panotrack/io/case_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pano::fuzz::ReadAsFile(data, size, ".yaml",
                                [](const std::string& path) { (void)pano::ReadCaseInitialPose(path); });
}

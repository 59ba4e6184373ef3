// E(D,Z) lookup table files (lut/radius_table.h), binary, as the table cache
// and a calibration's lut: key load them.
#include "fuzz_input.h"
#include "panotrack/lut/radius_table.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pano::fuzz::ReadAsFile(data, size, ".lut",
                                [](const std::string& path) { (void)pano::RadiusTable::Load(path); });
}

// Map YAML (io/map.h), as panoloc --map reads it.
#include "fuzz_input.h"
#include "panotrack/io/map.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pano::fuzz::ReadAsFile(data, size, ".yaml", [](const std::string& path) {
    const pano::Map m = pano::ReadMap(path);
    (void)pano::MapToYaml(m, true);
  });
}

// Paths the tests need: the source tree (calib/, ../shared) and a scratch folder.
#pragma once

#include <filesystem>
#include <string>

#include "pano/config.h"

namespace pano::test {

inline std::string SourcePath(const std::string& rel) { return std::string(PANO_SOURCE_DIR) + "/" + rel; }

// A fresh scratch folder for one test, under the build's temporary dir.
inline std::string ScratchDir(const std::string& name) {
  namespace fs = std::filesystem;
  fs::path p = fs::temp_directory_path() / ("pano_test_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

}  // namespace pano::test

// Paths the tests need: the source tree (calib/, ../shared) and scratch folders.
#pragma once

#include <stdlib.h>  // mkdtemp (POSIX)

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace pano::test {

inline std::string SourcePath(const std::string& rel) {
  return std::string(PANO_TEST_SOURCE_DIR) + "/" + rel;
}

namespace internal {
struct ScratchRegistry {
  std::mutex mu;
  std::vector<std::string> dirs;
};
inline ScratchRegistry& Scratch() {
  static ScratchRegistry r;
  return r;
}
}  // namespace internal

// A new, empty scratch folder for one test, unique to this run:
// <temp dir>/pano_test_<name>_XXXXXX (mkdtemp), so that two runs on one
// machine never share one. The test main removes them after a run where
// nothing failed and leaves them for inspection otherwise.
inline std::string ScratchDir(const std::string& name) {
  const std::filesystem::path pattern =
      std::filesystem::temp_directory_path() / ("pano_test_" + name + "_XXXXXX");
  std::string buf = pattern.string();
  if (!mkdtemp(buf.data()))
    throw std::runtime_error("ScratchDir: cannot create " + pattern.string() + ": " + std::strerror(errno));
  internal::ScratchRegistry& r = internal::Scratch();
  std::lock_guard<std::mutex> lock(r.mu);
  r.dirs.push_back(buf);
  return buf;
}

// Removes every scratch folder this process created (best effort).
inline void RemoveScratchDirs() {
  internal::ScratchRegistry& r = internal::Scratch();
  std::lock_guard<std::mutex> lock(r.mu);
  for (const std::string& d : r.dirs) {
    std::error_code ec;
    std::filesystem::remove_all(d, ec);
  }
  r.dirs.clear();
}

}  // namespace pano::test

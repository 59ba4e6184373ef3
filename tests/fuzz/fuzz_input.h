// What every fuzz target shares: the input as a file (the readers take a
// path), and the rule that a reader refuses bad input with pano::Error alone.
// Any other exception escapes LLVMFuzzerTestOneInput and libFuzzer reports
// it as a crash, as it does sanitizer reports and hangs.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "panotrack/core/error.h"

namespace pano::fuzz {

// Writes the input to a file of this process (in $TMPDIR, else /tmp, named
// with `extension`, which some readers look at) and returns its path.
inline std::string AsFile(const uint8_t* data, size_t size, const char* extension) {
  static const std::string path = [extension] {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir && *dir ? dir : "/tmp") + "/pano_fuzz_" + std::to_string(::getpid()) + extension;
  }();
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();  // the harness, not the reader, failed
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

// Runs `read` on the input written as a file; pano::Error is the expected
// answer to bad input.
template <typename Read>
int ReadAsFile(const uint8_t* data, size_t size, const char* extension, Read read) {
  const std::string path = AsFile(data, size, extension);
  try {
    read(path);
  } catch (const Error&) {
  }
  return 0;
}

}  // namespace pano::fuzz

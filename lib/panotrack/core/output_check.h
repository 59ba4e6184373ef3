// The programs' one rule for existing outputs: a file is replaced only when
// the user says so (--force). Checked for every planned output before any
// work starts, so that a refused run leaves nothing half done.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "panotrack/core/error.h"

namespace pano {

// True when writing `path` would replace a file the user has: a regular file
// (or a link to one) is there. Standard output ("-") and special files
// (/dev/null, FIFOs), which are written in place, are never replaced.
inline bool WouldReplaceFile(const std::string& path) {
  if (path.empty() || path == "-") return false;
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}

// Unless `overwrite`, throws pano::Error "PATH exists (use --force to replace
// it)" for the first of `paths` that would replace a file. Empty paths are
// outputs not asked for.
inline void RefuseToReplace(const std::vector<std::string>& paths, bool overwrite) {
  if (overwrite) return;
  for (const std::string& p : paths)
    if (WouldReplaceFile(p)) throw Error(p + " exists (use --force to replace it)");
}

}  // namespace pano

// The programs' one rule for existing outputs: a file is replaced only when
// the user says so (--force). Checked for every planned output before any
// work starts, so that a refused run leaves nothing half done.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
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

// True for outputs written in place rather than through a temporary file:
// standard output ("-"), /dev and /proc paths, existing special files
// (FIFOs, character devices).
bool WritesInPlace(const std::string& path);

// True when both paths name one file: std::filesystem::equivalent where both
// exist, else the same absolute path once symlinks and dots are resolved.
bool SameFile(const std::string& a, const std::string& b);

// (option, path) pairs, e.g. {"-o", "out.csv"}; empty paths are ignored.
// For a read, the first of the pair says where the file comes from, e.g.
// "--calib", or "a frame of frames/" for each file of an input that reads
// many.
using NamedPaths = std::vector<std::pair<std::string, std::string>>;

// Throws pano::Error naming the option, the output and the input when an
// output is a file the run reads, or two outputs are one file. Files are
// compared by identity (device and inode: links, hard links and other
// spellings of one file are one file), by their resolved path where either
// does not exist yet. Outputs written in place (WritesInPlace) and URLs are
// not compared. --force never lifts this: no option lets a run replace its
// own input.
void CheckOutputsDistinct(const NamedPaths& reads, const NamedPaths& writes);

// Throws pano::Error naming the option when `dir`, an output folder that the
// run replaces as a whole (everything in it is deleted), is or holds one of
// the reads.
void CheckFolderOutputHoldsNoInput(const NamedPaths& reads, const std::string& option, const std::string& dir);

// Creates the output folder `dir` (given by `option`) and its parents where
// missing. Throws pano::Error naming the option and the folder where a file
// stands in the way or the folder cannot be made.
void CreateOutputFolder(const std::string& dir, const std::string& option);

// Both checks every program runs on its planned outputs before any work:
// CheckOutputsDistinct, then RefuseToReplace unless `overwrite`.
void CheckPlannedOutputs(const NamedPaths& reads, const NamedPaths& writes, bool overwrite);

}  // namespace pano

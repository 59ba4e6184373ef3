// Where panoloc's outputs go: one name per input under --out-dir, and the
// checks that no output overwrites an input of the run or another output.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace pano {

// One CSV path per input under `out_dir`: `<name>.csv`, the name being the
// input's file or folder name without extension ("-": stdin); for a file
// named video.* (as panosim writes) and for printf patterns the folder's name
// comes first (seq/video.mp4 -> seq_video). Inputs whose names coincide get
// more of their folders in front until they differ (a/run.mp4, b/run.mp4 ->
// a_run, b_run). Throws pano::Error when two inputs cannot be told apart that
// way (the same input twice, a/run.mp4 and a/run.mkv).
std::vector<std::string> OutputPathsInDir(const std::vector<std::string>& inputs, const std::string& out_dir);

// True when both paths name one file: std::filesystem::equivalent where both
// exist, else the same absolute path once symlinks and dots are resolved.
bool SameFile(const std::string& a, const std::string& b);

// (option, path) pairs, e.g. {"-o", "out.csv"}; empty paths are ignored.
using NamedPaths = std::vector<std::pair<std::string, std::string>>;

// Throws pano::Error naming the option when an output is a file the run
// reads, or two outputs are one file. Standard streams ("-") and special
// files (/dev/null) are not compared.
void CheckOutputsDistinct(const NamedPaths& reads, const NamedPaths& writes);

}  // namespace pano

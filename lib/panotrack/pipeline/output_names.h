// Where panoloc's outputs go: one name per input under --out-dir, and the
// checks that no output overwrites an input of the run or another output.
#pragma once

#include <string>
#include <vector>

#include "panotrack/core/output_check.h"

namespace pano {

// One CSV path per input under `out_dir`: `<name>.csv`, the name being the
// input's file or folder name without extension ("-": stdin); for a file
// named video.* (as panosim writes) and for printf patterns the folder's name
// comes first (seq/video.mp4 -> seq_video). Inputs whose names coincide get
// more of their folders in front until they differ (a/run.mp4, b/run.mp4 ->
// a_run, b_run). Non-ASCII characters are kept (UTF-8); other characters
// than letters, digits, '-', '_' and '.' become '_', bytes that are not
// UTF-8 '_' and their hex digits. Throws pano::Error when two inputs cannot be told apart that
// way (the same input twice, a/run.mp4 and a/run.mkv).
std::vector<std::string> OutputPathsInDir(const std::vector<std::string>& inputs, const std::string& out_dir);


}  // namespace pano

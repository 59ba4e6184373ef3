// panocalib unwarp's job over files: a raw image or a video unwarped
// through a calibration file (unwarp/unwarp.h does the unwarping).
#pragma once

#include <string>

#include "panotrack/unwarp/unwarp.h"

namespace pano {

// panocalib unwarp: reads the calibration and the image (any depth, grey or
// colour), writes the view atomically to `out_path` (refusing to replace an
// existing file unless `overwrite`). Returns the view for a summary.
UnwarpView UnwarpImageFile(const std::string& calib_path, const std::string& image_path,
                           const std::string& out_path, const UnwarpOptions& options, bool overwrite);

// True when `path` names a video by its extension (.mp4, .avi, .mkv, .mov).
bool IsVideoPath(const std::string& path);

// The same for every frame of a video (or anything FrameSource reads: an
// image folder, a printf pattern), as 8-bit grey, written as an MPEG-4 video
// at the input's frame rate (10 fps when it has none). Video codecs need even
// sizes: a default side that comes out odd is made one pixel larger, a given
// odd side is refused. Returns
// the view; `frames` (optional) receives the number of frames written.
UnwarpView UnwarpVideoFile(const std::string& calib_path, const std::string& input_path,
                           const std::string& out_path, const UnwarpOptions& options, bool overwrite,
                           int* frames = nullptr);

struct UnwarpJob {
  std::string calibration;  // calibration YAML
  std::string input;        // an image; with a video output, anything FrameSource reads
  std::string output;       // an image, or a video by its extension (IsVideoPath)
  UnwarpOptions options;
  bool overwrite = false;   // replace an existing output
};
struct UnwarpResult {
  UnwarpView view;
  int frames = -1;  // frames written to a video output; -1: an image
};
// The image or the video form, chosen by the output's extension.
UnwarpResult RunUnwarp(const UnwarpJob& job);

}  // namespace pano

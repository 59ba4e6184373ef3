// The board images a calibration reads: a target file, a folder of images or
// a video (panocalib calibrate and evaluate, the Python module), loaded and
// checked before any fitting.
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "panotrack/core/output_check.h"
#include "panotrack/io/targets.h"

namespace pano {

// Loads the images (grey; a video's frames read front to back) and checks
// that they exist and share one size.
std::vector<cv::Mat> LoadTargetImages(const TargetSet& targets);

// The board and settings for an input without a target file.
struct TargetInputBoard {
  bool board_given = false;  // --board was given
  TargetBoard board;
  std::string units = "cm";  // the target file's default
  int every = 0;             // a video's frame step; 0: about 30 frames
};
// The calibration input `path`: a target file (.yaml/.yml: the board comes
// from it, so none may be given), a folder of images (natural order) or a
// video (sampled every `every` frames), both with the board given (io/targets.h:
// ClassifyTargetInput, TargetsFromFolder, TargetsFromVideoFrames). Throws
// pano::Error naming --board or the path.
TargetSet ReadTargetInput(const std::string& path, const TargetInputBoard& input);
// The files a calibration input reads, for the output guard
// (CheckOutputsDistinct): `path` itself under `option`, and each board image
// or video that `targets` (read from `path`) names, as "a board image of
// <path>".
NamedPaths TargetInputReads(const std::string& path, const TargetSet& targets, const std::string& option = "");
// Frames in a video, counted by reading it (containers' counts are estimates).
int CountVideoFrames(const std::string& path);

}  // namespace pano

// Calibration target file (README, "Files and conventions"): chessboard images, with board
// poses when they are known.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "panotrack/scene/target_board.h"

namespace pano {

struct TargetImage {
  std::string file;           // as written (a video's frame: "<video file name>#<frame index>")
  std::string resolved;       // relative to the target file's folder (a video's frame: the video)
  bool has_pose = false;
  std::array<double, 3> rvec{};  // X_sensor = R(rvec) X_board + tvec
  std::array<double, 3> tvec{};
  int frame = -1;  // >= 0: this frame of the video `resolved`
};

struct TargetSet {
  std::string units = "cm";
  TargetBoard board;
  std::vector<TargetImage> images;
  // True when every image has a pose (known targets).
  bool AllPosesKnown() const;
};

TargetSet ReadTargets(const std::string& path);
// Writes atomically; `with_poses` false leaves rvec/tvec out.
void WriteTargets(const std::string& path, const TargetSet& set, bool with_poses = true);
std::string TargetsToYaml(const TargetSet& set, bool with_poses = true);

// --- Calibration input without a target file: a folder of images or a
// video, and the board given on the command line.

// "7x11" (a chessboard) or "charuco:7x11": inner corners, cols x rows (the
// target file's board.cols and board.rows); the square (and for ChArUco the
// marker and dictionary) as given. Throws pano::Error naming --board.
TargetBoard ParseBoardSpec(const std::string& spec, double square, double marker = 0.0,
                           const std::string& dictionary = "DICT_4X4_50");

// Natural order: digit runs compare as numbers (image_2 before image_10),
// the rest byte by byte; ties (image_01, image_1) by the plain text.
bool NaturalLess(const std::string& a, const std::string& b);

enum class TargetInputKind { kTargetFile, kImageFolder, kVideo };
// A path ending in .yaml or .yml (any case) is a target file, a folder is a
// folder of images, anything else a video. Throws when a folder or video
// does not exist.
TargetInputKind ClassifyTargetInput(const std::string& path);

// The images of a folder (png, jpg, jpeg, bmp, tif, tiff, pgm, ppm, webp; any
// case), in natural order, no poses. Throws when there is none.
TargetSet TargetsFromFolder(const std::string& dir, const TargetBoard& board, const std::string& units);

// Frames 0, every, 2 every... of a video of `frame_count` frames; every 0:
// the step that takes about 30 frames (ceil(frame_count / 30)). Each frame is
// named "<video file name>#<frame index>".
TargetSet TargetsFromVideoFrames(const std::string& video, int frame_count, int every, const TargetBoard& board,
                                 const std::string& units);
// The default frame step for a video of `frame_count` frames.
int DefaultFrameStep(int frame_count);

}  // namespace pano

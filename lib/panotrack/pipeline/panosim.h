// panosim's jobs over files: a still, a test sequence with its ground truth,
// and calibration images, each one function the program calls with the
// options it parsed (render/ draws the images and writes the folders).
// Internal, as the renderer is: built with the toolkit, not installed.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "panotrack/pose/pose2.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/render/targets_render.h"
#include "panotrack/render/writers.h"

namespace pano {

// The user's changes over a preset's or the files' sensor and rendering
// options (rig faults, blur, noise...), applied before anything is drawn;
// empty: none.
struct RenderAdjustments {
  std::function<void(Sensor*)> sensor;
  std::function<void(RenderOptions*)> options;
  int num_threads = 0;  // rendering threads (0: every core)
};

// panosim still: one frame to a PNG, of a preset or of a map, a calibration
// and a pose.
struct StillJob {
  std::string preset;        // a built-in case; empty: the three below
  int frame = 0;             // the preset's frame whose pose is rendered
  std::string map_path, calib_path;
  std::optional<Pose2> pose;
  std::string output;        // PNG
  bool overwrite = false;    // replace an existing output
  RenderAdjustments adjust;
};
void RunStill(const StillJob& job);

// panosim sequence: a video and its ground truth in a folder (render/writers.h
// WriteSequence), of a preset or of a map, a calibration and a trajectory.
struct SequenceJob {
  std::string preset;  // a built-in case; empty: the three files below
  std::string map_path, calib_path, trajectory_path;
  std::optional<double> fps;  // none: the preset's; 10 frames/s for files
  // The survey error of the map written; its sigma and seed the preset's
  // unless given.
  SurveyError survey;
  std::optional<double> survey_sigma;
  std::optional<uint64_t> survey_seed;
  std::string output;  // folder, replaced as a whole
  SequenceWriteOptions write;
  RenderAdjustments adjust;
};
SequenceWriteResult RunSequence(const SequenceJob& job);

// panosim targets: chessboard (or ChArUco) images with their target files,
// the board's poses read from a file or placed automatically.
struct TargetsJob {
  std::string preset, calib_path;  // the sensor: a preset's, else the file's
  TargetBoard board;               // checked (CheckTargetBoard)
  std::string board_poses_path;    // the poses file; or:
  std::optional<int> auto_count;   // this many poses placed (AutoBoardPoses)
  double min_visible = 1.0;        // of each auto board's inner corners in view
  std::string output;              // folder, replaced as a whole
  TargetsWriteOptions write;
  RenderAdjustments adjust;
  // A pose from the file whose board is not wholly in view (the file's line).
  std::function<void(const std::string&)> on_warning;
};
void RunTargets(const TargetsJob& job);

}  // namespace pano

// The sensor's tilt from the robot's vertical, measured from video in a
// mapped room. A tilted mirror axis makes the bearings of one frame
// disagree (a vertical edge no longer images along a radius), so the tilt
// is the one under which the tracked frames' bearings fit their poses best:
// the mean RMS bearing residual of the tracked frames is minimised over the
// two tilt angles (Nelder-Mead), each trial tracking the frames through the
// aligned view of the rig with that tilt (track/aligned_view.h).
//
// What the board calibration left of the mirror's misalignment looks the
// same to the bearings and is taken into the tilt too.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "panotrack/io/calibration.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/scene/map.h"
#include "panotrack/sensor/sensor.h"
#include "panotrack/track/localizer.h"

namespace pano {

struct SensorTiltOptions {
  int max_frames = 60;             // frames used, from the start of the video
  double search_deg = 0.5;         // first step of the search (degrees)
  double tolerance_deg = 0.005;    // the search stops when its steps are this small
  int max_trials = 80;             // tracking runs at most
  std::optional<Pose2> init;       // pose at the first frame; none: the room-wide search
  // Also the mirror's offset from the camera's axis (mirror_offset): what
  // the boards determine least well, and what bearings see best.
  bool fit_decentre = false;
  LocalizerOptions localizer;      // how each trial tracks
  // Called after each trial: trials so far, the best parameters so far
  // (the tilt in radians, about x then y; then, with fit_decentre, the
  // mirror offset in radians of view from the pinhole) and its residual
  // (radians).
  std::function<void(int, const double*, double)> on_trial;
  // Throws pano::Error naming the field that is wrong.
  void Check() const;
};

struct SensorTiltResult {
  double tilt[2] = {0.0, 0.0};     // sensor_tilt (radians, about x then y)
  double mirror_offset[2] = {0.0, 0.0};  // mirror_offset (map units; the calibration's unless fit_decentre)
  double residual_before = 0.0;    // mean RMS bearing residual with the calibration's tilt (rad)
  double residual_after = 0.0;     // ... with the tilt found
  int frames = 0;                  // frames used
  int tracked_before = 0;          // of them tracked with the calibration's tilt
  int tracked_after = 0;           // ... with the tilt found
  int trials = 0;
};

// Measures the tilt from `frames` (grey, the calibration's size) of a
// mapped room. Throws pano::Error when too few frames are tracked to judge
// (fewer than 5 with any tilt tried).
SensorTiltResult EstimateSensorTilt(const Calibration& calib, const Map& map, const std::vector<cv::Mat>& frames,
                                    const SensorTiltOptions& options);

// The same from a video (or any input FrameSource reads): its first
// options.max_frames frames.
SensorTiltResult EstimateSensorTilt(const Calibration& calib, const Map& map, const std::string& input,
                                    const SensorTiltOptions& options);

}  // namespace pano

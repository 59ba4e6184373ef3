// Test cases for panosim: a map, a sensor, a trajectory and render options.
// The presets reproduce the seed paper's experiments (Fiala & Basu, sections
// 3.1 and 4.3) and add harder cases; they are the localiser's test data.
#pragma once

#include <string>
#include <vector>

#include "panotrack/sensor/calibration.h"
#include "panotrack/scene/map.h"
#include "panotrack/render/render.h"

namespace pano {

struct SequenceCase {
  std::string name;         // preset name, or "custom"
  std::string description;  // one line
  Calibration calib;
  Map map;                  // with distractors (they are left out of the written map)
  std::vector<Pose2> poses;  // one per frame
  double fps = 10.0;
  RenderOptions options;
  std::vector<int> kidnap_frames;  // first frames after sudden jumps of the pose (ascending)
  // Survey error of the map handed to the localiser (render/sequence.h
  // PerturbedMap): 0 writes the true map as map.yaml; above 0 map.yaml is
  // the perturbed map and map_true.yaml the true one.
  double map_sigma = 0.0;
  uint64_t map_seed = 1;
};

// Names of the built-in presets: paper-synthetic, paper-real, cluttered, kidnap,
// fast-turns, motion-blur, real-conditions, long-run, long-run-blur, faulty-rig,
// faulty-rig-2x, paper-real-map-error, paper-synthetic-map-error.
std::vector<std::string> PresetNames();
// Throws pano::Error "preset 'x': unknown (expected one of ...)".
SequenceCase MakePreset(const std::string& name);

// A case from files: map, calibration and a trajectory file. The trajectory is
// either a pose CSV (spec section 5, e.g. a gt.csv; every row must be ok) or a
// CSV with the header `x,y,theta` (radians) and one pose per line. Checks that
// every pose is inside the room and not inside a box, naming the file and line.
SequenceCase MakeCase(const std::string& map_path, const std::string& calib_path,
                      const std::string& trajectory_path, double fps);
std::vector<Pose2> ReadTrajectory(const std::string& path);

// Checks a case: sensor, map, options, and every pose (CheckPose with
// `clearance`); `what` names its origin in messages.
void CheckCase(const SequenceCase& c, const std::string& what, double clearance = 0.0);

// Smooth path through `waypoints` (Catmull-Rom), resampled to `n` poses
// equally spaced along its length, heading along the path plus
// `heading_offset`. Throws on fewer than 2 waypoints or n < 2.
std::vector<Pose2> SmoothPath(const std::vector<Eigen::Vector2d>& waypoints, int n,
                              double heading_offset = 0.0);

// The built-in sensors (equal to calib/paper-real.yaml and calib/paper-synthetic.yaml).
Calibration PaperRealCalibration();
Calibration PaperSyntheticCalibration();

}  // namespace pano

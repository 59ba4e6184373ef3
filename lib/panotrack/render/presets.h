// Test cases for panosim: a map, a sensor, a trajectory and render options.
// The presets reproduce the seed paper's experiments (Fiala & Basu, sections
// 3.1 and 4.3) and add harder cases; they are the localiser's test data.
#pragma once

#include <string>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/calibration.h"
#include "panotrack/scene/map.h"
#include "panotrack/render/render.h"

namespace pano {

// The errors of a survey of the room: map.yaml is the room as such a survey
// measured it (render/sequence.h SurveyMap), map_true.yaml the room rendered.
struct SurveyError {
  // Each rectangle end point (x, y), height and box coordinate moved by its
  // own Gaussian error of this sigma (map units).
  double sigma = 0.0;
  // Each rectangle and box moved as a whole by a Gaussian error of this
  // sigma in x and in y: placed from one reference measurement that was off.
  double offset_sigma = 0.0;
  // Rectangles with a gross fault, in turn: moved by gross_offset, in the
  // map but not in the room, in the room but not in the map.
  int gross = 0;
  double gross_offset = 0.0;  // map units; 0: 8 cm in the map's units
  uint64_t seed = 1;
  bool any() const { return sigma > 0.0 || offset_sigma > 0.0 || gross > 0; }
  // Throws pano::Error naming the panosim option that is out of range.
  void Check() const;
};

struct SequenceCase {
  std::string name;         // preset name, or "custom"
  std::string description;  // one line
  Calibration calib;
  Map map;                  // with distractors (they are left out of the written map)
  std::vector<Pose2> poses;  // one per frame
  double fps = 10.0;
  RenderOptions options;
  std::vector<int> kidnap_frames;  // first frames after sudden jumps of the pose (ascending)
  // Survey error of the map handed to the localiser: none writes the true
  // map as map.yaml; else map.yaml is the surveyed map and map_true.yaml
  // the true one.
  SurveyError survey;
};

// Names of the built-in presets: paper-synthetic, paper-real, cluttered, kidnap,
// fast-turns, motion-blur, real-conditions, long-run, long-run-blur, faulty-rig,
// faulty-rig-2x, paper-real-map-error, paper-synthetic-map-error.
std::vector<std::string> PresetNames();
// Throws pano::Error "preset 'x': unknown (expected one of ...)".
SequenceCase MakePreset(const std::string& name);

// A case from files: map, calibration and a trajectory file. The trajectory is
// either a pose CSV (docs/panoloc.md, e.g. a gt.csv; every row must be ok) or a
// CSV with the header `x,y,theta` (radians) and one pose per line. Checks that
// every pose is inside the room and not inside a box, naming the file and line
// (the trajectory is read by io/trajectory.h's ReadTrajectory).
SequenceCase MakeCase(const std::string& map_path, const std::string& calib_path,
                      const std::string& trajectory_path, double fps);

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

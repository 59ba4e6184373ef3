// Checking a room's landmark map against what the camera sees (panomap check).
//
// For each frame, every landmark the map predicts in view (track/landmarks.h)
// is looked for in a window around its predicted edges, with either polarity:
// the vertical edge (its image azimuth: the bearing the localiser uses) and
// the horizontal edge (its image radius). Over the run each vertical edge of
// the map (a rectangle's "from" or "to" end, a box's corner) gathers how
// often it was in view and found, whether its step had the polarity the
// map's shades imply, and the mean and spread of its bearing residual.
// Those figures become findings: never found (not in the room, or moved far),
// wrong polarity (shade inverted), biased (corner mis-measured). Rectangles
// the camera sees that the map lacks are found as panomap build finds new
// ones (mapping/build.h), seeded with the whole map: not in the map, or (near
// a mapped rectangle with a finding) where that one really stands.
//
// The residuals are measured from the frame's pose: a given one (ground
// truth, a pose CSV) or one solved from the bearings of every other map
// object's edges in that frame (the object held out), so that a
// mis-measured landmark cannot pull the pose towards itself.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "panotrack/lut/radius_table.h"
#include "panotrack/mapping/build.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/scene/map.h"
#include "panotrack/scene/scene.h"
#include "panotrack/sensor/calibration.h"
#include "panotrack/sensor/sensor.h"
#include "panotrack/track/landmarks.h"

namespace pano {

struct MapCheckOptions {
  PredictionOptions prediction;
  // Half-width (px, across the edge) of the window searched around each
  // predicted edge: a corner mis-measured by more than this at its image
  // radius reads as not found.
  double search_px = 12.0;
  // ... but no further than 0.45 of the way to the nearest other predicted
  // vertical edge; an edge with less than this (px) either side is not
  // judged in that frame.
  double min_window_px = 2.5;
  double min_step = 10.0;          // grey levels: the weakest edge counted
  double sample_spacing_px = 3.0;  // between the samples along an edge
  double corner_gap_px = 3.0;      // samples start this far from the corner
  int max_samples = 24;            // per edge
  // An edge is found when at least this fraction of its samples (and 3)
  // show a step within 1.5 px of their median offset.
  double min_sample_fraction = 0.5;
  // Findings. An edge in view on fewer than min_visible_frames frames (or
  // than all the frames with a pose, when fewer) is not judged.
  int min_visible_frames = 3;
  double min_found_fraction = 0.5;     // below: "never found"
  double min_polarity_agreement = 0.5; // below (of the frames found): "wrong polarity"
  // Biased: |mean residual| > bias_sigmas * std / sqrt(n) and > bias_floor_deg
  // (and beyond bias_survey_sigmas of the survey, below).
  double bias_sigmas = 4.0;
  double bias_floor_deg = 0.1;
  // ... and, when the map states how well the object was surveyed (its
  // survey_sigma, else the map's), further across the line of sight than
  // this many survey sigmas: a measured map's corners are all a little off,
  // and only the ones off by more than the survey's error are mis-measured.
  double bias_survey_sigmas = 4.0;
  int min_found_frames_for_bias = 3;
  // Self-localised poses: bearings further than this from a held-out solve
  // are left out of it (radians).
  double hold_out_outlier = 1.0 * M_PI / 180;
  // Rectangles in the room but not in the map (AddUnmappedFindings): looked
  // for with these options of panomap build, unless off.
  bool find_unmapped = true;
  MapBuildOptions unmapped;
  // ... from the frames whose median bearing residual of the map's edges is
  // within this (radians): a pose that does not fit the map misplaces them.
  double unmapped_pose_residual = 0.3 * M_PI / 180;
  void Check() const;
};

// One vertical edge of the map, as measured in one frame.
struct EdgeFrameMeasurement {
  int edge = -1;                 // into MapCheckReport::edges
  int landmark = -1;             // the corner predicted (into the landmark list)
  bool found = false;
  int expected_polarity = 0;     // +1: the face brighter than beyond it (map)
  int measured_polarity = 0;     // the same, seen; 0 when not found
  double predicted_azimuth = 0;  // image azimuth (radians)
  double measured_azimuth = 0;
  bool has_residual = false;     // found, and a pose to measure the residual from
  double bearing_residual = 0;   // measured - predicted (radians)
  bool horizontal_found = false;
  double radial_residual_px = 0; // horizontal edge: measured - predicted image radius
  double distance = 0;           // horizontal distance to the corner (map units)
  double beyond_shade = 0;       // the map's shade seen just beyond the vertical edge
  double brightness_ratio = -1;  // the face's grey over the grey beyond it (-1: unknown)
  // For the overlay: the predicted edges (image points): the vertical one
  // and the horizontal one at each corner in view.
  Eigen::Vector2d corner_px{0, 0}, v_end_px{0, 0};
  std::vector<std::vector<Eigen::Vector2d>> h_curves;
};

struct FrameCheck {
  int frame = 0;
  bool has_pose = false;  // false: lost (nothing predicted)
  Pose2 pose;
  std::vector<EdgeFrameMeasurement> edges;
};

enum class MapFinding { kNeverFound, kWrongPolarity, kBiased, kNotInMap };
const char* MapFindingName(MapFinding f);

// One vertical edge of the map over the run.
struct EdgeCheck {
  std::string object;  // the map rectangle's or box's id
  std::string id;      // "<object>/from", "<object>/to", "<box>/x0y1"
  bool box = false;
  Eigen::Vector2d position{0, 0};  // world (x, y) of the edge
  double shade = 0.0;              // the map's shade of its object
  int visible = 0, found = 0;      // frames predicted in view, found
  int polarity_agree = 0;          // of the frames found
  int radial_found = 0;
  double found_fraction = 0.0, polarity_fraction = 0.0;
  int residual_frames = 0;              // frames with a residual (found, with a pose)
  double mean_residual_deg = 0.0, std_residual_deg = 0.0;
  double mean_radial_px = 0.0, std_radial_px = 0.0;
  double mean_distance = 0.0;           // map units
  double beyond_shade = 0.0;            // mean shade the map puts just beyond the edge
  // The face's shade as seen: its brightness against what lies beyond,
  // times beyond_shade (-1: never found).
  double seen_shade = -1.0;
  std::vector<MapFinding> findings;
};

// One finding per map object (rectangle or box), in words.
struct ObjectFinding {
  std::string object;
  MapFinding kind = MapFinding::kNeverFound;
  std::string message;
};

struct MapCheckReport {
  std::vector<EdgeCheck> edges;
  std::vector<ObjectFinding> findings;
  int frames = 0;
  int frames_with_pose = 0;
  int frames_with_landmarks = 0;  // frames with at least one edge predicted in view
  // Edges in view on fewer frames are not judged: the option, or every
  // frame with a pose when there are fewer (a single image).
  int min_visible_frames = 1;
  std::string units;
};

// The map's vertical edges (one per rectangle end, one per box corner), in
// map order, and the index of each landmark's edge.
std::vector<EdgeCheck> MapEdges(const std::vector<Landmark>& landmarks, std::vector<int>* edge_of_landmark);

// Measures one grey frame from `pose`. Fills the predicted and measured
// edges (no residuals yet: SetResiduals).
class FrameChecker {
 public:
  FrameChecker(const Calibration& calib, const Map& map, std::shared_ptr<const RadiusTable> table,
               const MapCheckOptions& options);
  const std::vector<EdgeCheck>& edges() const { return edges_; }
  const std::vector<Landmark>& landmarks() const { return landmarks_; }
  // Predicts from `pose` and measures each edge in view.
  FrameCheck Measure(const cv::Mat& grey, int frame, const Pose2& pose) const;
  // Bearing residuals from the frame's own pose (given poses).
  void SetResiduals(FrameCheck* fc) const;
  // Bearing residuals of each object's edges from the pose solved from the
  // other objects' bearings (self-localised poses); an object whose held-out
  // solve fails gets no residuals in this frame.
  void SetHeldOutResiduals(FrameCheck* fc) const;

 private:
  // Measure's steps (check.cc): the search window of a vertical edge, the
  // vertical edge sampled along its radial segment, and the horizontal edge
  // at a corner sampled radially along its nearer half.
  double WindowPx(const PredictedLandmark& p, const std::vector<PredictedLandmark>& predicted) const;
  bool MeasureVerticalEdge(const cv::Mat& grey, const Pose2& pose, const PredictedLandmark& p, double half,
                           EdgeFrameMeasurement* m) const;
  bool MeasureHorizontalEdge(const cv::Mat& grey, const Pose2& pose, const PredictedLandmark& p,
                             EdgeFrameMeasurement* m, double* radial_offset) const;

  Calibration calib_;
  Map map_;
  Scene scene_;
  std::shared_ptr<const RadiusTable> table_;
  MapCheckOptions opt_;
  std::vector<Landmark> landmarks_;
  std::vector<EdgeCheck> edges_;
  std::vector<int> edge_of_landmark_;
};

// The run's figures and findings from its frames.
MapCheckReport SummarizeMapCheck(const Map& map, std::vector<EdgeCheck> edges,
                                 const std::vector<FrameCheck>& frames, const MapCheckOptions& options);

// Whether the map's edges fit the frame's pose: at least 3 found with a
// residual, their median |bearing residual| within `limit` (radians). A
// pose centimetres off (the localiser on a faulty map) would place the edges
// the map lacks wrong: such frames are left out of the search for them.
bool PoseFitsTheMap(const FrameCheck& fc, double limit);

// The rectangles that `built` (a MapBuilder seeded with `map`, fed the
// checked frames) found. One that stands where a mapped rectangle does
// (both ends within the tolerance: a rectangle seen from where the map does
// not predict it, from behind) is that one. One that is a mapped rectangle
// with a finding shifted as a whole (by up to a tenth of the map's size)
// shows where that one stands: its finding says so. Any other is a finding
// of its own, kNotInMap, named "unmapped-<k>". The tolerance is 1 % of the
// map's size, or 3 survey sigmas when larger.
void AddUnmappedFindings(const Map& map, const MapBuildResult& built, MapCheckReport* report);

// The table panomap check prints (one row per edge), and its findings.
std::string FormatMapCheckTable(const MapCheckReport& report);

}  // namespace pano

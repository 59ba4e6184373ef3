// Landmarks of a map and their predicted projections (paper section 4.2).
//
// A landmark is a corner of a rectangle or a box: the junction of a
// horizontal and a vertical edge. Ids: "<map id>/<end>-<bottom|top>" for a
// rectangle, where end is "from" or "to" (the rectangle's bottom-edge end
// points in the map file); "<box id>/<x0|x1><y0|y1>-<bottom|top>-<x|y>" for a
// box, the last letter naming the axis of its horizontal edge. A box corner
// is usable only where its vertical edge is a silhouette and the face that
// holds its horizontal edge faces the camera.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/scene/map.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/scene/scene.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

struct Landmark {
  std::string id;
  Eigen::Vector3d corner{0, 0, 0};  // world
  Eigen::Vector3d h_end{0, 0, 0};   // other end of the horizontal edge
  Eigen::Vector3d v_end{0, 0, 0};   // other end of the vertical edge
  double shade = 0.5;               // reflectance of the landmark's own face; NaN: unknown
  bool box = false;
  int object = -1;                  // its rectangle (0..) or box (after the rectangles) in the map
  // The standard deviation of each coordinate of the corner as surveyed
  // (map units; Map::survey_sigma); NaN: not stated.
  double survey_sigma = std::nan("");
  // For box corners: the face holding both edges faces the camera when
  // (camera - corner) . face_normal > 0; the other face at the vertical edge
  // must face away (silhouette).
  Eigen::Vector2d face_normal{0, 0};
  Eigen::Vector2d other_face_normal{0, 0};
};

std::vector<Landmark> LandmarksFromMap(const Map& map);

// Everything the trackers need about one landmark in one frame.
struct PredictedLandmark {
  int index = -1;              // into the landmark list
  const Landmark* landmark = nullptr;
  Eigen::Vector2d corner_px{0, 0};
  double corner_radius = 0.0;  // image polar coordinates of the corner
  double azimuth = 0.0;        // image azimuth of the vertical edge
  double distance = 0.0;       // horizontal distance to the corner
  // Vertical edge: a radial segment at `azimuth` from the corner's radius to
  // v_radius.
  double v_radius = 0.0;
  // Horizontal edge at height `h_height` (sensor frame): PH parameters
  // (R_main = E(D_main, Z), theta_main) and the far end's azimuth.
  double h_height = 0.0;
  double r_main = 0.0;
  double theta_main = 0.0;
  double h_end_azimuth = 0.0;
  // +1 when the landmark's face lies towards increasing azimuth from the
  // vertical edge, -1 otherwise; +1 when it lies towards increasing radius
  // from the horizontal edge.
  int inside_azimuth_sign = 1;
  int inside_radius_sign = 1;
  // Sign of the intensity step going into the face (+1 brighter inside)
  // across the vertical and the horizontal edge that the trackers search
  // for; 0: either sign (the polarity is unknown). PredictLandmarks sets the
  // map's (0 where a shade is unknown; landmarks whose known shades give no
  // contrast are not predicted), and keeps them in map_*_polarity; the
  // localiser may replace v_polarity / h_polarity with what it learned from
  // the images.
  int v_polarity = 0;
  int h_polarity = 0;
  int map_v_polarity = 0;
  int map_h_polarity = 0;
  // The corner's predicted image motion over one frame interval (px), across
  // the vertical edge (tangential) and across the horizontal one (radial):
  // the widest motion blur its edges can show. The localiser sets them from
  // its motion model; 0: a still camera.
  double tangential_motion_px = 0.0;
  double radial_motion_px = 0.0;
  double full_tangential_motion_px = 0.0;  // before scaling by the exposure
};

struct PredictionOptions {
  double min_radius_fraction = 0.25;  // of the limb: nearer the centre is the robot itself
  double max_radius_margin = 2.0;     // px inside the limb
  double image_margin = 4.0;          // px inside the image
  double min_contrast = 0.04;         // reflectance difference for a usable edge
  double min_edge_px = 6.0;           // shortest usable edge projection (px)
  // How far a corner may lie from the surface it is on (map units): a map
  // measured by hand places some corners a little behind their wall, and
  // that wall does not hide them (Scene::Occluded's plane tolerance).
  double surface_tolerance = 0.0;
  // Corners nearer than this many mirror distances (pinhole to the
  // sphere's centre) are left out: there the strongly curved edges bias a
  // junction beyond the image noise a pose's covariance holds. Walls that
  // near still count by their farther corners.
  double min_distance_mirrors = 2.0;
  // A horizontal edge whose line passes nearer than this many mirror
  // distances is left out (0: wherever the E(D,Z) table reaches). The
  // room-wide search sets two: a hypothesis a grid step off predicts such
  // a strongly curved edge far from where it is, so it could neither vouch
  // for the hypothesis nor count against it.
  double min_line_distance_mirrors = 0.0;
  // A landmark whose horizontal edge's line passes within this many mirror
  // distances is not chosen for SpreadPrediction's azimuth spread: the
  // robot's own motion blurs such a strongly curved edge most, and a sector
  // whose one chosen landmark is missed leaves the pose to the others. It
  // is tracked besides the chosen instead (SpreadPrediction::NearLines),
  // where its bearing tells the position best.
  double spread_line_distance_mirrors = 2.0;
  void Check() const;
};

// Which landmarks PredictLandmarks keeps, given a candidate's geometry and
// the landmarks predicted before it (null: all).
using WantedLandmark =
    std::function<bool(const PredictedLandmark& candidate, const std::vector<PredictedLandmark>& predicted)>;

// Predicts the landmarks in view from `pose`: inside the image and the
// mirror's annulus, not hidden by map surfaces, with contrast on both edges
// (or an unknown shade on either side of an edge); with `wanted`, only those
// it accepts, the others left out before the scene's ray casts (most of the
// cost). Image radii come from the E(D,Z) table (within 0.002 px of the model).
std::vector<PredictedLandmark> PredictLandmarks(const std::vector<Landmark>& landmarks,
                                                const Map& map, const Scene& scene,
                                                const Sensor& sensor, const RadiusTable& table,
                                                const Pose2& pose, const PredictionOptions& opt,
                                                const WantedLandmark& wanted = nullptr);

// Sets each predicted landmark's image motion (tangential_motion_px,
// radial_motion_px) for a camera that moved from `previous` to the pose the
// landmarks were predicted from, scaled by `fraction` (the part of that
// motion the exposure spans).
void SetImageMotion(const Map& map, const Sensor& sensor, const RadiusTable& table,
                    const Pose2& previous, double fraction, std::vector<PredictedLandmark>* predicted);

// The predicted landmarks reordered so that the first `max_count` (0: all)
// are spread in azimuth: the nearest in each of max_count equal sectors, then
// the nearest of the rest; the others follow, nearest first.
std::vector<PredictedLandmark> SelectSpread(std::vector<PredictedLandmark> all, int max_count);

namespace internal {
// What the predictions of every landmark from one pose share.
struct PredictionContext {
  PredictionContext(const Map& map, const Sensor& sensor, const Pose2& pose, const PredictionOptions& opt);
  Eigen::Vector3d eye;      // the mirror's vertex: where the scene is seen from, nearly
  Eigen::Vector2d cam;      // the robot's position
  Eigen::Vector2d cos_sin;  // of the pose's heading, for SensorFromWorld
  double r_lo, r_hi;        // the annulus that predictions keep to (px)
};
}  // namespace internal

// SelectSpread(PredictLandmarks(...), max_count) in two parts: its first
// min(max_count, size) landmarks, then on demand the rest. The scene's ray
// casts (occlusion and the shades beyond the edges: most of a prediction's
// cost) run only for the landmarks that decide the order of the first part,
// so a frame that tracks the chosen landmarks pays for about those alone.
// The landmarks whose horizontal edges' lines pass near
// (PredictionOptions::spread_line_distance_mirrors) take no part in the
// spread or the rest: NearLines() holds them.
class SpreadPrediction {
 public:
  // `partners`: Partners() holds the landmark at the other end of the
  // vertical edge of up to this many of the first part's landmarks (the
  // nearest first, where visible and not in the first part): the two
  // corners of one edge share its survey error, so the difference of their
  // bearings shows the image noise alone.
  SpreadPrediction(const std::vector<Landmark>& landmarks, const Map& map, const Scene& scene,
                   const Sensor& sensor, const RadiusTable& table, const Pose2& pose,
                   const PredictionOptions& opt, int max_count, int partners = 0);
  // The whole list's first min(max_count, size) elements (all for max_count <= 0).
  std::vector<PredictedLandmark> First();
  // Whether the whole list is longer than First().
  bool HasMore() const { return max_count_ > 0 && more_; }
  // The elements after First(), in order, less NearLines().
  std::vector<PredictedLandmark> Rest();
  // The visible landmarks whose horizontal edges' lines pass within
  // PredictionOptions::spread_line_distance_mirrors, nearest first, when
  // they are not in First() (which holds every landmark when there are no
  // more than max_count).
  std::vector<PredictedLandmark> NearLines() const;
  // The partners of the first part (the constructor's `partners`).
  std::vector<PredictedLandmark> Partners() const;

 private:
  bool Visible(int i);  // the image geometry's and the scene's tests of candidates_[i], run once
  bool NearLine(int i) const { return near_line_[static_cast<size_t>(i)]; }
  void FindPartners(int partners);  // partners_ (the constructor's `partners`)
  enum State : char { kUnknown, kVisible, kHidden };
  const Map& map_;
  const Scene& scene_;
  const Sensor& sensor_;
  const RadiusTable& table_;
  Pose2 pose_;
  PredictionOptions opt_;
  int max_count_;
  internal::PredictionContext ctx_;
  std::vector<PredictedLandmark> candidates_;  // landmark order, placed in front of the camera
  std::vector<State> state_;
  std::vector<int> by_distance_;  // candidates nearest first
  std::vector<char> taken_;       // in the first part
  std::vector<int> spread_;       // the first part (when more_)
  std::vector<int> partners_;     // Partners()
  std::vector<int> near_lines_;   // NearLines()
  std::vector<char> near_line_;   // per candidate: its horizontal edge's line passes near (the spread's rule)
  bool more_ = false;
};

}  // namespace pano

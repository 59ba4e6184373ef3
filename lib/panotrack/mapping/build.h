// Growing a map from video (panomap build): new vertical rectangles found
// from a run whose poses are known (a pose CSV, or localised with a few seed
// landmarks).
//
// 1. Vertical edges. A vertical world edge projects to a radial line: each
//    frame's tangential gradient, resampled in polar coordinates, gives per
//    image azimuth the pixels of a radial edge (with its sign and radial
//    extent); peaks of that profile are the frame's vertical edges. Those
//    within a few tenths of a degree of a seed landmark's predicted edge are
//    explained by the map and dropped.
// 2. Floor positions. Each unexplained edge is a ray on the floor from the
//    frame's position along its world bearing. Rays of one edge seen from
//    many poses cross at its (x, y): the rays are voted into a floor grid,
//    and each peak (strongest first) is refined by least squares on the
//    bearings of the rays it explains (one per frame, Huber), with its
//    covariance. Edges seen over too little parallax, in too few frames, or
//    with a large position std are rejected (with the reason).
// 3. Heights. The radial extent of the edge in each frame, through the
//    sensor model at the triangulated distance, gives its bottom and top
//    heights (median over the frames).
// 4. Rectangles. Two edges with matching bottom and top heights form a
//    rectangle when the image shows its horizontal edges: the projected top
//    and bottom segments between them are sampled in the stored frames and
//    must show a radial step of one sign along most of their length. The
//    heights are then refined by scanning for the strongest horizontal
//    edge. Pairs are taken strongest first, each edge in one rectangle.
//
// The seed's rectangles and boxes are kept unchanged; new rectangles get new
// ids and an unknown shade (the localiser learns their polarity).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "panotrack/lut/radius_table.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/pose/pose_row.h"
#include "panotrack/scene/map.h"
#include "panotrack/scene/scene.h"
#include "panotrack/sensor/calibration.h"
#include "panotrack/track/landmarks.h"

namespace pano {

struct MapBuildOptions {
  PredictionOptions prediction;  // for the seed landmarks' edges
  // Vertical edge detection (per frame).
  double azimuth_bin_deg = 0.25;
  double min_gradient = 3.0;        // grey levels per px across the edge
  int min_edge_px = 12;             // radial pixels of one sign in the peak's column
  int nms_bins = 4;                 // peaks are maxima over +-nms_bins
  double seed_exclusion_deg = 1.0;  // detections this near a seed edge are the seed's
  // Triangulation. Lengths are fractions of the map's size (the larger side
  // of its extent) so that the defaults suit any units.
  double cell_fraction = 1.0 / 300;  // floor grid cell
  int min_views = 8;                 // frames that see an accepted edge
  double ray_tolerance_deg = 0.6;    // a ray explains an edge within this
  double min_parallax_deg = 8.0;     // spread of the rays' world directions
  double max_std_fraction = 0.01;    // largest position std (1 sigma, major axis)
  // Rectangles.
  double height_tolerance_fraction = 0.03;  // bottoms (and tops) of the pair agree within
  double min_width_fraction = 0.04;
  double max_width_fraction = 0.5;
  double min_step = 8.0;              // grey levels across a horizontal edge sample
  double min_horizontal_score = 0.6;  // fraction of samples showing the step (both edges)
  int min_horizontal_frames = 3;
  int max_stored_frames = 60;  // frames kept for the horizontal checks (60..120, evenly spread)
  std::string id_prefix = "new";
  void Check() const;
};

// One vertical edge in one frame.
struct VerticalEdgeDetection {
  double azimuth = 0.0;           // image azimuth (radians)
  int polarity = 0;               // sign of the intensity step towards increasing azimuth
  double r_lo = 0.0, r_hi = 0.0;  // radial extent (px)
  int support = 0;                // pixels in the peak's column
};

// The vertical edges of one grey frame, by azimuth.
std::vector<VerticalEdgeDetection> DetectVerticalEdges(const cv::Mat& grey, const Sensor& sensor,
                                                       const MapBuildOptions& options);

enum class EdgeVerdict { kAccepted, kTooFewViews, kLowParallax, kPoorlyConditioned, kNoHeight, kRoomCorner };
const char* EdgeVerdictName(EdgeVerdict v);

struct BuiltEdge {
  Eigen::Vector2d position{0, 0};
  double std_major = 0.0;  // position std along its worst direction (map units)
  int views = 0;
  double parallax_deg = 0.0;
  double rms_bearing_deg = 0.0;
  double z0 = 0.0, z1 = 0.0, z0_std = 0.0, z1_std = 0.0;
  EdgeVerdict verdict = EdgeVerdict::kAccepted;
  int rectangle = -1;  // into MapBuildResult::rectangles
  // The rays it explains: (frame index into the stored poses, detection).
  std::vector<std::pair<int, int>> rays;
};

struct BuiltRectangle {
  MapRectangle rectangle;
  int edge_from = -1, edge_to = -1;            // into MapBuildResult::edges
  double top_score = 0.0, bottom_score = 0.0;  // fraction of horizontal samples showing the step
  int frames = 0;                              // frames the horizontal edges were checked in
};

struct MapBuildResult {
  Map map;  // the seed plus the new rectangles
  std::vector<BuiltEdge> edges;
  std::vector<BuiltRectangle> rectangles;
  int frames = 0, frames_with_pose = 0, frames_with_seed = 0;
  int detections = 0, unexplained = 0;
  // Pairs of accepted edges with matching heights, and of those the ones
  // whose horizontal edges were not seen.
  int pairs_considered = 0, pairs_rejected = 0;
};

// Accumulates frames with their poses, then builds.
class MapBuilder {
 public:
  MapBuilder(const Calibration& calib, const Map& seed, const MapBuildOptions& options);
  // `grey` is the frame (CV_8UC1 of the calibration's size).
  void AddFrame(const cv::Mat& grey, const Pose2& pose);
  void AddFrameWithoutPose() { ++frames_; }
  int frames_with_seed() const { return frames_with_seed_; }
  // Triangulates, pairs and writes the grown map.
  MapBuildResult Build() const;

 private:
  struct Frame {
    Pose2 pose;
    std::vector<VerticalEdgeDetection> edges;  // unexplained by the seed
  };
  Calibration calib_;
  Map seed_;
  MapBuildOptions opt_;
  std::vector<Landmark> landmarks_;
  Scene scene_;
  RadiusTable table_;
  double scale_ = 1.0;  // map size
  std::vector<Frame> frames_list_;
  std::vector<std::pair<int, cv::Mat>> stored_;  // (index into frames_list_, grey)
  int frames_ = 0, frames_with_seed_ = 0, detections_ = 0, unexplained_ = 0;
};

// What panomap build prints: counts, each candidate edge and its verdict,
// each new rectangle with its std.
std::string FormatMapBuildReport(const MapBuildResult& r);

}  // namespace pano

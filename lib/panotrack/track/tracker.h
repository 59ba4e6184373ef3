// Landmark trackers: given a frame and a predicted landmark, measure the
// landmark's image azimuth. The line-junction tracker (paper section 4.2) and
// the vertex tracker (section 3) implement this interface; the localiser
// drives either.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "panotrack/track/landmarks.h"

namespace pano {

struct LandmarkMeasurement {
  bool found = false;
  double azimuth = 0.0;  // image azimuth of the landmark (radians)
  double radius = 0.0;   // image radius of the junction (px)
  double weight = 1.0;   // confidence for the triangulation
  // Median width (px) between the 15 % and 85 % levels of the steps across
  // its vertical edge: the motion blur seen; -1 unknown.
  double edge_width_px = -1.0;
  const char* why = "";  // reason when not found
  // The step polarities found across the vertical and the horizontal edge,
  // going into the face (+1 brighter inside, as PredictedLandmark's), and
  // their contrasts (grey levels); 0 when not found.
  int v_polarity = 0;
  int h_polarity = 0;
  double v_contrast = 0.0;
  double h_contrast = 0.0;
  // For the debug video: image points of the found edges, and the tracked
  // horizontal edge's PH parameters.
  std::vector<Eigen::Vector2d> edge_points;
  double r_main = 0.0;
  double theta_main = 0.0;
};

class LandmarkTracker {
 public:
  virtual ~LandmarkTracker() = default;
  // Called once per frame before Measure (e.g. to warp the image).
  virtual void BeginFrame(const cv::Mat& grey) = 0;
  // search_px: expected image motion of the landmark since the prediction.
  // Must be safe to call concurrently for different landmarks.
  virtual LandmarkMeasurement Measure(const PredictedLandmark& p, double search_px) const = 0;
  // The landmark's azimuth alone, for a first estimate of the pose that a
  // full Measure around it then confirms: a tracker may skip what only
  // validates the landmark (the junction tracker: the horizontal edge and
  // the junction). By default the full measurement.
  virtual LandmarkMeasurement MeasureAzimuth(const PredictedLandmark& p, double search_px) const {
    return Measure(p, search_px);
  }
  // Whether MeasureAzimuth costs clearly less than Measure.
  virtual bool MeasuresAzimuthCheaply() const { return false; }
};

}  // namespace pano

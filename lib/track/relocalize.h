// Global relocalisation, for a robot that was moved while tracking was lost
// (the "kidnapped robot"): pose hypotheses ranked by how well the map's
// vertical edges, predicted from a grid of positions over the room, line up
// with the radial edges of the frame, for the best heading at each position.
// The localiser verifies the best hypotheses with its full tracker.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "scene/map.h"
#include "scene/scene.h"
#include "sensor/sensor.h"
#include "track/landmarks.h"

namespace pano {

struct RelocalizeOptions {
  double grid_step = 0.0;   // map units between candidate positions; 0: room size / 40
  double wall_margin = 0.0; // keep candidates this far from walls; 0: grid_step
  int heading_bins = 720;
  int hypotheses = 20;      // best distinct hypotheses returned (each verified by tracking)
  void Check() const;
};

// Histogram over image azimuth of radial edges (gradients across the
// azimuth, as vertical world edges make), smoothed, over `bins` bins.
std::vector<float> RadialEdgeHistogram(const cv::Mat& grey, const Sensor& sensor, int bins);

struct PoseHypothesis {
  Pose2 pose;
  double score = 0.0;
};

// The best distinct hypotheses, strongest first; the grid positions are
// scored on `num_threads` threads (0: OpenMP's default), with the same result
// for any count.
std::vector<PoseHypothesis> RelocalizationHypotheses(const cv::Mat& grey, const Sensor& sensor,
                                                     const RadiusTable& table, const Map& map,
                                                     const Scene& scene,
                                                     const std::vector<Landmark>& landmarks,
                                                     const PredictionOptions& prediction,
                                                     const RelocalizeOptions& options, int num_threads = 0);

}  // namespace pano

// Global relocalisation, for a robot that was moved while tracking was lost
// (the "kidnapped robot"): pose hypotheses ranked by how well the map's
// vertical edges, predicted from a grid of positions over the room, line up
// with the radial edges of the frame, for the best heading at each position.
// The localiser verifies the best hypotheses with its full tracker.
#pragma once

#include <opencv2/core.hpp>

#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/scene/map.h"
#include "panotrack/scene/scene.h"
#include "panotrack/sensor/sensor.h"
#include "panotrack/track/landmarks.h"

namespace pano {

struct RelocalizeOptions {
  double grid_step = 0.0;   // map units between candidate positions; 0: room size / 40
  double wall_margin = 0.0; // keep candidates this far from walls; 0: grid_step
  int heading_bins = 720;
  int hypotheses = 20;      // best distinct hypotheses returned (each verified by tracking)
  // An edge's support saturates at this level of the normalised histogram
  // (0: no cap), so that a pose scores by how many of its predicted edges
  // are there, not by a few strong ones.
  double support_cap = 0.25;
  void Check() const;
};

// The best heading for a set of predicted vertical edges (azimuth bins at
// heading 0): the heading bin t maximising the sum over the edges of
// hist[b - t], less 0.15 per edge (a pose that predicts edges where there
// are none is worse). Every heading is scored, all at once (vector adds
// over the histogram): faster than a branch and bound over blocks of
// headings at the histogram's resolution, and exhaustive.
class HeadingSearch {
 public:
  explicit HeadingSearch(const std::vector<float>& hist);
  // The best bin and its score (the lowest bin among equals); -1 (score 0)
  // when no heading scores above 0.
  int Best(const std::vector<int>& edge_bins, double* score) const;

 private:
  int bins_;
  // hist reversed, twice over: reversed2_[j] = hist[-j mod bins], so that
  // the bins b - t of headings t = 0, 1, ... are one contiguous run.
  std::vector<float> reversed2_;
};

struct PoseHypothesis {
  Pose2 pose;
  double score = 0.0;
};

// What the room-wide search needs that does not change from frame to frame,
// built once: the image pixels of the mirror's annulus with their azimuth
// bins, and each grid position's predicted vertical edges (azimuth bins at
// heading 0, after occlusion). A search then costs one pass over the pixels
// and one heading sweep per position.
class RelocalizationIndex {
 public:
  // Grid positions are scored on `num_threads` threads (0: OpenMP's
  // default), with the same result for any count.
  RelocalizationIndex(const Sensor& sensor, const RadiusTable& table, const Map& map, const Scene& scene,
                      const std::vector<Landmark>& landmarks, const PredictionOptions& prediction,
                      const RelocalizeOptions& options, int num_threads = 0);

  // Histogram over image azimuth of radial edges (gradients across the
  // azimuth, as vertical world edges make), smoothed, normalised to a
  // maximum of 1, over options.heading_bins bins.
  std::vector<float> RadialEdgeHistogram(const cv::Mat& grey) const;

  // The best distinct hypotheses, strongest first: `count` of them (0:
  // options.hypotheses).
  std::vector<PoseHypothesis> Hypotheses(const cv::Mat& grey, int num_threads = 0, int count = 0) const;

 private:
  struct Pixel {
    int offset;  // v * cols + u
    int row;     // v (frames may have padded rows)
    int bin;
    float cos_az, sin_az;
  };
  RelocalizeOptions opt_;
  int cols_ = 0, rows_ = 0;
  double aspect_ = 1.0;
  double step_ = 0.0;
  std::vector<Pixel> pixels_;
  std::vector<Eigen::Vector2d> positions_;
  std::vector<std::vector<int>> edge_bins_;  // per position: distinct vertical edges
};

// One index for the localisers of a run's inputs, which share the sensor,
// map and options: the first that needs it builds it (on its thread, with
// its threads) and the others wait for it instead of building their own.
class SharedRelocalizationIndex {
 public:
  // The index, from `build` on the first call; a build that throws leaves
  // none, and the next call tries again.
  std::shared_ptr<const RelocalizationIndex> Get(
      const std::function<std::unique_ptr<const RelocalizationIndex>()>& build);

 private:
  std::mutex mutex_;
  std::shared_ptr<const RelocalizationIndex> index_;
};

}  // namespace pano

// Linear samples of the image and the step-edge detector of paper section
// 4.2: "linear samples are independently analysed to identify the possible
// location of the largest step edge greater than a set threshold", with the
// polarity the map predicts.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "panotrack/core/grey_sample.h"

namespace pano {

// n samples at start + k * step, k = 0..n-1. False if any falls outside.
bool SampleLine(const cv::Mat& grey, const Eigen::Vector2d& start, const Eigen::Vector2d& step,
                int n, float* out);

struct StepEdge {
  double location = 0.0;  // fractional sample index of the edge
  double strength = 0.0;  // intensity change across it (grey levels), signed by polarity
  double width = 0.0;     // samples between its 15 % and 85 % levels (its blur)
};

// The largest step of the given polarity (+1: intensity rises with the sample
// index) whose rise over `baseline` samples exceeds `min_step`.
//
// A step blurred by motion is a ramp as wide as the image motion during the
// exposure; `ramp` (samples, >= 0) is the widest ramp expected. The rise is
// then taken over max(baseline, ramp + 2) samples, so a ramp still shows its
// whole contrast, and the edge is located by the area under the profile
// normalised between its two plateaus: for any blur kernel that is the
// kernel's centroid, i.e. the edge's mean position over the exposure, and for
// a sharp step the midpoint crossing. Noise enters linearly (no bias).
bool FindStep(const float* profile, int n, int polarity, int baseline, double min_step,
              StepEdge* edge, double ramp = 0.0);

}  // namespace pano

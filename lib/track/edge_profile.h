// Linear samples of the image and the step-edge detector of paper section
// 4.2: "linear samples are independently analysed to identify the possible
// location of the largest step edge greater than a set threshold", with the
// polarity the map predicts.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/grey_sample.h"

namespace pano {

// n samples at start + k * step, k = 0..n-1. False if any falls outside.
bool SampleLine(const cv::Mat& grey, const Eigen::Vector2d& start, const Eigen::Vector2d& step,
                int n, float* out);

struct StepEdge {
  double location = 0.0;  // fractional sample index of the edge
  double strength = 0.0;  // intensity change across it (grey levels), signed by polarity
};

// The largest step of the given polarity (+1: intensity rises with the sample
// index) whose rise over `baseline` samples exceeds `min_step`. Located where
// the profile crosses the midpoint of the plateaus either side (unbiased for
// a symmetric blur), falling back to the parabola through the derivative peak.
bool FindStep(const float* profile, int n, int polarity, int baseline, double min_step,
              StepEdge* edge);

}  // namespace pano

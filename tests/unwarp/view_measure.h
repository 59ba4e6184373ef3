// Measuring rendered edges in unwarped views: sub-pixel step locations
// checked against the surface ids unwarped the same way.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

#include "panotrack/unwarp/unwarp.h"

namespace pano::test {

// The offset t (px) along `dir` from `p` where the view's grey level crosses
// half-way between its plateaus at -reach and +reach; NaN unless the profile
// crosses exactly one boundary between `surface` and one other surface
// (`ids`: the surface ids unwarped with nearest-neighbour interpolation).
double StepOffset(const cv::Mat& view, const cv::Mat& ids, int surface, const Eigen::Vector2d& p,
                  const Eigen::Vector2d& dir, double reach = 3.0);

// Total-least-squares line through points: the perpendicular residuals' RMS
// and largest, and the line (a point on it and its unit direction).
struct LineFit {
  Eigen::Vector2d centre{0, 0}, direction{1, 0};
  double rms = 0.0, max_abs = 0.0;
  int n = 0;
};
LineFit FitLine(const std::vector<Eigen::Vector2d>& points);
Eigen::Vector2d Intersect(const LineFit& a, const LineFit& b);

// Surface ids (CV_32SC1) as CV_32FC1 unwarped with nearest-neighbour
// interpolation; -1 off the mirror.
cv::Mat UnwarpIds(const cv::Mat& ids, const Sensor& sensor, UnwarpOptions options);

}  // namespace pano::test

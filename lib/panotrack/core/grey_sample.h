// Bilinear intensity of an 8-bit grey image, shared by the trackers and the
// calibrator's corner refinement. Header-only (OpenCV core only).
#pragma once

#include <opencv2/core.hpp>

namespace pano {

// Bilinear intensity of an 8-bit grey image at (x, y); false outside.
inline bool SampleGrey(const cv::Mat& grey, double x, double y, float* value) {
  if (!(x >= 0.0) || !(y >= 0.0) || x > grey.cols - 1.001 || y > grey.rows - 1.001) return false;
  const int ix = static_cast<int>(x), iy = static_cast<int>(y);
  const float fx = static_cast<float>(x - ix), fy = static_cast<float>(y - iy);
  const uchar* r0 = grey.ptr<uchar>(iy) + ix;
  const uchar* r1 = grey.ptr<uchar>(iy + 1) + ix;
  *value = (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
  return true;
}

}  // namespace pano

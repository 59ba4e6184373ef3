// panocalib calibrate's report image (--report).
#pragma once

#include <opencv2/core.hpp>

#include "panotrack/calibrate/calibrate.h"

namespace pano {

// Report image: the corners of every view over `image` (faded; a grey canvas
// when empty or of another size) with the mirror's limb and the annulus the
// corners cover, the residuals of all corners (scatter, histogram), the RMS
// per image with its file name (view_index, the worst view, in bold; views of
// the unwarped retry marked) and the parameters with their standard deviations.
cv::Mat DrawReport(const CalibrationResult& result, const cv::Mat& image, int view_index);
// The view the report draws over: the one with the largest RMS, where the
// residuals show best.
int WorstView(const CalibrationResult& result);

}  // namespace pano

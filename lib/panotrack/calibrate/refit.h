// A refit that may fail without ending the calibration (internal to
// lib/panotrack/calibrate; kept apart from internal.h, which brings in Ceres and glog,
// so that tests can use it).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "panotrack/calibrate/calibrate.h"

namespace pano::calib_internal {

// Fits `views` again from `start` (FitCalibration, then the first fit's
// checks) with the `carried` warnings first. When that fails, nothing is
// returned and "<what> failed (<reason>); the previous fit stands" is added
// to *carried, so that the failure reaches the result's warnings.
std::optional<CalibrationResult> TryRefit(const std::string& what, const std::vector<BoardView>& views,
                                          const TargetBoard& board, const InitialEstimate& start,
                                          bool poses_known, const std::string& units,
                                          const CalibrateOptions& options,
                                          std::vector<std::string>* carried);

}  // namespace pano::calib_internal

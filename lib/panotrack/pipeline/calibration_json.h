// panocalib calibrate's summary in machine-readable form (--summary-json):
// the figures CalibrationSummary() prints, the tool's version and its command line.
#pragma once

#include <string>
#include <vector>

#include "panotrack/pipeline/panocalib.h"

namespace pano {

// A JSON object:
//   {"tool": "panocalib calibrate", "version": "X.Y.Z", "command_line": [argv...],
//    "model", "image_width", "image_height", "poses_known", "boards_used",
//    "rms_px" (as evaluate gives it), "rms_raw_px", "fit_rms_px" (null when
//    unknown), "image_rms_px": {file: the fit's RMS}, "detection": {file: "raw" |
//    "unwarped" | "given"}, "parameters": {name: {"value", "stddev", "fixed"}},
//    "images_not_found": [file...], "warnings": [...], "iterations",
//    "seconds": {"detection", "fit"}, "outputs": {"calibration", "lut", "report"}}
// A standard deviation the data do not determine is null.
std::string CalibrationSummaryJson(const CalibrationResult& result, const CalibrationOutputs& outputs,
                                   const std::vector<std::string>& command_line);

}  // namespace pano

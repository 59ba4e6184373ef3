// panoloc's summary in machine-readable form (--summary-json): the figures
// the program prints per input, the accuracy against ground truth, the tool's
// version and its command line.
#pragma once

#include <string>
#include <vector>

#include "panotrack/pipeline/localize_video.h"
#include "panotrack/pipeline/panoloc.h"

namespace pano {

// A JSON object:
//   {"tool": "panoloc", "version": "X.Y.Z", "command_line": [argv...],
//    "inputs": [{"input", "end" (VideoEndName), "done" (bool), "error"
//      (string or null), "frames", "ok", "lost", "seconds", "frames_per_s",
//      "outputs": {"poses", "smoothed", "tum", "debug_video", "plot"} (those
//      written), "accuracy" and "smoothed_accuracy" (with ground truth)}]}
// An accuracy object holds AccuracySummary's fields plus outlier_percent.
std::string PanolocSummaryJson(const PanolocOptions& options, const std::vector<VideoSummary>& results,
                               const std::vector<std::string>& command_line);

// Writes PanolocSummaryJson to options.summary_json atomically ("-":
// standard output); nothing when it is empty. Throws pano::Error when the
// file cannot be written.
void WritePanolocSummaryJson(const PanolocOptions& options, const std::vector<VideoSummary>& results,
                             const std::vector<std::string>& command_line);

}  // namespace pano

#include "panotrack/pipeline/summary_json.h"

#include <cstdio>
#include <nlohmann/json.hpp>

#include "panotrack/config.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"

namespace pano {

namespace {

// Keys in the order written, for people reading the file.
using json = nlohmann::ordered_json;

json AccuracyJson(const AccuracySummary& a) {
  return {{"frames", a.frames},
          {"tracked", a.tracked},
          {"compared", a.compared},
          {"rms", a.rms},
          {"std", a.std},
          {"mean", a.mean},
          {"max", a.max},
          {"heading_rms_deg", a.heading_rms_deg},
          {"heading_max_deg", a.heading_max_deg},
          {"outliers", a.outliers},
          {"outlier_percent", a.compared ? 100.0 * a.outliers / a.compared : 0.0},
          {"std_inliers", a.std_inliers}};
}

json InputJson(const VideoSummary& s, const PanolocOptions& options) {
  json outputs = json::object();
  const bool started = s.end != VideoEnd::kFailed;
  if (started && !s.output.empty()) outputs["poses"] = s.output;
  if (!s.smoothed_output.empty()) outputs["smoothed"] = s.smoothed_output;
  if (!s.tum_output.empty()) outputs["tum"] = s.tum_output;
  // One input only (PanolocOptions::Check); written once the input started.
  if (started && !options.debug_video.empty()) outputs["debug_video"] = options.debug_video;
  if (started && !options.plot.empty()) outputs["plot"] = options.plot;
  json j = {{"input", s.input},
            {"end", VideoEndName(s.end)},
            {"done", s.ok},
            {"error", s.error.empty() ? json(nullptr) : json(s.error)},
            {"frames", s.frames},
            {"ok", s.n_ok},
            {"lost", s.n_lost},
            {"seconds", s.seconds},
            {"frames_per_s", s.seconds > 0 ? s.frames / s.seconds : 0.0},
            {"decoder", s.hardware_decoding ? "nvdec" : "cpu"},
            {"outputs", outputs}};
  if (s.has_accuracy) j["accuracy"] = AccuracyJson(s.accuracy);
  if (s.has_smoothed_accuracy) j["smoothed_accuracy"] = AccuracyJson(s.smoothed_accuracy);
  return j;
}

}  // namespace

std::string PanolocSummaryJson(const PanolocOptions& options, const std::vector<VideoSummary>& results,
                               const std::vector<std::string>& command_line) {
  json inputs = json::array();
  for (const VideoSummary& s : results) inputs.push_back(InputJson(s, options));
  const json j = {{"tool", "panoloc"}, {"version", PANO_VERSION}, {"command_line", command_line},
                  {"inputs", inputs}};
  // Invalid UTF-8 in a file name becomes U+FFFD rather than an exception.
  return j.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

void WritePanolocSummaryJson(const PanolocOptions& options, const std::vector<VideoSummary>& results,
                             const std::vector<std::string>& command_line) {
  if (options.summary_json.empty()) return;
  const std::string text = PanolocSummaryJson(options, results, command_line);
  WriteFileOrStdout(options.summary_json, text, "--summary-json");
}

}  // namespace pano

#include "panotrack/pipeline/calibration_json.h"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "panotrack/config.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"

namespace pano {

std::string CalibrationSummaryJson(const CalibrationResult& r, const CalibrationOutputs& outputs,
                                   const std::vector<std::string>& command_line) {
  using json = nlohmann::ordered_json;  // keys in the order written, for people reading the file
  const Sensor& s = r.calib.sensor;
  json image_rms = json::object(), detection = json::object();
  for (size_t i = 0; i < r.views.size() && i < r.image_rms.size(); ++i) {
    image_rms[r.views[i].file] = r.image_rms[i];
    detection[r.views[i].file] = r.views[i].method;
  }
  json parameters = json::object();
  for (const ParameterEstimate& p : r.parameters)
    parameters[p.name] = {{"value", p.value},
                          {"stddev", std::isfinite(p.stddev) ? json(p.stddev) : json(nullptr)},
                          {"fixed", p.fixed}};
  // The cross-validation behind --model auto (null: the model was given).
  json selection = nullptr;
  if (!r.model_scores.empty()) {
    json candidates = json::array();
    for (const ModelScore& m : r.model_scores)
      candidates.push_back({{"model", m.name},
                            {"training_rms_px", std::isfinite(m.training_rms_px) ? json(m.training_rms_px) : json(nullptr)},
                            {"heldout_rms_px", std::isfinite(m.heldout_rms_px) ? json(m.heldout_rms_px) : json(nullptr)},
                            {"heldout_boards", m.heldout_boards},
                            {"failed_boards", m.failed_boards},
                            {"parameters", m.parameters},
                            {"refused", m.refused.empty() ? json(nullptr) : json(m.refused)}});
    selection = {{"chosen", r.model_chosen >= 0 ? json(r.model_scores[r.model_chosen].name) : json(nullptr)},
                 {"reason", r.model_reason},
                 {"candidates", candidates}};
  }
  json written = json::object();
  if (!outputs.calibration.empty()) written["calibration"] = outputs.calibration;
  if (!outputs.lut.empty()) written["lut"] = outputs.lut;
  if (!outputs.report.empty()) written["report"] = outputs.report;
  const json j = {{"tool", "panocalib calibrate"},
                  {"version", PANO_VERSION},
                  {"command_line", command_line},
                  {"model", MirrorModelName(s.model)},
                  {"model_selection", selection},
                  {"image_width", s.image_width},
                  {"image_height", s.image_height},
                  {"poses_known", r.poses_known},
                  {"boards_used", r.views.size()},
                  {"rms_px", r.rms_px},
                  {"rms_raw_px", std::isfinite(r.rms_raw_px) ? json(r.rms_raw_px) : json(nullptr)},
                  {"fit_rms_px", std::isfinite(r.fit_rms_px) ? json(r.fit_rms_px) : json(nullptr)},
                  {"image_rms_px", image_rms},
                  {"detection", detection},
                  {"parameters", parameters},
                  {"images_not_found", r.not_found_files},
                  {"warnings", r.warnings},
                  {"iterations", r.iterations},
                  {"seconds", {{"detection", r.seconds_detect}, {"fit", r.seconds_fit}}},
                  {"outputs", written}};
  // Invalid UTF-8 in a file name becomes U+FFFD rather than an exception.
  return j.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

}  // namespace pano

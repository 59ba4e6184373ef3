// Rendered test sequences for the localiser's tests: the first frames of
// panosim's presets, rendered in memory (no video codec in the way).
#pragma once

#include <algorithm>
#include <cmath>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "panotrack/io/pose_csv.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/lut/table_cache.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/scene/scene.h"
#include "panotrack/track/localizer.h"
#include "panotrack/pipeline/panoloc.h"

namespace pano::test {

// TableForMap, the tables used last kept for the test process: a suite's
// cases track many renders on the same maps (a second a table), and a table
// is a pure function of the sensor and the ranges the map needs (the table
// cache's key).
inline std::shared_ptr<const RadiusTable> TableForMapOnce(const Calibration& calib, const Map& map) {
  if (!calib.lut_resolved.empty()) return TableForMap(calib, map, true);
  constexpr size_t kKept = 8;
  static std::mutex mutex;
  static std::list<std::pair<std::string, std::shared_ptr<const RadiusTable>>> kept;  // the last used first
  const std::string key = RadiusTableCacheKey(calib.sensor, RangesForMap(map, calib.sensor), LutSize());
  std::lock_guard<std::mutex> lock(mutex);
  auto it = std::find_if(kept.begin(), kept.end(), [&](const auto& entry) { return entry.first == key; });
  if (it == kept.end()) {
    kept.emplace_front(key, TableForMap(calib, map, true));
    if (kept.size() > kKept) kept.pop_back();
  } else {
    kept.splice(kept.begin(), kept, it);
  }
  return kept.front().second;
}

struct RenderedCase {
  SequenceCase c;
  std::vector<cv::Mat> frames;
  std::vector<PoseRow> truth;
  std::shared_ptr<const RadiusTable> table;
};

inline RenderedCase RenderPreset(const std::string& name, int n_frames, int first = 0) {
  RenderedCase r;
  r.c = MakePreset(name);
  const Scene scene = Scene::FromMap(r.c.map, true);
  const Renderer renderer(r.c.calib.sensor, scene, r.c.map.sensor_height, r.c.options);
  for (int i = first; i < first + n_frames && i < static_cast<int>(r.c.poses.size()); ++i) {
    r.frames.push_back(renderer.Render(r.c.poses[i], i));
    PoseRow row;
    row.frame = i - first;
    row.pose = r.c.poses[i];
    r.truth.push_back(row);
  }
  Map no_distractors = r.c.map;
  no_distractors.distractors.clear();
  r.c.map = no_distractors;
  r.table = TableForMapOnce(r.c.calib, r.c.map);
  return r;
}

// The rows of every frame of `r`, taken `fps` frames a second apart, as
// panoloc writes them (a held frame's row ok once a later frame confirms it);
// `held`, where given: per frame, whether its pose was held for a later
// frame to confirm.
inline std::vector<PoseRow> ProcessFrames(Localizer* loc, const RenderedCase& r, double fps,
                                          std::vector<char>* held_out = nullptr) {
  std::vector<PoseRow> rows;
  if (held_out) held_out->assign(r.frames.size(), 0);
  for (size_t i = 0; i < r.frames.size(); ++i) {
    const FrameResult fr = loc->Process(r.frames[i], static_cast<int>(i), static_cast<double>(i) / fps);
    if (held_out) (*held_out)[i] = fr.unconfirmed;
    rows.push_back(fr.row);
    for (const FrameResult& held : loc->TakeConfirmedHolds()) rows[static_cast<size_t>(held.row.frame)] = held.row;
  }
  return rows;
}

// The fraction of the ok rows whose position lies inside the ellipse of
// three of their reported standard deviations (std_x, std_y).
inline double InsideThreeSigma(const std::vector<PoseRow>& rows, const std::vector<PoseRow>& truth) {
  int ok = 0, inside = 0;
  for (size_t i = 0; i < rows.size() && i < truth.size(); ++i) {
    if (rows[i].status != PoseStatus::kOk || rows[i].extra.size() < 2) continue;
    ++ok;
    const double dx = (rows[i].pose.x - truth[i].pose.x) / rows[i].extra[0];
    const double dy = (rows[i].pose.y - truth[i].pose.y) / rows[i].extra[1];
    inside += std::hypot(dx, dy) <= 3.0;
  }
  return ok > 0 ? static_cast<double>(inside) / ok : 0.0;
}

inline std::vector<PoseRow> Localize(const RenderedCase& r, const LocalizerOptions& opt, const Pose2& init) {
  Localizer loc(r.c.calib, r.c.map, r.table, opt);
  loc.Reset(init);
  return ProcessFrames(&loc, r, r.c.fps);
}

}  // namespace pano::test

#include "panotrack/pipeline/sensor_tilt.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "panotrack/core/error.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/video/frame_source.h"

namespace pano {

void SensorTiltOptions::Check() const {
  if (max_frames < 5) throw Error("tilt: max_frames: expected 5 or more");
  if (!(search_deg > 0) || !(tolerance_deg > 0) || !(tolerance_deg < search_deg))
    throw Error("tilt: search_deg and tolerance_deg: expected 0 < tolerance_deg < search_deg");
  if (max_trials < 3) throw Error("tilt: max_trials: expected 3 or more");
  localizer.Check();
}

namespace {

constexpr int kMinTracked = 5;

struct Trial {
  double residual = 0.0;  // mean RMS bearing residual of the tracked frames; large when too few
  int tracked = 0;
};

class TiltObjective {
 public:
  TiltObjective(const Calibration& calib, const Map& map, const std::vector<cv::Mat>& frames,
                const SensorTiltOptions& o)
      : calib_(calib), map_(map), frames_(frames), o_(o), table_(TableForMap(calib, map, /*quiet=*/true)) {}

  Trial operator()(const double* tilt) {
    ++trials_;
    Calibration c = calib_;
    c.sensor.faults.sensor_tilt[0] = tilt[0];
    c.sensor.faults.sensor_tilt[1] = tilt[1];
    Localizer loc(c, map_, table_, o_.localizer);
    if (o_.init)
      loc.Reset(*o_.init);
    else
      loc.ResetUnknown();
    double sum = 0.0;
    Trial t;
    for (size_t i = 0; i < frames_.size(); ++i) {
      const FrameResult fr = loc.Process(frames_[i], static_cast<int>(i), 0.1 * static_cast<double>(i));
      if (fr.row.status != PoseStatus::kOk) continue;
      sum += fr.triangulation.rms_bearing;
      ++t.tracked;
    }
    // A tilt that loses frames is worse than any that keeps them.
    t.residual = t.tracked >= kMinTracked ? sum / t.tracked + 1.0 * (frames_.size() - t.tracked) / frames_.size()
                                          : 1e3;
    return t;
  }
  int trials() const { return trials_; }

 private:
  const Calibration& calib_;
  const Map& map_;
  const std::vector<cv::Mat>& frames_;
  const SensorTiltOptions& o_;
  std::shared_ptr<const RadiusTable> table_;
  int trials_ = 0;
};

}  // namespace

SensorTiltResult EstimateSensorTilt(const Calibration& calib, const Map& map, const std::vector<cv::Mat>& frames,
                                    const SensorTiltOptions& options) {
  options.Check();
  if (frames.size() < static_cast<size_t>(kMinTracked)) throw Error("tilt: fewer than 5 frames");
  TiltObjective objective(calib, map, frames, options);
  using Point = std::array<double, 2>;
  struct Vertex {
    Point x;
    Trial t;
  };
  const Point start{calib.sensor.faults.sensor_tilt[0], calib.sensor.faults.sensor_tilt[1]};
  const double step = options.search_deg * M_PI / 180, tolerance = options.tolerance_deg * M_PI / 180;
  std::array<Vertex, 3> simplex{
      Vertex{start, objective(start.data())}, Vertex{{start[0] + step, start[1]}, {}},
      Vertex{{start[0], start[1] + step}, {}}};
  simplex[1].t = objective(simplex[1].x.data());
  simplex[2].t = objective(simplex[2].x.data());
  SensorTiltResult r;
  r.frames = static_cast<int>(frames.size());
  r.residual_before = simplex[0].t.residual;
  r.tracked_before = simplex[0].t.tracked;
  auto report = [&] {
    if (options.on_trial) {
      const Vertex& b = *std::min_element(simplex.begin(), simplex.end(),
                                          [](const Vertex& a, const Vertex& c) { return a.t.residual < c.t.residual; });
      options.on_trial(objective.trials(), b.x.data(), b.t.residual);
    }
  };
  report();
  // Nelder-Mead (reflection, expansion, contraction, shrink) on the 2 angles.
  auto lerp = [](const Point& a, const Point& b, double s) {
    return Point{a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])};
  };
  while (objective.trials() + 2 <= options.max_trials) {
    std::sort(simplex.begin(), simplex.end(), [](const Vertex& a, const Vertex& b) { return a.t.residual < b.t.residual; });
    const double size = std::max(std::hypot(simplex[1].x[0] - simplex[0].x[0], simplex[1].x[1] - simplex[0].x[1]),
                                 std::hypot(simplex[2].x[0] - simplex[0].x[0], simplex[2].x[1] - simplex[0].x[1]));
    if (size < tolerance) break;
    const Point centroid{(simplex[0].x[0] + simplex[1].x[0]) / 2, (simplex[0].x[1] + simplex[1].x[1]) / 2};
    const Point reflected = lerp(centroid, simplex[2].x, -1.0);
    const Trial tr = objective(reflected.data());
    if (tr.residual < simplex[0].t.residual) {
      const Point expanded = lerp(centroid, simplex[2].x, -2.0);
      const Trial te = objective(expanded.data());
      simplex[2] = te.residual < tr.residual ? Vertex{expanded, te} : Vertex{reflected, tr};
    } else if (tr.residual < simplex[1].t.residual) {
      simplex[2] = {reflected, tr};
    } else {
      const bool outside = tr.residual < simplex[2].t.residual;
      const Point contracted = lerp(centroid, outside ? reflected : simplex[2].x, 0.5);
      const Trial tc = objective(contracted.data());
      if (tc.residual < std::min(tr.residual, simplex[2].t.residual)) {
        simplex[2] = {contracted, tc};
      } else {
        for (int k = 1; k < 3; ++k) {
          simplex[k].x = lerp(simplex[0].x, simplex[k].x, 0.5);
          simplex[k].t = objective(simplex[k].x.data());
        }
      }
    }
    report();
  }
  const Vertex& best = *std::min_element(simplex.begin(), simplex.end(),
                                         [](const Vertex& a, const Vertex& b) { return a.t.residual < b.t.residual; });
  if (best.t.tracked < kMinTracked)
    throw Error("tilt: too few frames tracked (" + std::to_string(best.t.tracked) + " of " +
                std::to_string(frames.size()) + ") with any tilt tried: check the calibration, map and start pose");
  r.tilt[0] = best.x[0];
  r.tilt[1] = best.x[1];
  r.residual_after = best.t.residual;
  r.tracked_after = best.t.tracked;
  r.trials = objective.trials();
  return r;
}

SensorTiltResult EstimateSensorTilt(const Calibration& calib, const Map& map, const std::string& input,
                                    const SensorTiltOptions& options) {
  options.Check();
  FrameSource source(input);
  const Sensor& s = calib.sensor;
  if (source.width() != s.image_width || source.height() != s.image_height)
    throw Error(input + ": frame size " + std::to_string(source.width()) + "x" + std::to_string(source.height()) +
                " does not match the calibration's " + std::to_string(s.image_width) + "x" +
                std::to_string(s.image_height));
  std::vector<cv::Mat> frames;
  cv::Mat grey;
  while (static_cast<int>(frames.size()) < options.max_frames && source.Read(&grey)) frames.push_back(grey.clone());
  return EstimateSensorTilt(calib, map, frames, options);
}

}  // namespace pano

#include "panotrack/pipeline/sensor_tilt.h"

#include <algorithm>
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
      : map_(map), frames_(frames), o_(o), table_(TableForMap(calib, map, /*quiet=*/true)) {
    // The map as it states itself: a wrong trial's residuals are what is
    // measured, not a survey error to be learned.
    localizer_ = o.localizer;
    localizer_.survey.check = false;
    // Trials are scored on the landmarks each frame tracks: with every
    // extra found counted against a pose, frames keep to the wider windows'
    // chosen landmarks and the sets change less from trial to trial
    // (faulty-rig's boards + tilt localised at 0.0185 / 0.0180 cm this way,
    // 0.0217 / 0.0192 cm with the extras counted only where they do not fit).
    localizer_.extras_on_tracked_pose_count_for_it = false;
  }

  Trial operator()(const Calibration& c) {
    ++trials_;
    Localizer loc(c, map_, table_, localizer_);
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
  const Map& map_;
  const std::vector<cv::Mat>& frames_;
  const SensorTiltOptions& o_;
  LocalizerOptions localizer_;
  std::shared_ptr<const RadiusTable> table_;
  int trials_ = 0;
};

}  // namespace

SensorTiltResult EstimateSensorTilt(const Calibration& calib, const Map& map, const std::vector<cv::Mat>& frames,
                                    const SensorTiltOptions& options) {
  options.Check();
  if (frames.size() < static_cast<size_t>(kMinTracked)) throw Error("tilt: fewer than 5 frames");
  // The parameters searched: the tilt's two angles (radians), and with
  // fit_decentre the mirror's offset (map units), scaled so that one step
  // moves the image about as much as one step of tilt does.
  const int n = options.fit_decentre ? 4 : 2;
  const double step = options.search_deg * M_PI / 180, tolerance = options.tolerance_deg * M_PI / 180;
  const double offset_per_radian = calib.sensor.mirror_distance();
  auto calibration_at = [&](const std::vector<double>& x) {
    Calibration c = calib;
    c.sensor.faults.sensor_tilt[0] = x[0];
    c.sensor.faults.sensor_tilt[1] = x[1];
    if (n == 4) {
      c.sensor.faults.mirror_offset[0] = x[2] * offset_per_radian;
      c.sensor.faults.mirror_offset[1] = x[3] * offset_per_radian;
    }
    return c;
  };
  TiltObjective objective(calib, map, frames, options);
  struct Vertex {
    std::vector<double> x;
    Trial t;
  };
  auto evaluate = [&](const std::vector<double>& x) {
    const Calibration c = calibration_at(x);
    return objective(c);
  };
  std::vector<double> start{calib.sensor.faults.sensor_tilt[0], calib.sensor.faults.sensor_tilt[1]};
  if (n == 4) {
    start.push_back(calib.sensor.faults.mirror_offset[0] / offset_per_radian);
    start.push_back(calib.sensor.faults.mirror_offset[1] / offset_per_radian);
  }
  std::vector<Vertex> simplex{Vertex{start, evaluate(start)}};
  for (int k = 0; k < n; ++k) {
    std::vector<double> x = start;
    x[static_cast<size_t>(k)] += step;
    simplex.push_back(Vertex{x, evaluate(x)});
  }
  SensorTiltResult r;
  r.frames = static_cast<int>(frames.size());
  r.residual_before = simplex[0].t.residual;
  r.tracked_before = simplex[0].t.tracked;
  auto by_residual = [](const Vertex& a, const Vertex& b) { return a.t.residual < b.t.residual; };
  auto report = [&] {
    if (!options.on_trial) return;
    const Vertex& b = *std::min_element(simplex.begin(), simplex.end(), by_residual);
    options.on_trial(objective.trials(), b.x.data(), b.t.residual);
  };
  report();
  // Nelder-Mead (reflection, expansion, contraction, shrink).
  auto along = [](const std::vector<double>& a, const std::vector<double>& b, double s) {
    std::vector<double> x(a.size());
    for (size_t i = 0; i < a.size(); ++i) x[i] = a[i] + s * (b[i] - a[i]);
    return x;
  };
  while (objective.trials() + n <= options.max_trials) {
    std::sort(simplex.begin(), simplex.end(), by_residual);
    double size = 0.0;
    for (int k = 1; k <= n; ++k) {
      double d2 = 0.0;
      for (int i = 0; i < n; ++i) d2 += std::pow(simplex[k].x[i] - simplex[0].x[i], 2);
      size = std::max(size, std::sqrt(d2));
    }
    if (size < tolerance) break;
    std::vector<double> centroid(static_cast<size_t>(n), 0.0);
    for (int k = 0; k < n; ++k)
      for (int i = 0; i < n; ++i) centroid[i] += simplex[k].x[i] / n;
    Vertex& worst = simplex[static_cast<size_t>(n)];
    const std::vector<double> reflected = along(centroid, worst.x, -1.0);
    const Trial tr = evaluate(reflected);
    if (tr.residual < simplex[0].t.residual) {
      const std::vector<double> expanded = along(centroid, worst.x, -2.0);
      const Trial te = evaluate(expanded);
      worst = te.residual < tr.residual ? Vertex{expanded, te} : Vertex{reflected, tr};
    } else if (tr.residual < simplex[static_cast<size_t>(n - 1)].t.residual) {
      worst = {reflected, tr};
    } else {
      const bool outside = tr.residual < worst.t.residual;
      const std::vector<double> contracted = along(centroid, outside ? reflected : worst.x, 0.5);
      const Trial tc = evaluate(contracted);
      if (tc.residual < std::min(tr.residual, worst.t.residual)) {
        worst = {contracted, tc};
      } else {
        for (int k = 1; k <= n; ++k) {
          simplex[k].x = along(simplex[0].x, simplex[k].x, 0.5);
          simplex[k].t = evaluate(simplex[k].x);
        }
      }
    }
    report();
  }
  const Vertex& best = *std::min_element(simplex.begin(), simplex.end(), by_residual);
  if (best.t.tracked < kMinTracked)
    throw Error("tilt: too few frames tracked (" + std::to_string(best.t.tracked) + " of " +
                std::to_string(frames.size()) + ") with any tilt tried: check the calibration, map and start pose");
  const Calibration fitted = calibration_at(best.x);
  r.tilt[0] = best.x[0];
  r.tilt[1] = best.x[1];
  r.mirror_offset[0] = fitted.sensor.faults.mirror_offset[0];
  r.mirror_offset[1] = fitted.sensor.faults.mirror_offset[1];
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

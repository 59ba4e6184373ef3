// The calibration pipeline: options, orchestration, outputs and summary.
#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/evaluate.h"
#include "panotrack/calibrate/model_selection.h"
#include "panotrack/config.h"

#include <Eigen/QR>
#include <ceres/rotation.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <optional>
#include <sstream>

#include "panotrack/calibrate/internal.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/io/calibration.h"
#include "panotrack/lut/radius_table.h"

namespace pano {

using namespace calib_internal;

int CalibrateOptions::Threads() const { return ThreadCount(num_threads); }

FreeFaults DefaultFreeFaults(MirrorModel model) {
  FreeFaults f;
  if (model == MirrorModel::kUnified) {
    // Its viewpoint's offset is a shift of every board; omnidir's lens and
    // pixel grid.
    f.tangential = true;
    f.skew = true;
    return f;
  }
  f.decentre = true;
  f.camera_tilt = model != MirrorModel::kSphere;
  return f;
}

FreeFaults ParseFreeFaults(const std::string& list, MirrorModel model, int* distortion_terms) {
  if (list == "auto") return DefaultFreeFaults(model);
  FreeFaults f;
  if (list == "none") return f;
  int radial = 0;
  std::stringstream in(list);
  std::string name;
  while (std::getline(in, name, ',')) {
    if (name == "decentre") f.decentre = true;
    else if (name == "camera-tilt") f.camera_tilt = true;
    else if (name == "tangential") f.tangential = true;
    else if (name == "k3") f.k3 = true;
    else if (name == "skew") f.skew = true;
    else if (name == "sensor-tilt") f.sensor_tilt = true;
    else if (name == "k1") radial = std::max(radial, 1);
    else if (name == "k2") radial = 2;
    else
      throw Error("--free: unknown parameter '" + name +
                  "' (expected auto, none or a list of decentre, camera-tilt, k1, k2, tangential, k3, skew, sensor-tilt)");
  }
  if (radial > 0) {
    if (!distortion_terms) throw Error("--free: k1 and k2 are set with the lens distortion terms");
    *distortion_terms = radial;
  }
  return f;
}

void CalibrateOptions::Check() const {
  if (model != MirrorModel::kSphere && model != MirrorModel::kConic && model != MirrorModel::kAsphere &&
      model != MirrorModel::kUnified)
    throw Error("--model: expected sphere, conic, asphere or unified");
  if (asphere_terms < 1 || asphere_terms > 2)
    throw Error("--asphere-terms: expected 1 (a4) or 2 (a4, a6), got " + std::to_string(asphere_terms));
  if (select_model && (selection_folds < 2 || selection_folds > 100))
    throw Error("model selection: expected 2..100 folds, got " + std::to_string(selection_folds));
  if (select_model && !(selection_margin >= 0.0 && selection_margin < 1.0))
    throw Error("model selection: expected a margin in [0, 1)");
  if (select_model && !(selection_max_focal_rel_std > 0.0))
    throw Error("model selection: selection_max_focal_rel_std: expected a positive fraction");
  if (distortion_terms < -1 || distortion_terms > 2)
    throw Error("--distortion: expected 0, 1 or 2 radial terms, got " + std::to_string(distortion_terms));
  if (!(huber_px >= 0.0) || !std::isfinite(huber_px))
    throw Error("--huber: expected a non-negative number of pixels (0: plain least squares)");
  if (max_iterations < 1 || max_iterations > 100000)
    throw Error("--max-iterations: expected 1..100000, got " + std::to_string(max_iterations));
  if (!(max_rms_px > 0.0)) throw Error("--max-rms: expected a positive number of pixels");
  if (!std::isfinite(full_weight_px))
    throw Error("--full-weight: expected a number of pixels per square (0: uniform weights)");
  if (!(fault_warning_std > 0.0)) throw Error("fault warning threshold: expected a positive number");
  if (!(scale_warning_rel_std > 0.0)) throw Error("scale warning threshold: expected a positive fraction");
  CheckThreadCount(num_threads, "--threads");
}

namespace {

int MinImages(bool poses_known) { return poses_known ? 2 : 3; }

void CheckViewCount(size_t n_found, size_t n_total, bool poses_known, const CalibrateOptions& o,
                    const std::vector<std::string>& not_found, bool charuco = false) {
  const size_t need = MinImages(poses_known);
  if (n_found == 0) {
    std::string list;
    for (const std::string& f : not_found) list += (list.empty() ? "" : ", ") + f;
    if (charuco)
      throw Error("no ChArUco board (" + std::to_string(kMinPartialCorners) +
                  " corners or more) found in any of the " + std::to_string(n_total) + " images (" + list +
                  "): check the board's size, marker and dictionary against the images");
    throw Error("no chessboard found in any of the " + std::to_string(n_total) +
                " images (" + list + "): check board.cols/board.rows (inner corners) against the images");
  }
  if (n_found < need)
    throw Error("the board was found in only " + std::to_string(n_found) + " of " + std::to_string(n_total) +
                " images; the " + MirrorModelName(o.model) + " fit with " +
                (poses_known ? "known" : "unknown") + " board poses needs at least " +
                std::to_string(need) + " (more images, boards at several distances and azimuths)");
}

// Known poses are used when every view has one (and they are not ignored).
bool PosesKnown(const std::vector<BoardView>& views, const CalibrateOptions& options) {
  bool all_known = !views.empty();
  for (const BoardView& v : views) all_known = all_known && v.has_pose;
  return all_known && !options.ignore_known_poses;
}

// Warnings about the views themselves, which every fit of them carries.
std::vector<std::string> InputWarnings(const std::vector<BoardView>& views, const CalibrateOptions& options) {
  bool all_known = !views.empty(), any_known = false;
  for (const BoardView& v : views) {
    all_known = all_known && v.has_pose;
    any_known = any_known || v.has_pose;
  }
  if (any_known && !all_known && !options.ignore_known_poses)
    return {"some images have board poses and some not: all poses are estimated"};
  return {};
}

// The calibration file's contents: the fit's extras and a comment that
// names the model, the undetermined parameters and the warnings.
void Describe(CalibrationResult* result, bool poses_known, const std::string& units,
              const CalibrateOptions& options) {
  CalibrationResult& res = *result;
  Calibration& c = res.calib;
  c.units = units;
  for (const ParameterEstimate& p : res.parameters)
    if (!p.fixed && std::isfinite(p.stddev)) c.extras[p.name + "_std"] = p.stddev;
  c.extras["rms_px"] = res.rms_px;
  if (std::isfinite(res.fit_rms_px)) c.extras["fit_rms_px"] = res.fit_rms_px;
  if (std::isfinite(res.rms_raw_px)) c.extras["rms_raw_px"] = res.rms_raw_px;
  c.images.clear();
  for (size_t i = 0; i < res.views.size(); ++i) {
    const BoardView& v = res.views[i];
    CalibrationImage im;
    im.file = v.file.empty() ? "image_" + std::to_string(v.image_index >= 0 ? v.image_index : static_cast<int>(i))
                             : v.file;
    im.method = v.method;
    im.corners = static_cast<int>(v.corners.size());
    im.rms_px = res.image_rms[i];
    im.rvec = v.rvec;
    im.tvec = v.tvec;
    c.images.push_back(im);
  }
  c.images_not_found = res.not_found_files;
  c.software = std::string("panotrack ") + PANO_VERSION;
  std::ostringstream cm;
  cm << "panocalib calibrate: " << MirrorModelName(options.model) << " model, " << res.views.size()
     << " boards, " << (poses_known ? "known" : "unknown (estimated)") << " board poses, RMS "
     << res.rms_px << " px";
  if (std::isfinite(res.fit_rms_px)) cm << " (the fit's own " << res.fit_rms_px << " px)";
  if (std::isfinite(res.rms_raw_px)) cm << " (" << res.rms_raw_px << " px on the detector's corners)";
  cm << ".\n";
  std::vector<std::string> undetermined;
  for (const ParameterEstimate& p : res.parameters)
    if (!p.fixed && !std::isfinite(p.stddev)) undetermined.push_back(p.name);
  if (!undetermined.empty()) {
    cm << "Not determined by the data (no standard deviation):";
    for (const std::string& u : undetermined) cm << " " << u;
    cm << "\n";
  }
  for (const std::string& w : res.warnings) cm << "Warning: " << w << "\n";
  c.comment = cm.str();
  c.sensor.Check("calibration result");
}

// Checks the fit (throws when its RMS is too high), warns about outlying
// images after the `warnings` given, and fills the calibration file's contents.
void Finish(CalibrationResult* result, bool poses_known, const std::string& units, const CalibrateOptions& options,
            const std::vector<std::string>& warnings) {
  CalibrationResult& res = *result;
  res.warnings.insert(res.warnings.begin(), warnings.begin(), warnings.end());
  if (res.rms_px > options.max_rms_px)
    throw Error("calibration failed: RMS reprojection error " + std::to_string(res.rms_px) +
                " px exceeds " + std::to_string(options.max_rms_px) +
                " px (wrong model, wrong board size, or a failed initialisation: " + res.init_summary + ")");
  for (size_t i = 0; i < res.image_rms.size(); ++i)
    if (res.image_rms[i] > std::max(1.0, 4.0 * res.rms_px))
      res.warnings.push_back(res.views[i].file + ": RMS " + std::to_string(res.image_rms[i]) +
                             " px, far above the others (a misdetected or moved board?)");
  Describe(result, poses_known, units, options);
}

// A start at a previous fit: its sensor and its boards' poses.
InitialEstimate StartFrom(const CalibrationResult& fit, const std::string& summary) {
  InitialEstimate start;
  start.sensor = fit.calib.sensor;
  start.summary = summary;
  for (const BoardView& v : fit.views) start.poses.push_back(PackPose(v));
  return start;
}

// Initialize, timed when verbose.
InitialEstimate TimedInitialize(const std::vector<BoardView>& views, const TargetBoard& board, int width,
                                int height, bool poses_known, const CalibrateOptions& options) {
  const auto t_init = std::chrono::steady_clock::now();
  InitialEstimate init = Initialize(views, board, width, height, poses_known, options);
  if (options.on_log) {
    char line[96];
    std::snprintf(line, sizeof line, "[initialisation: %.2f s, %zu starts to refine]",
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t_init).count(),
                  1 + init.alternatives.size());
    options.on_log(line);
  }
  return init;
}

// The best start and the other starts (the conic's basins along its
// near-degenerate valley, whose fits converge slowly and rank only at the
// end) are fitted in parallel; the best final fit is kept, the earlier start
// on a tie, so the result does not depend on the thread count. Starts that
// fail are named in the kept fit's init_summary.
CalibrationResult FitBestStart(const std::vector<BoardView>& views, const TargetBoard& board,
                               const InitialEstimate& init, bool poses_known,
                               const CalibrateOptions& options) {
  std::vector<const InitialEstimate*> starts = {&init};
  for (const InitialEstimate& alt : init.alternatives) starts.push_back(&alt);
  const int n = static_cast<int>(starts.size()), threads = options.Threads();
  std::vector<CalibrationResult> fits(n);
  std::vector<std::string> errors(n);
  std::vector<char> ok(n, 0);
  ParallelFor(
      n,
      [&](int k) {
        try {
          fits[k] = FitCalibration(views, board, *starts[k], poses_known, options, n > 1 ? 1 : threads);
          ok[k] = 1;
        } catch (const Error& e) {
          errors[k] = e.what();  // that start failed; the others stand
        }
      },
      true, threads);
  int best = -1;
  double seconds = 0.0;
  for (int k = 0; k < n; ++k) {
    if (!ok[k]) continue;
    seconds += fits[k].seconds_fit;
    if (best < 0 || fits[k].fit_cost < fits[best].fit_cost) best = k;  // what the fit minimises
  }
  if (best < 0) throw Error(errors[0]);
  CalibrationResult res = fits[best];
  res.seconds_fit = seconds;
  if (best > 0) res.init_summary = starts[best]->summary + " (kept); " + init.summary;
  for (int k = 0; k < n; ++k)
    if (!ok[k]) res.init_summary += "; " + starts[k]->summary + ": fit failed (" + errors[k] + ")";
  return res;
}

// The unified model's fit moved along the valley where xi, f and the lens's
// k1 trade: refitted from other values of xi (f scaled so that the horizon
// keeps its image radius, k1 k2 reset, the rig faults and the board poses
// kept), the lowest cost kept. The starts are fitted without the faults, and
// with them freed the fit can stay in the basin they found: on boards of a
// camera with xi 1.28 and a sheared pixel grid, xi 1.01 at 0.156 px where
// the truth fits at 0.136 px.
CalibrationResult ExploreUnifiedValley(const std::vector<BoardView>& views, const TargetBoard& board,
                                       CalibrationResult fit, bool poses_known, const CalibrateOptions& options) {
  const SensorParams<double>& p = fit.calib.sensor.params;
  if (!p.unified) return fit;
  const double m = 1.0 / p.xi, horizon_radius = p.focal_px * m * (1.0 + m * m * (p.k1 + m * m * p.k2));
  InitialEstimate starts;
  for (double xi : {0.8, 1.0, 1.3, 1.6, 2.0}) {
    if (std::abs(xi - p.xi) < 0.1) continue;
    InitialEstimate st = StartFrom(fit, "the unified valley from xi " + std::to_string(xi));
    SensorParams<double>& q = st.sensor.params;
    q.xi = xi;
    q.focal_px = horizon_radius * xi;
    q.k1 = q.k2 = 0.0;
    q.rim_radius = 0.0;
    if (starts.poses.empty()) starts = st;
    else starts.alternatives.push_back(st);
  }
  if (starts.poses.empty()) return fit;
  try {
    CalibrationResult moved = FitBestStart(views, board, starts, poses_known, options);
    // Lower in both: under the Huber loss a fit that gives up a few corners
    // as outliers can cost less and map the board worse.
    if (moved.fit_cost < fit.fit_cost && moved.rms_px < fit.rms_px) {
      moved.init_summary += "; kept over the fit from " + fit.init_summary;
      return moved;
    }
  } catch (const Error&) {
    // No start along the valley fits: the first fit stands.
  }
  return fit;
}

// Logs each step's wall time through `log` (when set).
class StepClock {
 public:
  explicit StepClock(std::function<void(const std::string&)> log) : log_(std::move(log)) {}
  void Done(const char* step) {
    const auto now = std::chrono::steady_clock::now();
    if (log_) {
      char line[128];
      std::snprintf(line, sizeof line, "[%s: %.2f s]", step, std::chrono::duration<double>(now - last_).count());
      log_(line);
    }
    last_ = now;
  }
  double Seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::function<void(const std::string&)> log_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now(), last_ = start_;
};

// What the steps of Calibrate share: the input, the detections so far, the
// current fit, and the warnings that every later fit carries.
struct Pipeline {
  Pipeline(const TargetSet& t, const std::vector<cv::Mat>& im, const CalibrateOptions& o)
      : targets(t), images(im), options(o) {}
  const TargetSet& targets;
  const std::vector<cv::Mat>& images;
  CalibrateOptions options;  // with the model chosen, when the user asked for a choice
  bool poses_known = false;
  DetectionResult det;
  CalibrationResult res;
  std::vector<std::string> carried;
  LimbObservation limb;  // the mirror's limb, once measured
  // Every board used, with the corners as the detector found them (raw, or
  // mapped back from an unwarped view), for the raw-corner figure.
  std::vector<BoardView> found_views;
};

// The limb for a refit's start, its points weighted against the corners'
// scatter in the current fit (both then count in the same pixels).
void AddLimb(const Pipeline& p, InitialEstimate* start) {
  start->limb = p.limb;
  if (p.limb.Empty()) return;
  const double corner_sigma = p.res.rms_px / std::sqrt(2.0);
  start->limb.weight = std::clamp(corner_sigma / p.limb.point_sigma_px, 0.1, 100.0);
}

// Measures the mirror's limb near where the current fit puts it.
void MeasureLimbStep(Pipeline* p) {
  if (!p->options.use_limb || p->res.calib.sensor.model != MirrorModel::kSphere) return;
  p->limb = MeasureLimb(p->images, p->res.calib.sensor, LimbOptions(), p->options.Threads());
  if (p->limb.Empty())
    p->carried.push_back("the mirror's limb is not clean in enough of the images: the sphere's centre off the "
                         "axis and the principal point rest on the boards alone");
}

void CheckImages(const TargetSet& targets, const std::vector<cv::Mat>& images) {
  if (images.size() != targets.images.size()) throw Error("calibration: one image per target entry expected");
  for (size_t i = 1; i < images.size(); ++i)
    if (images[i].size() != images[0].size())
      throw Error(targets.images[i].resolved + ": image size differs from the first image's");
}

// Step 4b: the refit's start: the fitted boards at their fitted poses, the
// new ones at their known poses or at their poses through the fitted sensor
// (left out when that fails), in image order.
void StartWithUnwarpedBoards(const Pipeline& p, const std::vector<BoardView>& base, std::vector<BoardView> extra,
                             std::vector<BoardView>* views, InitialEstimate* start) {
  struct Item {
    BoardView view;
    std::array<double, 6> pose;
  };
  const TargetBoard& board = p.targets.board;
  const Sensor& sensor = p.res.calib.sensor;
  std::vector<Item> items;
  for (const BoardView& v : base) items.push_back({v, PackPose(v)});
  if (p.poses_known) OrderCornersByKnownPose(board, sensor.params.cx, sensor.params.cy, &extra);
  for (const BoardView& v : extra) {
    std::array<double, 6> pose{};
    if (p.poses_known) {
      pose = PackPose(v);
    } else if (!InitialPoseFromSensor(v, board, sensor, &pose) && !PoseFromRays(v, board, sensor, &pose)) {
      continue;
    }
    items.push_back({v, pose});
  }
  std::sort(items.begin(), items.end(),
            [](const Item& a, const Item& b) { return a.view.image_index < b.view.image_index; });
  start->sensor = sensor;
  start->sensor.params.rim_radius = 0.0;
  start->summary = "refit with the unwarped boards from the previous fit; " + p.res.init_summary;
  for (const Item& it : items) {
    views->push_back(it.view);
    start->poses.push_back(it.pose);
  }
}

// The boards found in unwarped views whose RMS is far above the fit's ("" when none).
std::string OutlyingUnwarpedBoards(const CalibrationResult& fit) {
  std::string files;
  for (size_t i = 0; i < fit.views.size(); ++i)
    if (fit.views[i].method == "unwarped" && fit.image_rms[i] > std::max(1.0, 3.0 * fit.rms_px))
      files += (files.empty() ? "" : ", ") + fit.views[i].file;
  return files;
}

// Takes the images whose board `views` now holds off the not-found lists.
void DropFoundImages(const std::vector<BoardView>& views, DetectionResult* det) {
  std::vector<int> missing;
  std::vector<std::string> missing_files;
  for (size_t k = 0; k < det->not_found.size(); ++k) {
    bool used = false;
    for (const BoardView& v : views) used = used || v.image_index == det->not_found[k];
    if (!used) {
      missing.push_back(det->not_found[k]);
      missing_files.push_back(det->not_found_files[k]);
    }
  }
  det->not_found = missing;
  det->not_found_files = missing_files;
}

// Step 4: images without a board retried in unwarped views; when any is
// found, the fit is repeated with them and kept when the new boards fit
// like the others.
// The fit again with the boards of unwarped views `extra` beside `base`;
// nothing when it fails or when those boards fit far worse than the others
// (then `boards`, what they are, goes into the run's warnings with
// `outcome`).
std::optional<CalibrationResult> RefitWithUnwarpedBoards(Pipeline* p, const std::vector<BoardView>& base,
                                                         const std::vector<BoardView>& extra,
                                                         const std::string& what, const std::string& boards,
                                                         const std::string& outcome) {
  std::vector<BoardView> views;
  InitialEstimate start;
  StartWithUnwarpedBoards(*p, base, extra, &views, &start);
  std::optional<CalibrationResult> again =
      TryRefit(what, views, p->targets.board, start, p->poses_known, p->targets.units, p->options, &p->carried);
  if (!again) return std::nullopt;
  const std::string outliers = OutlyingUnwarpedBoards(*again);
  if (outliers.empty()) return again;
  p->carried.push_back(boards + " (" + outliers + ") fit far worse than the others: " + outcome);
  return std::nullopt;
}

// Step 4a: the images without a board searched through the first fit
// (FindMissingBoards); the fit repeated with those found.
void RetryUnwarped(Pipeline* p) {
  const std::vector<BoardView> extra = FindMissingBoards(p->targets, p->images, p->det, p->res.views,
                                                        p->res.calib.sensor, p->options.Threads(), &p->carried);
  if (extra.empty()) return;
  std::optional<CalibrationResult> again =
      RefitWithUnwarpedBoards(p, p->res.views, extra, "the refit with the boards found in unwarped views",
                              "boards found in unwarped views", "left out, the previous fit stands");
  if (!again) return;
  p->res = std::move(*again);
  for (const BoardView& v : p->res.views)
    if (std::any_of(extra.begin(), extra.end(), [&](const BoardView& e) { return e.image_index == v.image_index; }))
      p->found_views.push_back(v);
  DropFoundImages(p->res.views, &p->det);
}

// Step 5: every corner (the unwarped boards' too) located again on the board
// plane through the fitted model, then the model fitted again from where it
// was. Corners left biased here bias the whole fit, so this comes last.
void RefineThroughModel(Pipeline* p) {
  for (int pass = 0; pass < p->options.refine_passes; ++pass) {
    std::vector<BoardView> views = p->res.views;
    if (RefineCornersThroughModel(p->images, p->targets.board, p->res.calib.sensor, &views,
                                  p->options.Threads()) == 0)
      break;
    const InitialEstimate start =
        StartFrom(p->res, "refit on corners refined through the model; " + p->res.init_summary);
    std::optional<CalibrationResult> again =
        TryRefit("the refit on corners refined through the model", views, p->targets.board, start,
                 p->poses_known, p->targets.units, p->options, &p->carried);
    if (!again) break;
    p->res = std::move(*again);
  }
}

// Step 5b: the boards of the unwarped views searched for again, with the
// images still without one, through the final model. The first search went
// through the first fit, which can place a board near the limb a little off
// or miss it; searched through the final model they are the boards and
// corners `panocalib evaluate` finds through the calibration. When the
// boards change, the fit is repeated and the corners refined through it.
void RedetectUnwarped(Pipeline* p) {
  std::vector<int> missing = p->det.not_found;
  std::vector<BoardView> raw;
  for (const BoardView& v : p->res.views) {
    if (v.method == "unwarped") missing.push_back(v.image_index);
    else raw.push_back(v);
  }
  if (missing.empty() || raw.empty()) return;
  std::sort(missing.begin(), missing.end());
  std::vector<std::string> warnings;
  const std::vector<BoardView> extra = calib_internal::FindUnwarpedBoards(
      p->targets, p->images, missing, raw, p->res.calib.sensor, p->options.Threads(), &warnings);
  // Unchanged: the same images, the same corners as first found.
  std::vector<BoardView> before;
  for (const BoardView& v : p->found_views)
    if (v.method == "unwarped") before.push_back(v);
  bool same = before.size() == extra.size();
  for (size_t k = 0; same && k < extra.size(); ++k) {
    same = before[k].image_index == extra[k].image_index && before[k].corners.size() == extra[k].corners.size();
    for (size_t j = 0; same && j < extra[k].corners.size(); ++j)
      same = (before[k].corners[j] - extra[k].corners[j]).norm() < 1e-3;
  }
  if (same) return;
  std::optional<CalibrationResult> again =
      RefitWithUnwarpedBoards(p, raw, extra, "the refit with the boards found again through the final model",
                              "boards found in views unwarped through the final model", "the previous fit stands");
  if (!again) return;
  p->carried.insert(p->carried.end(), warnings.begin(), warnings.end());
  p->res = std::move(*again);
  std::vector<BoardView> found;
  for (const BoardView& v : p->found_views)
    if (v.method != "unwarped") found.push_back(v);
  for (const BoardView& v : p->res.views)
    if (v.method == "unwarped") found.push_back(v);
  p->found_views = found;
  // The images without a board now.
  DetectionResult& det = p->det;
  det.not_found.clear();
  det.not_found_files.clear();
  for (int i = 0; i < static_cast<int>(p->targets.images.size()); ++i) {
    bool used = false;
    for (const BoardView& v : p->res.views) used = used || v.image_index == i;
    if (!used) {
      det.not_found.push_back(i);
      det.not_found_files.push_back(p->targets.images[static_cast<size_t>(i)].file);
    }
  }
  RefineThroughModel(p);
}

// On request (CalibrateOptions::select_model): the candidates scored by
// cross-validation on the corners refined so far (the conic's fit, p->res,
// starts that candidate), the chosen one's fit to all boards finished as the
// calibration and its corners refined through it.
ModelSelection SelectModelAndRefit(Pipeline* p, const CalibrateOptions& options) {
  const Sensor& s = p->res.calib.sensor;
  if (options.selection_fallback &&
      !SelectionPossible(static_cast<int>(p->res.views.size()), options.selection_folds)) {
    p->options = options;
    p->options.select_model = false;
    p->carried.push_back(std::to_string(p->res.views.size()) +
                         " boards are too few to choose the model by cross-validation (4 at least): the " +
                         MirrorModelName(options.model) + " model fitted");
    p->res = CalibrateViews(p->res.views, p->targets.board, s.image_width, s.image_height, p->targets.units,
                            p->options);
    RefineThroughModel(p);
    return {};
  }
  ModelSelection sel = SelectModel(p->res.views, p->targets.board, s.image_width, s.image_height, p->targets.units,
                                   options, &p->res, &p->options);
  p->carried.insert(p->carried.end(), sel.warnings.begin(), sel.warnings.end());
  p->options = sel.options;
  std::optional<CalibrationResult> chosen =
      TryRefit("the chosen model's fit", sel.fit.views, p->targets.board,
               StartFrom(sel.fit, "model selection: " + sel.reason), p->poses_known, p->targets.units, p->options,
               &p->carried);
  p->res = chosen ? std::move(*chosen)
                  : CalibrateViews(p->res.views, p->targets.board, s.image_width, s.image_height, p->targets.units,
                                   p->options);
  RefineThroughModel(p);
  return sel;
}

// Step 6 (on request): the last fit again with the mirror's limb, its points
// weighted against the refined corners' scatter.
void RefitWithLimb(Pipeline* p) {
  if (p->limb.Empty()) return;
  InitialEstimate start = StartFrom(p->res, "refit with the mirror's limb; " + p->res.init_summary);
  AddLimb(*p, &start);
  std::optional<CalibrationResult> again = TryRefit("the refit with the mirror's limb", p->res.views,
                                                    p->targets.board, start, p->poses_known, p->targets.units,
                                                    p->options, &p->carried);
  if (again) p->res = std::move(*again);
  else p->limb = LimbObservation();
}

// The figures `panocalib evaluate` gives on the calibration's images
// (CalibrationResult::rms_raw_px, and rms_px in place of the fit's own):
// the final model on the detector's corners, only each board's pose fitted
// (`--no-refine`); then those corners refined through the model at the
// robust fit's pose and each pose fitted again, refine_passes times, as
// evaluate does. The fit's own RMS is over corners refined through the model
// as it was being fitted, which follow it (on a board at the limb by a tenth
// of a pixel): the figure reported is the one a check of the calibration
// repeats. When the corners cannot be scored, the fit's own stays rms_px.
void ScoreAsEvaluate(const Pipeline& p, CalibrationResult* res) {
  res->corners_refined = p.options.refine_passes > 0;
  std::vector<BoardView> views = p.found_views;
  std::sort(views.begin(), views.end(),
            [](const BoardView& a, const BoardView& b) { return a.image_index < b.image_index; });
  EvaluateOptions eo;
  eo.huber_px = p.options.huber_px;
  eo.full_weight_px = p.options.full_weight_px;
  eo.num_threads = p.options.num_threads;
  eo.refine_passes = p.options.refine_passes;
  const Sensor& sensor = res->calib.sensor;
  try {
    const EvaluationResult raw = EvaluateViews(views, p.targets.board, sensor, eo);
    res->rms_raw_px = raw.rms_px;
    res->raw_boards = raw.boards_fitted;
    const EvaluationResult e =
        RefineAndEvaluate(p.images, p.targets.board, sensor, eo, p.options.Threads(), &views, raw);
    res->fit_rms_px = res->rms_px;
    res->rms_px = e.rms_px;
    res->boards_scored = e.boards_fitted;
  } catch (const Error& e) {
    res->warnings.push_back(std::string("the detector's corners could not be scored through the final model (") +
                            e.what() + "): the RMS given is the fit's own");
  }
}

// The final result: the images without a board, every carried warning, the
// calibration file's comment, the times.
CalibrationResult Complete(Pipeline* p, const StepClock& clock) {
  CalibrationResult& res = p->res;
  res.not_found = p->det.not_found;
  if (!p->limb.Empty()) {
    res.limb = p->limb;
    res.limb_rms_px = LimbRmsPx(p->limb, res.calib.sensor);
  }
  res.not_found_files = p->det.not_found_files;
  for (const std::string& w : p->carried)
    if (std::find(res.warnings.begin(), res.warnings.end(), w) == res.warnings.end())
      res.warnings.push_back(w);
  ScoreAsEvaluate(*p, &res);
  Describe(&res, p->poses_known, p->targets.units, p->options);
  res.seconds_detect = p->det.seconds;
  res.seconds_fit = clock.Seconds() - p->det.seconds;
  res.calib.images_total = static_cast<int>(p->images.size());
  if (!res.not_found_files.empty()) {
    std::string list;
    for (const std::string& f : res.not_found_files) list += " " + f;
    res.calib.comment += "No board found (skipped):" + list + "\n";
  }
  return res;
}

}  // namespace

namespace calib_internal {

namespace {

// Median horizontal distance and height of the fitted boards' centres:
// where the unwarped views look for the missing boards.
struct BoardPlace {
  double distance = 0.0, height = 0.0;
};
BoardPlace TypicalBoardPlace(const std::vector<BoardView>& views, const TargetBoard& board) {
  std::vector<double> dist, hgt;
  for (const BoardView& v : views) {
    const double mid[3] = {0.5 * (board.cols - 1) * board.square, 0.5 * (board.rows - 1) * board.square, 0.0};
    Eigen::Vector3d centre;
    ceres::AngleAxisRotatePoint(v.rvec.data(), mid, centre.data());
    centre += v.tvec;
    dist.push_back(std::hypot(centre.x(), centre.y()));
    hgt.push_back(centre.z());
  }
  std::nth_element(dist.begin(), dist.begin() + dist.size() / 2, dist.end());
  std::nth_element(hgt.begin(), hgt.begin() + hgt.size() / 2, hgt.end());
  return {dist[dist.size() / 2], hgt[hgt.size() / 2]};
}

}  // namespace

namespace {

// Each corner's residual less what its grid neighbours' residuals predict
// there (an affine trend over the board points within 2 of it, itself left
// out): what the model's own error, smooth across a board, does not
// explain. NaN where the corner has no residual or fewer than 5 neighbours
// with one.
std::vector<double> ResidualsOffNeighbours(const BoardView& view, const TargetBoard& board,
                                           const std::vector<Eigen::Vector2d>& residuals) {
  std::vector<int> index_of(static_cast<size_t>(board.cols) * board.rows, -1);
  for (size_t k = 0; k < view.corners.size(); ++k) index_of[static_cast<size_t>(view.PointId(k))] = static_cast<int>(k);
  std::vector<double> off(view.corners.size(), NAN);
  for (size_t k = 0; k < view.corners.size(); ++k) {
    if (!residuals[k].allFinite()) continue;
    const int i = view.PointId(k) % board.cols, j = view.PointId(k) / board.cols;
    std::vector<Eigen::Vector3d> rows;
    std::vector<Eigen::Vector2d> values;
    for (int dj = -2; dj <= 2; ++dj)
      for (int di = -2; di <= 2; ++di) {
        const int ni = i + di, nj = j + dj;
        if ((di == 0 && dj == 0) || ni < 0 || nj < 0 || ni >= board.cols || nj >= board.rows) continue;
        const int n = index_of[static_cast<size_t>(nj * board.cols + ni)];
        if (n < 0 || !residuals[static_cast<size_t>(n)].allFinite()) continue;
        rows.emplace_back(1.0, di, dj);
        values.push_back(residuals[static_cast<size_t>(n)]);
      }
    if (rows.size() < 5) continue;
    Eigen::MatrixX3d A(rows.size(), 3);
    Eigen::MatrixX2d b(rows.size(), 2);
    for (size_t r = 0; r < rows.size(); ++r) {
      A.row(static_cast<Eigen::Index>(r)) = rows[r].transpose();
      b.row(static_cast<Eigen::Index>(r)) = values[r].transpose();
    }
    // The trend's value at the corner itself (di = dj = 0): its constant term.
    const Eigen::Matrix<double, 3, 2> trend = A.colPivHouseholderQr().solve(b);
    off[k] = (residuals[k] - trend.row(0).transpose()).norm();
  }
  return off;
}

}  // namespace

bool DropStrayCorners(const TargetBoard& board, const Sensor& sensor, BoardView* view) {
  constexpr double kFloorPx = 1.0, kMedianFactor = 5.0;
  // max(1 px, 5x the median of `v`'s finite values); infinity when none.
  auto limit_of = [&](std::vector<double> v) {
    v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
    if (v.empty()) return std::numeric_limits<double>::infinity();
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return std::max(kFloorPx, kMedianFactor * v[v.size() / 2]);
  };
  // The robust fit's pose, which the stray corners cannot pull.
  EvaluateOptions robust;
  robust.least_squares_pose = false;
  for (int round = 0; round < 3; ++round) {
    const BoardPoseFit fit = FitBoardPose(*view, board, sensor, robust);
    if (!fit.ok) return true;  // judged by the fit that follows, as any board
    std::vector<double> error(fit.residuals.size());
    for (size_t k = 0; k < error.size(); ++k) error[k] = fit.residuals[k].norm();
    const std::vector<double> off = ResidualsOffNeighbours(*view, board, fit.residuals);
    const double error_limit = limit_of(error), off_limit = limit_of(off);
    BoardView kept = *view;
    kept.corners.clear();
    kept.ids.clear();
    for (size_t k = 0; k < view->corners.size(); ++k) {
      // Stray: far off the pose and off its neighbours both.
      if (std::isfinite(error[k]) && error[k] > error_limit && std::isfinite(off[k]) && off[k] > off_limit) continue;
      kept.corners.push_back(view->corners[k]);
      kept.ids.push_back(view->PointId(k));
    }
    if (kept.corners.size() == view->corners.size()) return true;
    if (!EnoughCorners(kept.ids, board)) return false;
    *view = kept;
  }
  return true;
}

std::vector<BoardView> FindUnwarpedBoards(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                          const std::vector<int>& missing, const std::vector<BoardView>& fitted,
                                          const Sensor& sensor, int threads, std::vector<std::string>* warnings) {
  if (missing.empty() || fitted.empty()) return {};
  const BoardPlace place = TypicalBoardPlace(fitted, targets.board);
  const int n_missing = static_cast<int>(missing.size());
  std::vector<std::vector<Eigen::Vector2d>> corners(n_missing);
  std::vector<std::vector<int>> ids(n_missing);
  std::vector<std::string> failures(n_missing);
  std::vector<char> ok(n_missing, 0);
  ParallelFor(
      n_missing,
      [&](int k) {
        ok[k] = DetectBoardUnwarped(images[missing[k]], targets.board, sensor, place.distance, place.height,
                                    &corners[k], n_missing > 1 ? 1 : threads, &failures[k], &ids[k]);
      },
      true, threads);
  std::vector<BoardView> found;
  for (int k = 0; k < n_missing; ++k) {
    if (ok[k]) {
      BoardView view = ViewOfImage(targets, missing[k], corners[k], "unwarped");
      view.ids = ids[k];
      if (DropStrayCorners(targets.board, sensor, &view)) {
        found.push_back(view);
      } else if (warnings) {
        warnings->push_back(view.file + ": the board found in an unwarped view has too few corners where the "
                            "model puts them: left out");
      }
    } else if (!failures[k].empty() && warnings) {
      warnings->push_back(targets.images[static_cast<size_t>(missing[k])].file +
                          ": the search in unwarped views failed (" + failures[k] + ")");
    }
  }
  return found;
}

std::vector<BoardView> FindMissingBoards(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                         const DetectionResult& det, const std::vector<BoardView>& fitted,
                                         const Sensor& sensor, int threads, std::vector<std::string>* warnings) {
  std::vector<BoardView> found =
      FindUnwarpedBoards(targets, images, det.not_found, fitted, sensor, threads, warnings);
  if (!det.exhaustive_deferred) return found;
  const std::vector<BoardView> exhaustive =
      FindBoardsExhaustive(targets, images, ImagesWithout(det.not_found, found), threads);
  found.insert(found.end(), exhaustive.begin(), exhaustive.end());
  std::sort(found.begin(), found.end(),
            [](const BoardView& a, const BoardView& b) { return a.image_index < b.image_index; });
  return found;
}

std::optional<CalibrationResult> TryRefit(const std::string& what, const std::vector<BoardView>& views,
                                          const TargetBoard& board, const InitialEstimate& start,
                                          bool poses_known, const std::string& units,
                                          const CalibrateOptions& options,
                                          std::vector<std::string>* carried) {
  try {
    CalibrationResult again = FitCalibration(views, board, start, poses_known, options);
    Finish(&again, poses_known, units, options, *carried);
    return again;
  } catch (const Error& e) {
    carried->push_back(what + " failed (" + e.what() + "); the previous fit stands");
    return std::nullopt;
  }
}

}  // namespace calib_internal

CalibrationResult CalibrateViews(const std::vector<BoardView>& views_in, const TargetBoard& board, int width,
                                 int height, const std::string& units, const CalibrateOptions& options) {
  options.Check();
  if (width <= 0 || height <= 0) throw Error("calibration: image size unknown");
  std::vector<BoardView> views = views_in;
  for (const BoardView& v : views) CheckBoardView(v, board);
  const bool poses_known = PosesKnown(views, options);
  CheckViewCount(views.size(), views.size(), poses_known, options, {});
  if (poses_known) OrderCornersByKnownPose(board, 0.5 * (width - 1), 0.5 * (height - 1), &views);
  const InitialEstimate init = TimedInitialize(views, board, width, height, poses_known, options);
  CalibrationResult res =
      ExploreUnifiedValley(views, board, FitBestStart(views, board, init, poses_known, options), poses_known, options);
  Finish(&res, poses_known, units, options, InputWarnings(views, options));
  return res;
}

CalibrationResult Calibrate(const TargetSet& targets, const std::vector<cv::Mat>& images,
                            const CalibrateOptions& options) {
  options.Check();
  StepClock clock(options.on_log);
  CheckImages(targets, images);
  Pipeline p(targets, images, options);
  p.det = DetectBoards(targets, images, options, /*defer_to_unwarped=*/true);
  clock.Done("raw detection");
  p.poses_known = targets.AllPosesKnown() && !options.ignore_known_poses;
  CheckViewCount(p.det.views.size(), images.size(), p.poses_known, options, p.det.not_found_files,
                 targets.board.IsCharuco());
  p.carried = InputWarnings(p.det.views, options);
  p.carried.insert(p.carried.end(), p.det.warnings.begin(), p.det.warnings.end());
  // A model to be chosen: the conic, which holds the sphere, takes the
  // steps up to the corners refined through it, on which the candidates are
  // then scored (the detector's own corners are biased by a pixel on a
  // curved mirror's squeezed squares, far more than profiles differ).
  if (options.select_model) {
    p.options.select_model = false;
    p.options.model = MirrorModel::kConic;
  }
  p.res = CalibrateViews(p.det.views, targets.board, p.det.image_width, p.det.image_height, targets.units,
                         p.options);
  p.found_views = p.det.views;
  clock.Done("initialisation and first fit");
  MeasureLimbStep(&p);
  clock.Done("limb");
  if (options.unwarp_fallback && !p.det.not_found.empty()) {
    RetryUnwarped(&p);
    clock.Done("unwarped detection and refit");
  }
  RefineThroughModel(&p);
  clock.Done("corner refinement and refit");
  ModelSelection selection;
  if (options.select_model) {
    selection = SelectModelAndRefit(&p, options);
    clock.Done("model selection and refit");
  }
  if (options.unwarp_fallback) {
    RedetectUnwarped(&p);
    clock.Done("unwarped detection through the final model");
  }
  RefitWithLimb(&p);
  clock.Done("refit with the limb");
  CalibrationResult res = Complete(&p, clock);
  res.model_scores = std::move(selection.scores);
  res.model_chosen = selection.chosen;
  res.model_reason = selection.reason;
  return res;
}

}  // namespace pano

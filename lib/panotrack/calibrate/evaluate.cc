#include "panotrack/calibrate/evaluate.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "panotrack/calibrate/internal.h"
#include "panotrack/config.h"
#include "panotrack/core/parallel.h"
#include "panotrack/core/error.h"

namespace pano {

using namespace calib_internal;

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// One corner's reprojection residual through a fixed sensor, the board pose
// the only parameter: the calibration's whole model (rig faults and asphere
// terms included), as the calibration's fit computes it (the same rim cap).
struct PoseCornerCost {
  PoseCornerCost(const GeneralSensorParams<double>& g, const Eigen::Vector3d& board_point,
                 const Eigen::Vector2d& pixel, const Eigen::Matrix2d& sqrt_info = Eigen::Matrix2d::Identity())
      : g(g), X(board_point), obs(pixel), L(sqrt_info) {}
  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    T Xs[3];
    BoardPointInSensor(pose, X, Xs);
    T u, v;
    const GeneralSensorParams<T> gt = g.template cast<T>();
    if (g.IsAligned() ? !project(gt.aligned, Xs, &u, &v) : !ProjectGeneral(gt, Xs, &u, &v)) return false;
    WhitenedResidual(L, u, v, obs, residual);
    return true;
  }
  GeneralSensorParams<double> g;
  Eigen::Vector3d X;
  Eigen::Vector2d obs;
  Eigen::Matrix2d L;
};

// The sensor as the calibration's fit projects through it: the rim that caps
// the mirror at the image's reach (CapRadiusPx), whatever the file says.
GeneralSensorParams<double> FitModel(const Sensor& sensor) {
  GeneralSensorParams<double> g = sensor.general();
  g.aligned.rim_radius = RimForRadius(g.aligned, CapRadiusPx(sensor.image_width, sensor.image_height) /
                                                     g.aligned.focal_px);
  return g;
}

// Errors of every corner through the sensor and pose; fills the fit's
// residuals, counts and RMS.
void Score(const BoardView& view, const std::vector<Eigen::Vector3d>& pts, const GeneralSensorParams<double>& g,
           const std::array<double, 6>& pose, BoardPoseFit* fit) {
  fit->residuals.clear();
  double s2 = 0.0, worst = 0.0;
  int n = 0;
  for (size_t j = 0; j < view.corners.size(); ++j) {
    PoseCornerCost c(g, pts[view.PointId(j)], view.corners[j]);
    double r[2];
    if (!c(pose.data(), r)) {
      fit->residuals.emplace_back(NAN, NAN);
      continue;
    }
    fit->residuals.emplace_back(r[0], r[1]);
    const double e2 = r[0] * r[0] + r[1] * r[1];
    s2 += e2;
    worst = std::max(worst, e2);
    ++n;
  }
  fit->corners_used = n;
  fit->rms_px = n > 0 ? std::sqrt(s2 / n) : NAN;
  fit->max_px = n > 0 ? std::sqrt(worst) : NAN;
}

// The pose fit from one start: Ceres on the corners visible from it. The
// final cost (weighted, robust), or infinity when too few corners are
// visible or the fit fails.
double FitPoseFrom(const BoardView& view, const std::vector<Eigen::Vector3d>& pts, const GeneralSensorParams<double>& g,
                   const std::vector<Eigen::Matrix2d>& weights, const EvaluateOptions& options,
                   std::array<double, 6>* pose, std::string* failure) {
  ceres::Problem problem;
  problem.AddParameterBlock(pose->data(), 6);
  size_t n_obs = 0;
  for (size_t j = 0; j < view.corners.size(); ++j) {
    const Eigen::Vector3d& X = pts[view.PointId(j)];
    double r[2];
    if (!PoseCornerCost(g, X, view.corners[j])(pose->data(), r)) continue;
    ceres::LossFunction* loss = options.huber_px > 0 ? new ceres::HuberLoss(options.huber_px) : nullptr;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PoseCornerCost, 2, 6>(
                                 new PoseCornerCost(g, X, view.corners[j], weights[j])),
                             loss, pose->data());
    ++n_obs;
  }
  if (n_obs < 3 || n_obs * 2 < view.corners.size()) {
    *failure = "the initial pose sees only " + std::to_string(n_obs) + " of " + std::to_string(view.corners.size()) +
               " corners";
    return kInfinity;
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = 1;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (options.on_log) options.on_log(view.file + ": " + summary.BriefReport());
  bool finite = true;
  for (double v : *pose) finite = finite && std::isfinite(v);
  if (summary.termination_type == ceres::FAILURE || !finite) {
    *failure = "the pose fit failed (" + summary.message + ")";
    return kInfinity;
  }
  // Per corner it saw, so that a start that sees fewer does not win by that.
  return summary.final_cost / static_cast<double>(n_obs);
}

void Summarise(EvaluationResult* r) {
  double s2 = 0.0, worst = 0.0;
  r->boards_found = r->boards_fitted = r->corners = 0;
  for (const ImageEvaluation& im : r->images) {
    if (!im.found) continue;
    ++r->boards_found;
    if (!im.fit.ok) continue;
    ++r->boards_fitted;
    r->corners += im.fit.corners_used;
    s2 += im.fit.rms_px * im.fit.rms_px * im.fit.corners_used;
    worst = std::max(worst, im.fit.max_px);
  }
  r->rms_px = r->corners > 0 ? std::sqrt(s2 / r->corners) : NAN;
  r->max_px = r->corners > 0 ? worst : NAN;
}

}  // namespace

void EvaluateOptions::Check() const {
  if (!std::isfinite(huber_px)) throw Error("huber_px: expected a finite number");
  if (!std::isfinite(full_weight_px)) throw Error("full_weight_px: expected a finite number");
  if (refine_passes < 0 || refine_passes > 10) throw Error("refine_passes: expected 0..10");
  if (max_iterations < 1) throw Error("max_iterations: expected at least 1");
  CheckThreadCount(num_threads, "--threads");
}

BoardPoseFit FitBoardPose(const BoardView& view, const TargetBoard& board, const Sensor& sensor,
                          const EvaluateOptions& options) {
  BoardPoseFit fit;
  CheckBoardView(view, board);
  const std::vector<Eigen::Vector3d> pts = BoardPoints(board);
  const GeneralSensorParams<double> g = FitModel(sensor);
  const std::vector<Eigen::Matrix2d> weights = CornerWeights(view, board, options.full_weight_px);
  // Two starts, the better fit kept: the in-plane solve about the principal
  // point (the calibration's own), and the homography to the corners' rays
  // through the whole model, which a decentred or tilted mirror (whose image
  // is not centred on cx, cy) needs.
  std::array<std::array<double, 6>, 2> starts{};
  std::array<bool, 2> have = {InitialPoseFromSensor(view, board, sensor, &starts[0]),
                              PoseFromRays(view, board, sensor, &starts[1])};
  if (!have[0] && !have[1]) {
    fit.failure = "the board's pose through the calibration could not be initialised";
    return fit;
  }
  double best = kInfinity;
  std::array<double, 6> pose{};
  for (size_t k = 0; k < starts.size(); ++k) {
    if (!have[k]) continue;
    std::string why;
    const double cost = FitPoseFrom(view, pts, g, weights, options, &starts[k], &why);
    if (cost < best) {
      best = cost;
      pose = starts[k];
    } else if (!std::isfinite(best) && fit.failure.empty()) {
      fit.failure = why;
    }
  }
  if (!std::isfinite(best)) {
    if (fit.failure.empty()) fit.failure = "the pose fit failed from every start";
    return fit;
  }
  fit.failure.clear();
  fit.robust_rvec = Eigen::Vector3d(pose[0], pose[1], pose[2]);
  fit.robust_tvec = Eigen::Vector3d(pose[3], pose[4], pose[5]);
  if (options.least_squares_pose && (options.huber_px > 0 || options.full_weight_px > 0)) {
    // The robust fit found the basin; plain least squares from there gives
    // the pose of least RMS near it. Kept only where its RMS is lower.
    EvaluateOptions plain = options;
    plain.huber_px = 0.0;
    plain.on_log = nullptr;
    std::array<double, 6> polished = pose;
    std::string why;
    const std::vector<Eigen::Matrix2d> uniform(view.corners.size(), Eigen::Matrix2d::Identity());
    if (std::isfinite(FitPoseFrom(view, pts, g, uniform, plain, &polished, &why))) {
      BoardPoseFit robust, least_squares;
      Score(view, pts, g, pose, &robust);
      Score(view, pts, g, polished, &least_squares);
      if (least_squares.corners_used >= robust.corners_used && least_squares.rms_px < robust.rms_px) pose = polished;
    }
  }
  fit.rvec = Eigen::Vector3d(pose[0], pose[1], pose[2]);
  fit.tvec = Eigen::Vector3d(pose[3], pose[4], pose[5]);
  Score(view, pts, g, pose, &fit);
  if (fit.corners_used * 2 < static_cast<int>(view.corners.size())) {
    fit.failure = "the fitted pose sees only " + std::to_string(fit.corners_used) + " of " +
                  std::to_string(view.corners.size()) + " corners";
    return fit;
  }
  fit.ok = true;
  return fit;
}

EvaluationResult EvaluateViews(const std::vector<BoardView>& views, const TargetBoard& board,
                               const Sensor& sensor, const EvaluateOptions& options) {
  options.Check();
  const auto t0 = std::chrono::steady_clock::now();
  EvaluationResult r;
  r.model = MirrorModelName(sensor.model);
  for (const BoardView& v : views) {
    ImageEvaluation im;
    im.image_index = v.image_index;
    im.file = v.file;
    im.found = true;
    im.corners = static_cast<int>(v.corners.size());
    im.fit = FitBoardPose(v, board, sensor, options);
    if (!im.fit.ok) r.warnings.push_back(v.file + ": " + im.fit.failure);
    r.images.push_back(im);
  }
  Summarise(&r);
  r.seconds_fit = Seconds(t0);
  if (r.boards_fitted == 0)
    throw Error("no board's pose could be fitted through the calibration (" + std::to_string(views.size()) +
                " boards)");
  return r;
}

std::vector<BoardView> ViewsAtFittedPoses(const std::vector<BoardView>& views, const EvaluationResult& r) {
  std::vector<BoardView> fitted;
  for (size_t i = 0; i < views.size(); ++i) {
    if (!r.images[i].fit.ok) continue;
    fitted.push_back(views[i]);
    fitted.back().rvec = r.images[i].fit.robust_rvec;
    fitted.back().tvec = r.images[i].fit.robust_tvec;
  }
  return fitted;
}

EvaluationResult RefineAndEvaluate(const std::vector<cv::Mat>& images, const TargetBoard& board,
                                   const Sensor& sensor, const EvaluateOptions& options, int threads,
                                   std::vector<BoardView>* views, EvaluationResult r) {
  for (int pass = 0; pass < options.refine_passes; ++pass) {
    // Refinement needs each board's pose: the fitted boards only.
    std::vector<BoardView> fitted = ViewsAtFittedPoses(*views, r);
    RefineCornersThroughModel(images, board, sensor, &fitted, threads);
    for (BoardView& v : *views)
      for (const BoardView& f : fitted)
        if (f.image_index == v.image_index) v.corners = f.corners;
    r = EvaluateViews(*views, board, sensor, options);
  }
  return r;
}

EvaluationResult EvaluateCalibration(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                     const Calibration& calib, const EvaluateOptions& options) {
  options.Check();
  if (!calib.units.empty() && !targets.units.empty() && calib.units != targets.units)
    throw Error("the calibration's units (" + calib.units + ") differ from the targets' (" + targets.units +
                "): the board's size must be given in the calibration's units");
  CalibrateOptions detect;
  detect.num_threads = options.num_threads;
  detect.verbose = options.verbose;
  detect.on_log = options.on_log;
  // The detection calibrate runs: the quick raw search (the exhaustive one
  // only where too few boards are found), then the images without a board
  // searched in views unwarped through the calibration and, where those miss,
  // by the exhaustive search, so that both score the same boards.
  detect.unwarp_fallback = options.unwarp_fallback;
  DetectionResult det = DetectBoards(targets, images, detect, /*defer_to_unwarped=*/true);
  const Sensor& sensor = calib.sensor;
  if (det.image_width != sensor.image_width || det.image_height != sensor.image_height)
    throw Error("the images are " + std::to_string(det.image_width) + "x" + std::to_string(det.image_height) +
                ", the calibration's " + std::to_string(sensor.image_width) + "x" +
                std::to_string(sensor.image_height));
  if (det.views.empty())
    throw Error(targets.images.size() == 1
                    ? std::string("no board found in the image")
                    : "no board found in any of the " + std::to_string(targets.images.size()) + " images");

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<BoardView> views = det.views;
  EvaluationResult r = EvaluateViews(views, targets.board, sensor, options);
  if (options.unwarp_fallback && !det.not_found.empty()) {
    std::vector<BoardView> extra = FindMissingBoards(targets, images, det, ViewsAtFittedPoses(views, r), sensor,
                                                     detect.Threads(), &det.warnings);
    if (!extra.empty()) {
      views.insert(views.end(), extra.begin(), extra.end());
      std::sort(views.begin(), views.end(),
                [](const BoardView& a, const BoardView& b) { return a.image_index < b.image_index; });
      r = EvaluateViews(views, targets.board, sensor, options);
      // As calibrate: a board of an unwarped view that fits far worse than
      // the raw ones (a misdetection) is left out, with a warning.
      double s2 = 0.0;
      int n = 0;
      for (size_t i = 0; i < views.size(); ++i) {
        const BoardPoseFit& f = r.images[i].fit;
        if (!f.ok || views[i].method != "raw") continue;
        s2 += f.rms_px * f.rms_px * f.corners_used;
        n += f.corners_used;
      }
      const double limit = std::max(1.0, 3.0 * (n > 0 ? std::sqrt(s2 / n) : 0.0));
      std::vector<BoardView> kept;
      for (size_t i = 0; i < views.size(); ++i) {
        if (views[i].method == "unwarped" && r.images[i].fit.ok && r.images[i].fit.rms_px > limit) {
          det.warnings.push_back(views[i].file + ": the board found in an unwarped view fits far worse than the " +
                                 "others (RMS " + std::to_string(r.images[i].fit.rms_px) + " px): left out");
          continue;
        }
        kept.push_back(views[i]);
      }
      if (kept.size() != views.size()) {
        views = kept;
        r = EvaluateViews(views, targets.board, sensor, options);
      }
    }
  }
  r = RefineAndEvaluate(images, targets.board, sensor, options, detect.Threads(), &views, r);
  // Every image, in order: the ones without a board too.
  std::vector<ImageEvaluation> all(targets.images.size());
  for (size_t i = 0; i < all.size(); ++i) {
    all[i].image_index = static_cast<int>(i);
    all[i].file = targets.images[i].file;
  }
  for (const ImageEvaluation& im : r.images) all[static_cast<size_t>(im.image_index)] = im;
  r.images = all;
  r.warnings.insert(r.warnings.begin(), det.warnings.begin(), det.warnings.end());
  Summarise(&r);
  r.seconds_detect = det.seconds;
  r.seconds_fit = Seconds(t0);
  return r;
}

std::string EvaluationSummary(const EvaluationResult& r) {
  std::ostringstream s;
  char line[512];
  for (const ImageEvaluation& im : r.images) {
    if (!im.found) {
      std::snprintf(line, sizeof line, "  %s: no board\n", im.file.c_str());
    } else if (!im.fit.ok) {
      std::snprintf(line, sizeof line, "  %s: %d corners, not fitted (%s)\n", im.file.c_str(), im.corners,
                    im.fit.failure.c_str());
    } else {
      std::snprintf(line, sizeof line, "  %s: %d corners, RMS %.4f px, max %.4f px\n", im.file.c_str(),
                    im.fit.corners_used, im.fit.rms_px, im.fit.max_px);
    }
    s << line;
  }
  std::snprintf(line, sizeof line,
                "held-out RMS reprojection error %.4f px over %d corners (max %.4f px); board found in %d of "
                "%zu images, %d fitted; %s model fixed, only the board poses fitted\n",
                r.rms_px, r.corners, r.max_px, r.boards_found, r.images.size(), r.boards_fitted, r.model.c_str());
  s << line;
  return s.str();
}

std::string EvaluationSummaryJson(const EvaluationResult& r, const std::vector<std::string>& command_line) {
  using json = nlohmann::ordered_json;
  auto number = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };
  json per_image = json::array();
  for (const ImageEvaluation& im : r.images) {
    json e = {{"file", im.file},
              {"found", im.found},
              {"corners", im.found && im.fit.ok ? im.fit.corners_used : im.corners},
              {"rms_px", number(im.found && im.fit.ok ? im.fit.rms_px : NAN)},
              {"max_px", number(im.found && im.fit.ok ? im.fit.max_px : NAN)}};
    if (im.found && !im.fit.ok) e["failure"] = im.fit.failure;
    per_image.push_back(e);
  }
  const json j = {{"tool", "panocalib evaluate"},
                  {"version", PANO_VERSION},
                  {"command_line", command_line},
                  {"model", r.model},
                  {"images", r.images.size()},
                  {"boards_found", r.boards_found},
                  {"boards_fitted", r.boards_fitted},
                  {"corners", r.corners},
                  {"rms_px", number(r.rms_px)},
                  {"max_px", number(r.max_px)},
                  {"per_image", per_image},
                  {"warnings", r.warnings},
                  {"seconds", {{"detection", r.seconds_detect}, {"fit", r.seconds_fit}}}};
  return j.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

}  // namespace pano

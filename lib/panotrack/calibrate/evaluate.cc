#include "panotrack/calibrate/evaluate.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "panotrack/calibrate/internal.h"
#include "panotrack/config.h"
#include "panotrack/core/parallel.h"
#include "panotrack/core/error.h"

namespace pano {

using namespace calib_internal;

namespace {

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Errors of every corner through the sensor block and pose; fills the fit's
// residuals, counts and RMS.
void Score(const BoardView& view, const std::vector<Eigen::Vector3d>& pts, const std::array<double, kNumSensor>& s,
           const SensorParams<double>& asphere, const std::array<double, 6>& pose, double cap, BoardPoseFit* fit) {
  fit->residuals.clear();
  double s2 = 0.0, worst = 0.0;
  int n = 0;
  for (size_t j = 0; j < view.corners.size(); ++j) {
    CornerCost c(pts[view.PointId(j)], view.corners[j], cap);
    c.WithAsphere(asphere);
    double r[2];
    if (!c(s.data(), pose.data(), r)) {
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
  std::array<double, kNumSensor> s = BlockFromParams(sensor.params);
  const double cap = CapRadiusPx(sensor.image_width, sensor.image_height);
  std::array<double, 6> pose{};
  if (!InitialPoseFromSensor(view, board, sensor, &pose)) {
    fit.failure = "the board's pose through the calibration could not be initialised";
    return fit;
  }
  ceres::Problem problem;
  problem.AddParameterBlock(s.data(), kNumSensor);
  problem.SetParameterBlockConstant(s.data());  // the calibration is fixed
  problem.AddParameterBlock(pose.data(), 6);
  const std::vector<Eigen::Matrix2d> weights = CornerWeights(view, board, options.full_weight_px);
  size_t n_obs = 0;
  for (size_t j = 0; j < view.corners.size(); ++j) {
    const Eigen::Vector3d& X = pts[view.PointId(j)];
    CornerCost probe(X, view.corners[j], cap);
    probe.WithAsphere(sensor.params);
    double r[2];
    if (!probe(s.data(), pose.data(), r)) continue;
    ceres::LossFunction* loss = options.huber_px > 0 ? new ceres::HuberLoss(options.huber_px) : nullptr;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerCost, 2, kNumSensor, 6>(
                                 &(new CornerCost(X, view.corners[j], cap, weights[j]))->WithAsphere(sensor.params)),
                             loss, s.data(), pose.data());
    ++n_obs;
  }
  if (n_obs < 3 || n_obs * 2 < view.corners.size()) {
    fit.failure = "the initial pose sees only " + std::to_string(n_obs) + " of " +
                  std::to_string(view.corners.size()) + " corners";
    return fit;
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
  if (options.verbose) std::fprintf(stderr, "%s: %s\n", view.file.c_str(), summary.BriefReport().c_str());
  bool finite = true;
  for (double v : pose) finite = finite && std::isfinite(v);
  if (summary.termination_type == ceres::FAILURE || !finite) {
    fit.failure = "the pose fit failed (" + summary.message + ")";
    return fit;
  }
  fit.rvec = Eigen::Vector3d(pose[0], pose[1], pose[2]);
  fit.tvec = Eigen::Vector3d(pose[3], pose[4], pose[5]);
  Score(view, pts, s, sensor.params, pose, cap, &fit);
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
  r.model = mirror_model_name(sensor.model);
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

EvaluationResult EvaluateCalibration(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                     const Calibration& calib, const EvaluateOptions& options) {
  options.Check();
  if (!calib.units.empty() && !targets.units.empty() && calib.units != targets.units)
    throw Error("the calibration's units (" + calib.units + ") differ from the targets' (" + targets.units +
                "): the board's size must be given in the calibration's units");
  CalibrateOptions detect;
  detect.num_threads = options.num_threads;
  detect.verbose = options.verbose;
  const DetectionResult det = DetectBoards(targets, images, detect);
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
  for (int pass = 0; pass < options.refine_passes; ++pass) {
    // Refinement needs each board's pose: the fitted boards only.
    std::vector<BoardView> fitted;
    for (size_t i = 0; i < views.size(); ++i) {
      if (!r.images[i].fit.ok) continue;
      BoardView v = views[i];
      v.rvec = r.images[i].fit.rvec;
      v.tvec = r.images[i].fit.tvec;
      fitted.push_back(v);
    }
    RefineCornersThroughModel(images, targets.board, sensor, &fitted, detect.Threads());
    for (BoardView& v : views)
      for (const BoardView& f : fitted)
        if (f.image_index == v.image_index) v.corners = f.corners;
    r = EvaluateViews(views, targets.board, sensor, options);
  }
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

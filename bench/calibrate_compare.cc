// calibrate_compare TARGETS.yaml: detects the board in the raw images once
// (findChessboardCornersSB, the same corners for every model), then fits
//   - panotrack's conic model (k1, k2 lens distortion),
//   - panotrack's sphere model,
//   - panotrack's asphere model (the conic plus a4, or a4 and a6) in the
//     cross-validation,
//   - OpenCV's cv::omnidir::calibrate (Mei's unified model, k1 k2 p1 p2),
// and prints each one's Euclidean RMS reprojection error over all corners
// (rigid board poses), plus the full `Calibrate` pipeline (with the unwarped
// retry of images without a board) and its time.
//
// Then a 5-fold cross-validation on the same corners: each model is fitted to
// 4/5 of the boards, only the held-out boards' poses are fitted through it
// (panotrack: FitBoardPose, the pose fit of `panocalib evaluate`; omnidir: a
// Ceres pose fit through Mei's projection, scored by cv::omnidir::projectPoints)
// and the held-out corners are scored (Euclidean RMS in pixels).
//   calibrate_compare TARGETS.yaml [--cv-only]
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <map>
#include <set>
#include <string>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/evaluate.h"
#include "panotrack/calibrate/model_selection.h"
#include "panotrack/calibrate/internal.h"
#include "panotrack/calibrate/omnidir_peer.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/target_input.h"
#include "panotrack/pipeline/panocalib.h"

namespace {

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// OpenCV omnidir on the same corners (calibrate/omnidir_peer.h); prints its
// parameters and returns the Euclidean RMS over the images it kept.
double OmnidirRms(const std::vector<pano::BoardView>& views, const pano::TargetBoard& board, cv::Size size,
                  int* used, double* seconds, int flags = 0) {
  const pano::OmnidirFit f = pano::FitOmnidir(views, board, size, flags);
  *used = f.images_used;
  *seconds = f.seconds;
  std::printf("  omnidir: fx %.2f fy %.2f s %.4f cx %.2f cy %.2f xi %.4f D [%.4f %.4f %.5f %.5f]\n",
              f.K.at<double>(0, 0), f.K.at<double>(1, 1), f.K.at<double>(0, 1), f.K.at<double>(0, 2),
              f.K.at<double>(1, 2), f.xi.at<double>(0), f.D.at<double>(0), f.D.at<double>(1), f.D.at<double>(2),
              f.D.at<double>(3));
  return f.rms_px;
}


// Held-out RMS over the boards in `common` only (every method fitted them).
double HeldOn(const pano::ModelScore& score, const std::set<std::string>& common) {
  double s2 = 0;
  size_t n = 0;
  for (const auto& [file, e] : score.board_errors)
    if (common.count(file)) {
      s2 += e.first;
      n += e.second;
    }
  return n ? std::sqrt(s2 / n) : NAN;
}

size_t CornerCount(const std::vector<pano::BoardView>& views) {
  size_t n = 0;
  for (const pano::BoardView& v : views) n += v.corners.size();
  return n;
}

// The image radius (pixels from the centre) at which a far point at
// `elevation` (radians) appears: the mapping, whatever the parameters.
double RadiusAtElevation(const pano::Sensor& s, double elevation) {
  const double far = 1e4 * s.params.vertex_distance;
  Eigen::Vector2d px;
  if (!s.project(Eigen::Vector3d(far * std::cos(elevation), 0.0, far * std::sin(elevation)), &px)) return NAN;
  return std::hypot(px.x() - s.params.cx, px.y() - s.params.cy);
}


// The gauge experiment: the conic refitted to the same boards with its focal
// length held at `focal` (every other parameter and the poses free), reached
// from the free fit in small steps along the valley. Returns the sensor and
// its training RMS (pixels, every corner alike).
pano::Sensor FitWithFocalHeld(const std::vector<pano::BoardView>& views, const pano::TargetBoard& board,
                              const pano::CalibrationResult& free_fit, double focal,
                              const pano::CalibrateOptions& options, double* train_rms) {
  using namespace pano::calib_internal;
  const std::vector<Eigen::Vector3d> pts = pano::BoardPoints(board);
  pano::Sensor sensor = free_fit.calib.sensor;
  const double cap = CapRadiusPx(sensor.image_width, sensor.image_height);
  std::array<double, kNumSensor> s = BlockFromParams(sensor.params);
  std::vector<std::array<double, 6>> poses;
  for (const pano::BoardView& v : free_fit.views) poses.push_back(PackPose(v));
  std::vector<int> fixed = FixedSensorIndices(false, options);
  fixed.push_back(kFocal);
  std::sort(fixed.begin(), fixed.end());
  const double f0 = s[kFocal];
  const int steps = 12;
  for (int step = 1; step <= steps; ++step) {
    // Geometric steps: the mirror follows the focal length along the valley.
    const double scale = std::pow(focal / f0, static_cast<double>(step) / steps) / (s[kFocal] / f0);
    s[kFocal] *= scale;
    ceres::Problem problem;
    problem.AddParameterBlock(s.data(), kNumSensor);
    problem.SetManifold(s.data(), new ceres::SubsetManifold(kNumSensor, fixed));
    for (size_t i = 0; i < views.size(); ++i) {
      const std::vector<Eigen::Matrix2d> w = pano::CornerWeights(views[i], board, options.full_weight_px);
      for (size_t j = 0; j < views[i].corners.size(); ++j) {
        CornerCost probe(pts[views[i].PointId(j)], views[i].corners[j], cap);
        double r[2];
        if (!probe(s.data(), poses[i].data(), r)) continue;
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerCost, 2, kNumSensor, 6>(
                                     new CornerCost(pts[views[i].PointId(j)], views[i].corners[j], cap, w[j])),
                                 options.huber_px > 0 ? new ceres::HuberLoss(options.huber_px) : nullptr, s.data(),
                                 poses[i].data());
      }
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_SCHUR;
    so.max_num_iterations = step == steps ? 200 : 30;
    so.logging_type = ceres::SILENT;
    so.num_threads = 2;
    ceres::Solver::Summary sum;
    ceres::Solve(so, &problem, &sum);
  }
  double s2 = 0;
  size_t n = 0;
  for (size_t i = 0; i < views.size(); ++i)
    for (size_t j = 0; j < views[i].corners.size(); ++j) {
      CornerCost c(pts[views[i].PointId(j)], views[i].corners[j], cap);
      double r[2];
      if (!c(s.data(), poses[i].data(), r)) continue;
      s2 += r[0] * r[0] + r[1] * r[1];
      ++n;
    }
  *train_rms = n ? std::sqrt(s2 / n) : NAN;
  sensor.params = ParamsFromBlock(s.data());
  SetRimForImage(&sensor);
  return sensor;
}

// One method of the comparison and its cross-validated score.
struct Method {
  const char* name;
  const pano::CalibrateOptions* options;  // null: omnidir
  pano::ModelScore score;
};

// cv::omnidir on each fold's training boards, each held-out board's pose
// fitted through it.
void ScoreOmnidir(const std::vector<std::vector<pano::BoardView>>& trains,
                  const std::vector<std::vector<pano::BoardView>>& helds, const pano::TargetBoard& board, int W, int H,
                  pano::ModelScore* score) {
  const std::vector<Eigen::Vector3d> pts = pano::BoardPoints(board);
  double train_s2 = 0, held_s2 = 0;
  size_t train_n = 0, held_n = 0;
  for (size_t fold = 0; fold < trains.size(); ++fold) {
    const pano::OmnidirFit f = pano::FitOmnidir(trains[fold], board, cv::Size(W, H));
    // omnidir's training RMS is over the boards it kept.
    const size_t kept = CornerCount(trains[fold]) * f.images_used / trains[fold].size();
    train_s2 += f.rms_px * f.rms_px * kept;
    train_n += kept;
    double s2 = 0;
    size_t n = 0;
    for (const pano::BoardView& v : helds[fold]) {
      double s2b = 0;
      size_t nb = 0;
      if (!pano::OmnidirHeldOut(f, v, pts, &s2b, &nb)) {
        ++score->failed_boards;
        continue;
      }
      s2 += s2b;
      n += nb;
      score->board_errors[v.file] = {s2b, nb};
    }
    held_s2 += s2;
    held_n += n;
    score->fold_heldout_rms_px.push_back(n ? std::sqrt(s2 / n) : NAN);
  }
  score->training_rms_px = train_n ? std::sqrt(train_s2 / train_n) : NAN;
  score->heldout_rms_px = held_n ? std::sqrt(held_s2 / held_n) : NAN;
}

// The table: training, held-out and common-board RMS of every method, the
// conic's spread over the folds, and the best panotrack / omnidir ratio.
void PrintComparison(const std::vector<pano::BoardView>& views, const std::vector<Method>& methods,
                     const std::vector<double>& focals, const std::vector<double>& r0s) {
  // The boards every method could fit when held out: the fair comparison
  // when some model fails on some (its fit does not reach them).
  std::set<std::string> common;
  for (const pano::BoardView& v : views) common.insert(v.file);
  for (const Method& m : methods)
    for (auto it = common.begin(); it != common.end();)
      it = m.score.board_errors.count(*it) ? std::next(it) : common.erase(it);
  std::printf("  %-28s %10s %10s %14s   per fold held-out\n", "", "train RMS", "held-out", "common boards");
  for (const Method& m : methods) {
    std::printf("  %-28s %8.4f px %8.4f px %8.4f px (%zu)  ", m.name, m.score.training_rms_px,
                m.score.heldout_rms_px, HeldOn(m.score, common), common.size());
    for (double h : m.score.fold_heldout_rms_px) std::printf(" %.3f", h);
    if (m.score.failed_boards) std::printf("  (%d held-out boards not fitted)", m.score.failed_boards);
    std::printf("\n");
  }
  if (!focals.empty()) {
    const auto [fmin, fmax] = std::minmax_element(focals.begin(), focals.end());
    const auto [rmin, rmax] = std::minmax_element(r0s.begin(), r0s.end());
    std::printf("  conic focal over the folds: %.1f .. %.1f px (spread %.1f %%); image radius of the horizon "
                "%.3f .. %.3f px (spread %.3f px)\n",
                *fmin, *fmax, 100.0 * (*fmax / *fmin - 1.0), *rmin, *rmax, *rmax - *rmin);
  }
  // Over the models that fitted every held-out board (a held-out RMS over
  // fewer boards is not comparable).
  double best = INFINITY;
  for (const Method& m : methods)
    if (m.options && m.score.failed_boards == 0) best = std::min(best, m.score.heldout_rms_px);
  std::printf("  best panotrack held-out / omnidir held-out: %.3f\n", best / methods.back().score.heldout_rms_px);
}

// Gauge: every fold's conic with the focal length held at the folds' median.
void PrintFocalHeld(const std::vector<std::vector<pano::BoardView>>& trains,
                    const std::vector<std::vector<pano::BoardView>>& helds, const pano::TargetBoard& board,
                    const std::vector<pano::CalibrationResult>& conic_fits, const std::vector<double>& focals,
                    const pano::CalibrateOptions& conic, const pano::ModelScore& conic_score) {
  std::vector<double> sorted = focals;
  std::sort(sorted.begin(), sorted.end());
  const double f_held = sorted[sorted.size() / 2];
  double train_s2 = 0, held_s2 = 0;
  size_t train_n = 0, held_n = 0;
  std::printf("  conic with the focal held at %.2f px (the folds' median), the rest refitted:\n", f_held);
  for (size_t k = 0; k < conic_fits.size(); ++k) {
    double train_rms = NAN;
    const pano::Sensor sensor = FitWithFocalHeld(trains[k], board, conic_fits[k], f_held, conic, &train_rms);
    double s2 = 0;
    size_t n = 0;
    pano::EvaluateOptions eo;
    for (const pano::BoardView& v : helds[k]) {
      const pano::BoardPoseFit f = pano::FitBoardPose(v, board, sensor, eo);
      if (!f.ok) continue;
      s2 += f.rms_px * f.rms_px * f.corners_used;
      n += static_cast<size_t>(f.corners_used);
    }
    train_s2 += train_rms * train_rms * CornerCount(trains[k]);
    train_n += CornerCount(trains[k]);
    held_s2 += s2;
    held_n += n;
    const pano::SensorParams<double>& p = sensor.params;
    std::printf("  fold %zu: R %9.4f  K %8.4f  vertex %9.4f | horizon %.3f px | train %.4f (free %.4f) held-out "
                "%.4f (free %.4f) px\n",
                k, p.curvature_radius, p.conic_constant, p.vertex_distance, RadiusAtElevation(sensor, 0.0),
                train_rms, conic_fits[k].rms_px, n ? std::sqrt(s2 / n) : NAN, conic_score.fold_heldout_rms_px[k]);
  }
  std::printf("  %-28s %8.4f px %8.4f px\n", "conic, focal held", std::sqrt(train_s2 / train_n),
              std::sqrt(held_s2 / held_n));
}

void CrossValidate(const std::vector<pano::BoardView>& views, const pano::TargetBoard& board, int W, int H,
                   const std::string& units, int folds, bool gauge) {
  pano::CalibrateOptions conic, sphere, conic_ls, asphere, asphere_a4;
  conic.model = pano::MirrorModel::kConic;
  asphere.model = pano::MirrorModel::kAsphere;
  asphere_a4 = asphere;
  asphere_a4.asphere_terms = 1;
  conic_ls = conic;
  conic_ls.huber_px = 0.0;
  conic_ls.full_weight_px = 0.0;
  std::vector<Method> methods = {{"panotrack conic (k1,k2)", &conic, {}},
                                 {"panotrack conic, least sq.", &conic_ls, {}},
                                 {"panotrack sphere", &sphere, {}},
                                 {"panotrack asphere (a4)", &asphere_a4, {}},
                                 {"panotrack asphere (a4,a6)", &asphere, {}},
                                 {"OpenCV omnidir (Mei)", nullptr, {}}};
  std::printf("\n%d-fold cross-validation on the same %zu raw-detected boards (board k held out in fold k mod %d; "
              "held-out boards: only their pose fitted):\n",
              folds, views.size(), folds);
  std::printf("  conic per fold: focal_px, curvature_radius, conic_constant, vertex_distance | image radius at "
              "elevation -30, 0, +30 deg\n");
  std::vector<double> focals, r0s;
  std::vector<pano::CalibrationResult> conic_fits;
  std::vector<std::vector<pano::BoardView>> trains, helds;
  for (int fold = 0; fold < folds; ++fold) {
    std::vector<pano::BoardView> train, held;
    for (size_t i = 0; i < views.size(); ++i) (static_cast<int>(i) % folds == fold ? held : train).push_back(views[i]);
    trains.push_back(train);
    helds.push_back(held);
  }
  for (Method& m : methods) {
    if (!m.options) {
      ScoreOmnidir(trains, helds, board, W, H, &m.score);
      continue;
    }
    m.score = pano::CrossValidateModel(views, board, W, H, units, *m.options, folds,
                                       [&](int fold, const pano::CalibrationResult& r) {
      const pano::SensorParams<double>& p = r.calib.sensor.params;
      if (m.options->model == pano::MirrorModel::kAsphere)
        std::printf("  fold %d %s: a4 %.5f a6 %.5f (K %.4f) train %.4f px\n", fold, m.name, p.asphere_a4,
                    p.asphere_a6, p.conic_constant, r.rms_px);
      if (m.options != &conic) return;
      const double r0 = RadiusAtElevation(r.calib.sensor, 0.0);
      focals.push_back(p.focal_px);
      conic_fits.push_back(r);
      r0s.push_back(r0);
      std::printf("  fold %d: focal %8.2f  R %9.4f  K %8.4f  vertex %9.4f | %.3f %.3f %.3f px\n", fold,
                  p.focal_px, p.curvature_radius, p.conic_constant, p.vertex_distance,
                  RadiusAtElevation(r.calib.sensor, -M_PI / 6), r0, RadiusAtElevation(r.calib.sensor, M_PI / 6));
    });
    if (!m.score.failure.empty()) std::printf("  %s: first failure: %s\n", m.name, m.score.failure.c_str());
  }
  PrintComparison(views, methods, focals, r0s);
  if (!focals.empty() && gauge) PrintFocalHeld(trains, helds, board, conic_fits, focals, conic, methods[0].score);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || (argc == 3 && std::strcmp(argv[2], "--cv-only") != 0) || argc > 3) {
    std::fprintf(stderr, "usage: calibrate_compare TARGETS.yaml [--cv-only]\n");
    return 2;
  }
  const bool cv_only = argc == 3;
  try {
    const pano::TargetSet t = pano::ReadTargets(argv[1]);
    const std::vector<cv::Mat> images = pano::LoadTargetImages(t);
    pano::CalibrateOptions conic;
    conic.model = pano::MirrorModel::kConic;
    const pano::DetectionResult det = pano::DetectBoards(t, images, conic);
    const int W = det.image_width, H = det.image_height;
    std::printf("%s: %zu images, board found in %zu by findChessboardCornersSB on the raw image (%.2f s)\n",
                argv[1], t.images.size(), det.views.size(), det.seconds);
    if (cv_only) {
      CrossValidate(det.views, t.board, W, H, t.units, 5, true);
      return 0;
    }

    auto t0 = std::chrono::steady_clock::now();
    const pano::CalibrationResult rc = pano::CalibrateViews(det.views, t.board, W, H, t.units, conic);
    const double tc = Seconds(t0);
    std::printf("%s", pano::CalibrationSummary(rc).c_str());
    pano::CalibrateOptions sphere;
    t0 = std::chrono::steady_clock::now();
    const pano::CalibrationResult rs = pano::CalibrateViews(det.views, t.board, W, H, t.units, sphere);
    const double ts = Seconds(t0);
    pano::CalibrateOptions conic_ls = conic;
    conic_ls.huber_px = 0.0;  // omnidir's objective: plain least squares,
    conic_ls.full_weight_px = 0.0;  // every corner weighted the same
    const pano::CalibrationResult rcl = pano::CalibrateViews(det.views, t.board, W, H, t.units, conic_ls);
    pano::CalibrateOptions conic0 = conic;
    conic0.distortion_terms = 0;
    const pano::CalibrationResult rc0 = pano::CalibrateViews(det.views, t.board, W, H, t.units, conic0);
    int used = 0;
    double to = 0;
    const double omni = OmnidirRms(det.views, t.board, cv::Size(W, H), &used, &to);

    // The whole pipeline: detection, fit, unwarped retry, refit.
    t0 = std::chrono::steady_clock::now();
    const pano::CalibrationResult full = pano::Calibrate(t, images, conic);
    const double tf = Seconds(t0);

    std::printf("\nsame %zu raw-detected boards (%zu corners):\n", det.views.size(),
                det.views.size() * t.board.cols * t.board.rows);
    std::printf("  panotrack conic (k1,k2)   RMS %.4f px  fit %.2f s\n", rc.rms_px, tc);
    std::printf("  panotrack conic, least sq. RMS %.4f px\n", rcl.rms_px);
    std::printf("  panotrack conic (no dist) RMS %.4f px\n", rc0.rms_px);
    std::printf("  panotrack sphere          RMS %.4f px  fit %.2f s\n", rs.rms_px, ts);
    std::printf("  OpenCV omnidir (Mei)      RMS %.4f px  fit %.2f s  (%d boards kept)\n", omni, to, used);
    {
      // omnidir without its skew and/or tangential terms (our model has neither).
      for (int fl : {static_cast<int>(cv::omnidir::CALIB_FIX_SKEW), cv::omnidir::CALIB_FIX_P1 | cv::omnidir::CALIB_FIX_P2,
                     cv::omnidir::CALIB_FIX_SKEW | cv::omnidir::CALIB_FIX_P1 | cv::omnidir::CALIB_FIX_P2}) {
        int u2 = 0;
        double t2 = 0;
        const double r2 = OmnidirRms(det.views, t.board, cv::Size(W, H), &u2, &t2, fl);
        std::printf("  OpenCV omnidir, %-14s RMS %.4f px\n",
                    fl == cv::omnidir::CALIB_FIX_SKEW ? "skew fixed" : fl == (cv::omnidir::CALIB_FIX_P1 | cv::omnidir::CALIB_FIX_P2) ? "p1 p2 fixed" : "skew, p fixed", r2);
      }
    }
    std::printf("full pipeline (conic, with unwarped retry): %zu of %zu boards, RMS %.4f px, "
                "detection %.2f s + fit %.2f s = %.2f s\n",
                full.views.size(), t.images.size(), full.rms_px, full.seconds_detect, full.seconds_fit, tf);
    {
      // The corners the pipeline refined on the board plane (step 5), given
      // to every model: the fair comparison for the refined pipeline.
      std::vector<pano::BoardView> refined = full.views;
      for (pano::BoardView& v : refined) v.has_pose = false;
      const pano::CalibrationResult rc2 = pano::CalibrateViews(refined, t.board, W, H, t.units, conic);
      const pano::CalibrationResult rcl2 = pano::CalibrateViews(refined, t.board, W, H, t.units, conic_ls);
      const pano::CalibrationResult rs2 = pano::CalibrateViews(refined, t.board, W, H, t.units, sphere);
      int u3 = 0;
      double t3 = 0;
      const double omni2 = OmnidirRms(refined, t.board, cv::Size(W, H), &u3, &t3);
      std::printf("\nsame %zu boards, corners refined through the model (step 5):\n", refined.size());
      std::printf("  panotrack conic (k1,k2)   RMS %.4f px\n", rc2.rms_px);
      std::printf("  panotrack conic, least sq. RMS %.4f px\n", rcl2.rms_px);
      std::printf("  panotrack sphere          RMS %.4f px\n", rs2.rms_px);
      std::printf("  OpenCV omnidir (Mei)      RMS %.4f px  (%d boards kept)\n", omni2, u3);
    }
    CrossValidate(det.views, t.board, W, H, t.units, 5, true);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calibrate_compare: %s\n", e.what());
    return 1;
  }
  return 0;
}

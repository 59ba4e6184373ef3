// The calibration pipeline: options, orchestration, outputs and summary.
#include "calibrate/calibrate.h"

#include <ceres/rotation.h>
#include <glog/logging.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "calibrate/internal.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/parallel.h"
#include "lut/radius_table.h"

namespace pano {

void CalibrateOptions::Check() const {
  if (model != MirrorModel::kSphere && model != MirrorModel::kConic)
    throw Error("--model: expected sphere or conic");
  if (distortion_terms < -1 || distortion_terms > 2)
    throw Error("--distortion: expected 0, 1 or 2 radial terms, got " + std::to_string(distortion_terms));
  if (!(huber_px >= 0.0) || !std::isfinite(huber_px))
    throw Error("--huber: expected a non-negative number of pixels (0: plain least squares)");
  if (max_iterations < 1 || max_iterations > 100000)
    throw Error("--max-iterations: expected 1..100000, got " + std::to_string(max_iterations));
  if (!(max_rms_px > 0.0)) throw Error("--max-rms: expected a positive number of pixels");
  if (!std::isfinite(full_weight_px))
    throw Error("--full-weight: expected a number of pixels per square (0: uniform weights)");
  if (!(scale_warning_rel_std > 0.0)) throw Error("scale warning threshold: expected a positive fraction");
}

namespace {

// Ceres logs every rejected step (a corner leaving the mirror during a trial
// step) as a warning; the fit handles those, so keep the console quiet.
class QuietCeres {
 public:
  QuietCeres() : saved_(FLAGS_minloglevel) { FLAGS_minloglevel = std::max(saved_, 2); }
  ~QuietCeres() { FLAGS_minloglevel = saved_; }

 private:
  int saved_;
};

int MinImages(bool poses_known) { return poses_known ? 2 : 3; }

void CheckViewCount(size_t n_found, size_t n_total, bool poses_known, const CalibrateOptions& o,
                    const std::vector<std::string>& not_found) {
  const size_t need = MinImages(poses_known);
  if (n_found == 0) {
    std::string list;
    for (const std::string& f : not_found) list += (list.empty() ? "" : ", ") + f;
    throw Error("no chessboard found in any of the " + std::to_string(n_total) +
                " images (" + list + "): check board.cols/board.rows (inner corners) against the images");
  }
  if (n_found < need)
    throw Error("the board was found in only " + std::to_string(n_found) + " of " + std::to_string(n_total) +
                " images; the " + mirror_model_name(o.model) + " fit with " +
                (poses_known ? "known" : "unknown") + " board poses needs at least " +
                std::to_string(need) + " (more images, boards at several distances and azimuths)");
}

// Checks the fit and fills the calibration file's contents.
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

  // Calibration file contents.
  Calibration& c = res.calib;
  c.units = units;
  for (const ParameterEstimate& p : res.parameters)
    if (!p.fixed && std::isfinite(p.stddev)) c.extras[p.name + "_std"] = p.stddev;
  c.extras["rms_px"] = res.rms_px;
  c.extras["images_used"] = static_cast<double>(res.views.size());
  for (size_t i = 0; i < res.views.size(); ++i)
    c.extras["rms_image_" + std::to_string(res.views[i].image_index >= 0 ? res.views[i].image_index
                                                                           : static_cast<int>(i))] =
        res.image_rms[i];
  std::ostringstream cm;
  cm << "panocalib calibrate: " << mirror_model_name(options.model) << " model, " << res.views.size()
     << " boards, " << (poses_known ? "known" : "unknown (estimated)") << " board poses, RMS "
     << res.rms_px << " px.\n";
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

// A start at a previous fit: its sensor and its boards' poses.
InitialEstimate StartFrom(const CalibrationResult& fit, const std::string& summary) {
  InitialEstimate start;
  start.sensor = fit.calib.sensor;
  start.summary = summary;
  for (const BoardView& v : fit.views)
    start.poses.push_back({v.rvec.x(), v.rvec.y(), v.rvec.z(), v.tvec.x(), v.tvec.y(), v.tvec.z()});
  return start;
}

}  // namespace

CalibrationResult CalibrateViews(const std::vector<BoardView>& views_in, const TargetBoard& board, int width,
                                 int height, const std::string& units, const CalibrateOptions& options) {
  options.Check();
  const QuietCeres quiet;
  if (width <= 0 || height <= 0) throw Error("calibration: image size unknown");
  std::vector<BoardView> views = views_in;
  bool all_known = !views.empty(), any_known = false;
  for (const BoardView& v : views) {
    all_known = all_known && v.has_pose;
    any_known = any_known || v.has_pose;
  }
  const bool poses_known = all_known && !options.ignore_known_poses;
  CheckViewCount(views.size(), views.size(), poses_known, options, {});
  std::vector<std::string> warnings;
  if (any_known && !all_known && !options.ignore_known_poses)
    warnings.push_back("some images have board poses and some not: all poses are estimated");
  if (poses_known) OrderCornersByKnownPose(board, 0.5 * (width - 1), 0.5 * (height - 1), &views);
  const auto t_init = std::chrono::steady_clock::now();
  const InitialEstimate init = Initialize(views, board, width, height, poses_known, options);
  if (options.verbose)
    std::fprintf(stderr, "[initialisation: %.2f s, %zu starts to refine]\n",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t_init).count(),
                 1 + init.alternatives.size());
  // The best start and the other starts (the conic's basins along its
  // near-degenerate valley, whose fits converge slowly and rank only at the
  // end) are fitted in parallel; the best final fit is kept, the earlier
  // start on a tie, so the result does not depend on the thread count.
  std::vector<const InitialEstimate*> starts = {&init};
  for (const InitialEstimate& alt : init.alternatives) starts.push_back(&alt);
  const int n = static_cast<int>(starts.size());
  std::vector<CalibrationResult> fits(n);
  std::vector<std::string> errors(n);
  std::vector<char> ok(n, 0);
  ParallelFor(n, [&](int k) {
    try {
      fits[k] = FitCalibration(views, board, *starts[k], poses_known, options, n > 1 ? 1 : 0);
      ok[k] = 1;
    } catch (const Error& e) {
      errors[k] = e.what();  // that start failed; the others stand
    }
  });
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
  Finish(&res, poses_known, units, options, warnings);
  return res;
}

CalibrationResult Calibrate(const TargetSet& targets, const CalibrateOptions& options) {
  options.Check();
  const std::vector<cv::Mat> images = LoadTargetImages(targets);
  return Calibrate(targets, images, options);
}

CalibrationResult Calibrate(const TargetSet& targets, const std::vector<cv::Mat>& images,
                            const CalibrateOptions& options) {
  options.Check();
  const QuietCeres quiet;
  const auto t0 = std::chrono::steady_clock::now();
  if (images.size() != targets.images.size()) throw Error("calibration: one image per target entry expected");
  for (size_t i = 1; i < images.size(); ++i)
    if (images[i].size() != images[0].size())
      throw Error(targets.images[i].resolved + ": image size differs from the first image's");
  DetectionResult det = DetectBoards(targets, images, options);
  auto phase = [&, last = t0](const char* what) mutable {
    const auto now = std::chrono::steady_clock::now();
    if (options.verbose)
      std::fprintf(stderr, "[%s: %.2f s]\n", what, std::chrono::duration<double>(now - last).count());
    last = now;
  };
  phase("raw detection");
  const bool poses_known = targets.AllPosesKnown() && !options.ignore_known_poses;
  CheckViewCount(det.views.size(), images.size(), poses_known, options, det.not_found_files);
  const std::string units = targets.units;
  CalibrationResult res =
      CalibrateViews(det.views, targets.board, det.image_width, det.image_height, units, options);

  phase("initialisation and first fit");
  // Step 4: images without a board, in views unwarped through the first fit.
  const bool retry_unwarped = options.unwarp_fallback && !det.not_found.empty();
  if (retry_unwarped) {
    std::vector<double> dist, hgt;
    for (const BoardView& v : res.views) {
      const double mid[3] = {0.5 * (targets.board.cols - 1) * targets.board.square,
                             0.5 * (targets.board.rows - 1) * targets.board.square, 0.0};
      Eigen::Vector3d centre;
      ceres::AngleAxisRotatePoint(v.rvec.data(), mid, centre.data());
      centre += v.tvec;
      dist.push_back(std::hypot(centre.x(), centre.y()));
      hgt.push_back(centre.z());
    }
    std::nth_element(dist.begin(), dist.begin() + dist.size() / 2, dist.end());
    std::nth_element(hgt.begin(), hgt.begin() + hgt.size() / 2, hgt.end());
    const double d_med = dist[dist.size() / 2], h_med = hgt[hgt.size() / 2];
    // In parallel over images (each search is then serial); one image
    // searches its views in parallel instead.
    const int n_missing = static_cast<int>(det.not_found.size());
    std::vector<BoardView> found(n_missing);
    std::vector<char> ok(n_missing, 0);
    ParallelFor(n_missing, [&](int k) {
      ok[k] = DetectBoardUnwarped(images[det.not_found[k]], targets.board, res.calib.sensor, d_med, h_med,
                                  &found[k].corners);
    });
    std::vector<BoardView> extra;
    for (int k = 0; k < n_missing; ++k) {
      if (!ok[k]) continue;
      const int i = det.not_found[k];
      BoardView& v = found[k];
      const TargetImage& ti = targets.images[i];
      v.image_index = i;
      v.file = ti.file;
      v.method = "unwarped";
      v.has_pose = ti.has_pose;
      v.rvec = Eigen::Vector3d(ti.rvec[0], ti.rvec[1], ti.rvec[2]);
      v.tvec = Eigen::Vector3d(ti.tvec[0], ti.tvec[1], ti.tvec[2]);
      extra.push_back(v);
    }
    if (!extra.empty()) {
      // Refit from the fitted model: the new boards' poses through it.
      struct Item {
        BoardView view;
        std::array<double, 6> pose;
      };
      std::vector<Item> items;
      for (const BoardView& v : res.views)
        items.push_back({v, {v.rvec.x(), v.rvec.y(), v.rvec.z(), v.tvec.x(), v.tvec.y(), v.tvec.z()}});
      if (poses_known)
        OrderCornersByKnownPose(targets.board, res.calib.sensor.params.cx, res.calib.sensor.params.cy, &extra);
      for (const BoardView& v : extra) {
        std::array<double, 6> pose{};
        if (poses_known) {
          pose = {v.rvec.x(), v.rvec.y(), v.rvec.z(), v.tvec.x(), v.tvec.y(), v.tvec.z()};
        } else if (!calib_internal::InitialPoseFromSensor(v, targets.board, res.calib.sensor, &pose)) {
          continue;
        }
        items.push_back({v, pose});
      }
      std::sort(items.begin(), items.end(),
                [](const Item& a, const Item& b) { return a.view.image_index < b.view.image_index; });
      InitialEstimate start;
      start.sensor = res.calib.sensor;
      start.sensor.params.rim_radius = 0.0;
      start.summary = "refit with the unwarped boards from the previous fit; " + res.init_summary;
      std::vector<BoardView> all;
      for (const Item& it : items) {
        all.push_back(it.view);
        start.poses.push_back(it.pose);
      }
      try {
        CalibrationResult again = FitCalibration(all, targets.board, start, poses_known, options);
        Finish(&again, poses_known, units, options, {});
        // Keep the new boards only when they fit like the others.
        bool consistent = true;
        for (size_t i = 0; i < again.views.size(); ++i)
          if (again.views[i].method == "unwarped" && again.image_rms[i] > std::max(1.0, 3.0 * again.rms_px))
            consistent = false;
        if (consistent) {
          res = again;
          std::vector<int> missing;
          std::vector<std::string> missing_files;
          for (size_t k = 0; k < det.not_found.size(); ++k) {
            bool used = false;
            for (const BoardView& v : res.views) used = used || v.image_index == det.not_found[k];
            if (!used) {
              missing.push_back(det.not_found[k]);
              missing_files.push_back(det.not_found_files[k]);
            }
          }
          det.not_found = missing;
          det.not_found_files = missing_files;
        }
      } catch (const Error&) {
        // The first fit stands.
      }
    }
  }
  if (retry_unwarped) phase("unwarped detection and refit");
  // Step 5: every corner (the unwarped boards' too) located again on the
  // board plane through the fitted model, then the model fitted again from
  // where it was. Corners left biased here bias the whole fit, so this comes
  // last.
  for (int pass = 0; pass < options.refine_passes; ++pass) {
    std::vector<BoardView> views = res.views;
    if (RefineCornersThroughModel(images, targets.board, res.calib.sensor, &views) == 0) break;
    const InitialEstimate start = StartFrom(res, "refit on corners refined through the model; " + res.init_summary);
    try {
      CalibrationResult again = FitCalibration(views, targets.board, start, poses_known, options);
      Finish(&again, poses_known, units, options, {});
      res = again;
    } catch (const Error&) {
      break;  // the previous fit stands
    }
  }

  phase("corner refinement and refit");
  res.not_found = det.not_found;
  res.not_found_files = det.not_found_files;
  res.seconds_detect = det.seconds;
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  res.seconds_fit = total - det.seconds;
  res.calib.extras["images_total"] = static_cast<double>(images.size());
  if (!res.not_found_files.empty()) {
    std::string list;
    for (const std::string& f : res.not_found_files) list += " " + f;
    res.calib.comment += "No board found (skipped):" + list + "\n";
  }
  return res;
}

std::string Summary(const CalibrationResult& r) {
  std::ostringstream o;
  const Sensor& s = r.calib.sensor;
  o << "model " << mirror_model_name(s.model) << ", " << s.image_width << "x" << s.image_height << " px, "
    << r.views.size() << " boards used, board poses " << (r.poses_known ? "known" : "estimated") << "\n";
  char line[256];
  for (const ParameterEstimate& p : r.parameters) {
    if (p.fixed)
      std::snprintf(line, sizeof line, "  %-17s %14.6g   (fixed)\n", p.name.c_str(), p.value);
    else if (std::isfinite(p.stddev))
      std::snprintf(line, sizeof line, "  %-17s %14.6g +- %.3g\n", p.name.c_str(), p.value, p.stddev);
    else
      std::snprintf(line, sizeof line, "  %-17s %14.6g   (not determined)\n", p.name.c_str(), p.value);
    o << line;
  }
  if (s.params.rim_radius > 0)
    o << "  rim_radius        " << s.params.rim_radius << " (set to cover the image; not fitted)\n";
  std::snprintf(line, sizeof line, "RMS reprojection error %.4f px over %zu boards\n", r.rms_px, r.views.size());
  o << line;
  for (size_t i = 0; i < r.views.size(); ++i) {
    std::snprintf(line, sizeof line, "  %-24s %8.4f px  (%s)\n", r.views[i].file.c_str(), r.image_rms[i],
                  r.views[i].method.c_str());
    o << line;
  }
  if (!r.not_found_files.empty()) {
    o << "no board found (skipped):";
    for (const std::string& f : r.not_found_files) o << " " << f;
    o << "\n";
  }
  std::snprintf(line, sizeof line, "time: detection %.2f s, fit %.2f s\n", r.seconds_detect, r.seconds_fit);
  o << line;
  for (const std::string& w : r.warnings) o << "warning: " << w << "\n";
  return o.str();
}

void WriteCalibrationOutputs(const CalibrationResult& result, const CalibrationOutputs& out,
                             const cv::Mat& report_image) {
  namespace fs = std::filesystem;
  if (out.calibration.empty()) throw Error("-o: an output calibration file is required");
  Calibration calib = result.calib;
  calib.sensor.Check(out.calibration);
  // Prepare everything before writing anything.
  RadiusTable table;
  if (!out.lut.empty()) {
    table = RadiusTable::Build(calib.sensor, DefaultRanges(calib.sensor));
    const fs::path cal_dir = fs::absolute(fs::path(out.calibration)).parent_path();
    const fs::path lut_abs = fs::absolute(fs::path(out.lut));
    calib.lut = lut_abs.lexically_relative(cal_dir).string();
    if (calib.lut.empty()) calib.lut = lut_abs.string();
  }
  std::vector<uchar> png;
  if (!out.report.empty()) {
    if (report_image.empty()) throw Error(out.report + ": no report image to write");
    if (!cv::imencode(".png", report_image, png)) throw Error(out.report + ": cannot encode the report PNG");
  }
  if (!out.lut.empty()) table.Save(out.lut);
  if (!out.report.empty()) {
    AtomicFile f(out.report);
    f.Write(png.data(), png.size());
    f.Commit();
  }
  WriteCalibration(out.calibration, calib);
}

}  // namespace pano

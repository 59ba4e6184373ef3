// The pipeline's contract with its callers: calibrations running at once do
// not disturb each other (no global state), and a step that fails and is
// skipped reaches the result's warnings.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/refit.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/target_input.h"
#include "rendered_targets.h"
#include "synthetic.h"
#include "test_paths.h"
#include "test_rng.h"

namespace pano {
namespace {

// Relative difference, against the larger magnitude (0 for two zeros).
double RelativeDifference(double a, double b) {
  const double scale = std::max(std::abs(a), std::abs(b));
  return scale > 0.0 ? std::abs(a - b) / scale : 0.0;
}

void CheckSameResult(const CalibrationResult& a, const CalibrationResult& b) {
  REQUIRE(a.parameters.size() == b.parameters.size());
  for (size_t k = 0; k < a.parameters.size(); ++k) {
    INFO(a.parameters[k].name << ": " << a.parameters[k].value << " and " << b.parameters[k].value);
    CHECK(a.parameters[k].name == b.parameters[k].name);
    CHECK(RelativeDifference(a.parameters[k].value, b.parameters[k].value) < 1e-9);
  }
  CHECK(RelativeDifference(a.rms_px, b.rms_px) < 1e-9);
  REQUIRE(a.views.size() == b.views.size());
  for (size_t i = 0; i < a.views.size(); ++i) {
    CHECK(a.views[i].image_index == b.views[i].image_index);
    CHECK(a.views[i].method == b.views[i].method);
    CHECK(RelativeDifference(a.image_rms[i], b.image_rms[i]) < 1e-9);
  }
  CHECK(a.not_found == b.not_found);
  CHECK(a.warnings == b.warnings);
}

// 8 rendered boards of the paper-real sensor (known poses, 2 grey levels of
// noise), read back with their images.
struct RenderedSet {
  TargetSet targets;
  std::vector<cv::Mat> images;
};

RenderedSet RenderPaperReal(const std::string& name) {
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  RenderedSet set;
  set.targets = ReadTargets(test::RenderTargets(name, truth, 8, 5) + "/targets.yaml");
  set.images = LoadTargetImages(set.targets);
  return set;
}

TEST_CASE("two calibrations at once give what one alone gives", "[concurrent]") {
  // Rendered boards through the whole pipeline: detection, the unwarped
  // retry, refinement, each with its own threads.
  const RenderedSet set = RenderPaperReal("calibrate_concurrent");
  const TargetSet& targets = set.targets;
  const std::vector<cv::Mat>& images = set.images;
  CalibrateOptions o;
  o.num_threads = 2;
  // The steps' timings and the fits' summaries go to the caller's log (the
  // library prints nothing), from the threads the fits run on.
  std::mutex log_mutex;
  std::vector<std::string> log;
  CalibrateOptions logged = o;
  logged.on_log = [&](const std::string& line) {
    std::lock_guard<std::mutex> lock(log_mutex);
    log.push_back(line);
  };
  const CalibrationResult alone = Calibrate(targets, images, logged);
  auto logged_line = [&](const std::string& start) {
    return std::any_of(log.begin(), log.end(), [&](const std::string& l) { return l.rfind(start, 0) == 0; });
  };
  CHECK(logged_line("[raw detection: "));
  CHECK(logged_line("[initialisation: "));
  CHECK(logged_line("[corner refinement and refit: "));
  CHECK(logged_line("Ceres Solver Report: "));

  CalibrationResult results[2];
  std::string errors[2];
  auto run = [&](int k) {
    try {
      results[k] = Calibrate(targets, images, o);
    } catch (const std::exception& e) {
      errors[k] = e.what();
    }
  };
  std::thread first(run, 0), second(run, 1);
  first.join();
  second.join();
  for (int k = 0; k < 2; ++k) {
    INFO("calibration " << k << " running at once with the other");
    REQUIRE(errors[k].empty());
    CheckSameResult(results[k], alone);
  }
}

TEST_CASE("the exhaustive raw search, deferred past the unwarped views, finds the boards as raw ones",
          "[exhaustive]") {
  const RenderedSet set = RenderPaperReal("calibrate_exhaustive");
  const TargetSet& targets = set.targets;
  const std::vector<cv::Mat>& images = set.images;
  CalibrateOptions o;
  o.num_threads = 2;
  const DetectionResult det = DetectBoards(targets, images, o, /*defer_to_unwarped=*/true);
  REQUIRE(det.views.size() >= 4);
  // Half the boards (4 at least) found by the quick search: the exhaustive
  // one waits for the images the unwarped views miss.
  CHECK(det.exhaustive_deferred);
  CHECK_FALSE(DetectBoards(targets, images, o, /*defer_to_unwarped=*/false).exhaustive_deferred);
  std::vector<int> all(targets.images.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const std::vector<BoardView> found = FindBoardsExhaustive(targets, images, all, o.Threads());
  // Every board the quick search found, the same corners within a pixel,
  // whatever their order (both searches run with CALIB_CB_ACCURACY).
  for (const BoardView& quick : det.views) {
    const auto it = std::find_if(found.begin(), found.end(),
                                 [&](const BoardView& v) { return v.image_index == quick.image_index; });
    REQUIRE(it != found.end());
    CHECK(it->method == "raw");
    REQUIRE(it->corners.size() == quick.corners.size());
    double worst = 0.0;
    for (const Eigen::Vector2d& q : quick.corners) {
      double nearest = HUGE_VAL;
      for (const Eigen::Vector2d& e : it->corners) nearest = std::min(nearest, (e - q).norm());
      worst = std::max(worst, nearest);
    }
    INFO("image " << quick.image_index);
    CHECK(worst < 1.0);
  }
}

TEST_CASE("a refit that fails is a warning and the previous fit stands", "[refit_warning]") {
  PANO_SEEDED_RNG(66);
  TargetBoard board;
  board.cols = 9;
  board.rows = 6;
  board.square = 3.0;
  const Sensor truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor;
  const auto set = test::MakeSyntheticSet(truth, board, 6, 12.0, 30.0, -30.0, 10.0, 0.05, rng);
  REQUIRE(set.views.size() == 6);
  InitialEstimate start;
  start.sensor = truth;
  start.sensor.params.rim_radius = 0.0;
  start.poses = set.true_poses;
  start.summary = "the truth";
  std::vector<std::string> carried = {"an earlier warning"};

  // A bound below the corners' noise: the refit's own check fails.
  CalibrateOptions strict;
  strict.max_rms_px = 1e-3;
  const auto failed = calib_internal::TryRefit("the test refit", set.views, board, start, true, "cm", strict,
                                               &carried);
  CHECK_FALSE(failed.has_value());
  REQUIRE(carried.size() == 2);
  CHECK(carried[0] == "an earlier warning");
  CHECK(carried[1].rfind("the test refit failed (calibration failed: RMS reprojection error", 0) == 0);
  CHECK(carried[1].find("; the previous fit stands") != std::string::npos);

  // The same refit within the bound: its result carries every warning so
  // far, first, and its comment (the calibration file's) names them.
  const auto fit = calib_internal::TryRefit("the test refit", set.views, board, start, true, "cm",
                                            CalibrateOptions(), &carried);
  REQUIRE(fit);
  CHECK(fit->rms_px < 0.1);
  REQUIRE(fit->warnings.size() >= 2);
  CHECK(fit->warnings[0] == carried[0]);
  CHECK(fit->warnings[1] == carried[1]);
  CHECK(fit->calib.comment.find("Warning: " + carried[1]) != std::string::npos);
}

}  // namespace
}  // namespace pano

// --model auto: the mirror profile chosen by cross-validation over the
// boards. On rendered boards of a mirror bent away from any conic the
// asphere maps held-out boards far better and is chosen; on the paper's
// sphere no richer profile does better by the margin and the sphere stays.
#include <catch2/catch.hpp>

#include <cmath>

#include "expect_error.h"
#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/model_selection.h"
#include "panotrack/io/calibration.h"
#include "rendered_targets.h"
#include "test_paths.h"

namespace pano {
namespace {

const ModelScore& Score(const CalibrationResult& r, const std::string& name) {
  for (const ModelScore& s : r.model_scores)
    if (s.name == name) return s;
  FAIL("no score for " << name);
  return r.model_scores.front();
}

CalibrationResult CalibrateAuto(const std::string& name, const Calibration& truth) {
  const TargetSet targets = ReadTargets(test::RenderTargets(name, truth, 14, 5) + "/targets.yaml");
  REQUIRE(targets.AllPosesKnown());
  CalibrateOptions o;
  o.select_model = true;
  o.distortion_terms = 0;
  const CalibrationResult r = Calibrate(targets, o);
  WARN(ModelSelectionTable(r.model_scores, r.model_chosen));
  REQUIRE(r.model_scores.size() == 4);
  REQUIRE(r.model_chosen >= 0);
  return r;
}

TEST_CASE("model selection: the asphere for a mirror that is not a conic, the sphere for a sphere",
          "[model_selection]") {
  Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  SECTION("sphere bent by a4 0.02, a6 0.03") {
    truth.sensor.model = MirrorModel::kAsphere;
    truth.sensor.params.asphere_a4 = 0.02;
    truth.sensor.params.asphere_a6 = 0.03;
    truth.sensor.Check("truth");
    const CalibrationResult r = CalibrateAuto("model_selection_asphere", truth);
    CHECK(r.model_scores[r.model_chosen].name == "asphere (a4, a6)");
    CHECK(r.calib.sensor.model == MirrorModel::kAsphere);
    // Measured: conic 0.159, asphere (a4, a6) 0.0757 px held out.
    CHECK(Score(r, "asphere (a4, a6)").heldout_rms_px < 0.5 * Score(r, "conic").heldout_rms_px);
    CHECK(Score(r, "asphere (a4, a6)").heldout_rms_px < 0.085);
    CHECK(Score(r, "asphere (a4, a6)").failed_boards == 0);
    CHECK(r.calib.sensor.params.asphere_a4 == Approx(0.02).margin(0.002));
  }
  SECTION("the paper's sphere") {
    const CalibrationResult r = CalibrateAuto("model_selection_sphere", truth);
    CHECK(r.model_scores[r.model_chosen].name == "sphere");
    CHECK(r.calib.sensor.model == MirrorModel::kSphere);
    // Every richer profile within 1 % (it contains the sphere); measured
    // 0.0739 px held out for sphere and conic alike.
    CHECK(Score(r, "conic").heldout_rms_px > 0.99 * Score(r, "sphere").heldout_rms_px);
    CHECK(Score(r, "sphere").heldout_rms_px < 0.082);
  }
}

TEST_CASE("model selection: too few boards to hold any out", "[model_selection]") {
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const TargetSet targets = ReadTargets(test::RenderTargets("model_selection_few", truth, 3, 5) + "/targets.yaml");
  CalibrateOptions o;
  o.select_model = true;
  test::ExpectError([&] { Calibrate(targets, o); }, "model selection", {"3 boards found", "needs 4 at least"});
  o.selection_folds = 1;
  test::ExpectError([&] { o.Check(); }, "model selection", {"expected 2..100 folds"});
}

}  // namespace
}  // namespace pano

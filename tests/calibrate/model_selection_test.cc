// --model auto: the mirror profile, lens distortion and rig faults chosen by
// cross-validation over the boards. On rendered boards of a mirror bent away
// from any conic the asphere maps held-out boards far better and is chosen;
// behind a lens with strong radial distortion the sphere with k1 k2 is; on the
// paper's sphere no richer model does better by the margin and the sphere
// stays. A candidate the boards do not determine is refused.
#include <catch2/catch.hpp>

#include <cmath>

#include "expect_error.h"
#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/model_selection.h"
#include "panotrack/io/calibration.h"
#include "panotrack/pipeline/target_input.h"
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

// lens_given: distortion_terms 0 for every candidate (then 7 candidates),
// else the lens is chosen too (9).
CalibrationResult CalibrateAuto(const std::string& name, const Calibration& truth, bool lens_given = true,
                                const std::string& target_file = "targets.yaml") {
  const TargetSet targets = ReadTargets(test::RenderTargets(name, truth, 14, 5) + "/" + target_file);
  CalibrateOptions o;
  o.select_model = true;
  if (lens_given) o.distortion_terms = 0;
  o.num_threads = 2;
  const CalibrationResult r = Calibrate(targets, LoadTargetImages(targets), o);
  WARN(ModelSelectionTable(r.model_scores, r.model_chosen) << "chosen: " << r.model_reason);
  REQUIRE(r.model_scores.size() == (lens_given ? 7u : 9u));
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

TEST_CASE("model selection: lens distortion chosen behind a distorting lens", "[model_selection]") {
  Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  truth.sensor.params.k1 = -0.12;
  truth.sensor.params.k2 = 0.08;
  truth.sensor.Check("truth");
  const CalibrationResult r = CalibrateAuto("model_selection_lens", truth, /*lens_given=*/false);
  CHECK(r.model_scores[r.model_chosen].name == "sphere + k1 k2");
  CHECK(r.calib.sensor.model == MirrorModel::kSphere);
  CHECK(r.model_reason.find("sphere + k1 k2") == 0);
  // Measured: sphere 0.1541 px, conic 0.0741 px (a conic absorbs much of
  // the lens: with k1 -0.05 alone it maps held-out boards within 1 % of the
  // sphere + k1 k2 and, simpler, is chosen), sphere + k1 k2 0.0726 px held
  // out (the richer models 0.0727 px); the asphere (a4, a6) refused (k2
  // -0.31 +- 1.62).
  CHECK(Score(r, "sphere + k1 k2").heldout_rms_px < 0.6 * Score(r, "sphere").heldout_rms_px);
  CHECK(Score(r, "sphere + k1 k2").heldout_rms_px < 0.99 * Score(r, "conic").heldout_rms_px);
  CHECK(Score(r, "sphere + k1 k2").heldout_rms_px < 0.08);
  CHECK_FALSE(Score(r, "asphere (a4, a6) + k1 k2").refused.empty());
  CHECK(r.calib.sensor.params.k1 == Approx(-0.12).margin(0.015));
}

TEST_CASE("model selection: a model the boards do not determine is refused", "[model_selection]") {
  CalibrateOptions o;
  CalibrationResult fit;
  fit.parameters = {{"focal_px", 2035.0, 1390.0, false}, {"cx", 376.0, 0.5, false},
                    {"mirror_radius", 2.0, NAN, false},  {"k1", -0.5, 0.2, false},
                    {"k2", -103.0, 310.0, false},         {"azimuth_offset", 0.0, 0.0, true}};
  const std::string why = UndeterminedParameters(fit, o);
  CHECK(why.find("focal_px 2035 +- 1390") != std::string::npos);
  CHECK(why.find("k2 -103 +- 310") != std::string::npos);
  CHECK(why.find("k1") == std::string::npos);             // determined well enough
  CHECK(why.find("mirror_radius") == std::string::npos);  // the mirror's size is not judged
  fit.parameters = {{"focal_px", 590.0, 0.6, false}, {"conic_constant", -0.2, NAN, false}};
  CHECK(UndeterminedParameters(fit, o) == "conic_constant not determined");
  fit.parameters = {{"focal_px", 590.0, 100.0, false}};
  CHECK(UndeterminedParameters(fit, o).empty());  // 17 %, under the 20 % default
  o.selection_max_focal_rel_std = 0.1;
  CHECK_FALSE(UndeterminedParameters(fit, o).empty());
}

TEST_CASE("model selection: too few boards to hold any out", "[model_selection]") {
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const TargetSet targets = ReadTargets(test::RenderTargets("model_selection_few", truth, 3, 5) + "/targets.yaml");
  CalibrateOptions o;
  o.select_model = true;
  test::ExpectError([&] { Calibrate(targets, LoadTargetImages(targets), o); }, "model selection",
                    {"3 boards found", "needs 4 at least"});
  // As `panocalib calibrate`'s default: the sphere fitted, and said so.
  o.selection_fallback = true;
  const CalibrationResult r = Calibrate(targets, LoadTargetImages(targets), o);
  CHECK(r.calib.sensor.model == MirrorModel::kSphere);
  CHECK(r.model_scores.empty());
  CHECK(r.model_chosen == -1);
  bool said = false;
  for (const std::string& w : r.warnings) said = said || w.find("3 boards are too few to choose the model") == 0;
  CHECK(said);
  o.selection_folds = 1;
  test::ExpectError([&] { o.Check(); }, "model selection", {"expected 2..100 folds"});
}

}  // namespace
}  // namespace pano

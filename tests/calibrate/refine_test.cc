// Model-based corner refinement on rendered chessboard images: corners found
// by the detector on strongly curved squares carry a systematic error that
// the fit turns into biased parameters; located again on the board plane
// through the fitted model, the bias goes.
#include <catch2/catch.hpp>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/target_input.h"
#include "rendered_targets.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::RenderTargets;

TEST_CASE("refined corners remove the detector's bias (rendered boards, known poses)", "[refine]") {
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const TargetSet targets = ReadTargets(RenderTargets("calibrate_refine", truth, 10, 5) + "/targets.yaml");
  const std::vector<cv::Mat> images = LoadTargetImages(targets);
  struct Outcome {
    double rms_px, distance_error;
  };
  auto calibrate = [&](int passes) {
    CalibrateOptions o;
    o.refine_passes = passes;
    const CalibrationResult r = Calibrate(targets, images, o);
    INFO("passes " << passes << ": focal " << r.calib.sensor.params.focal_px << ", distance "
                   << r.calib.sensor.mirror_distance() << ", RMS " << r.rms_px);
    return Outcome{r.rms_px, std::abs(r.calib.sensor.mirror_distance() / truth.sensor.mirror_distance() - 1.0)};
  };
  const Outcome before = calibrate(0), after = calibrate(1);
  WARN("detected corners: RMS " << before.rms_px << " px, mirror distance error " << 100 * before.distance_error
                                << " %; refined: RMS " << after.rms_px << " px, " << 100 * after.distance_error
                                << " %");
  // The bounds with known poses: RMS 0.3 px, mirror distance 1 %; the
  // distance is guarded at 0.6 % (measured 0.19 %). The boards reach the
  // limb, where the detector's corners are off by up to a pixel; the
  // refinement must bring them under the bounds.
  CHECK(after.rms_px < 0.3);
  CHECK(after.rms_px < before.rms_px);
  CHECK(after.distance_error < 0.006);
  CHECK(after.distance_error <= before.distance_error + 0.002);
}

TEST_CASE("rendered boards, unknown poses: parameters near the truth", "[rendered_unknown]") {
  // The synthetic acceptance on a smaller set: panosim's --auto
  // boards (near, up to 60 degrees above the mirror), noise 2 grey levels,
  // the whole pipeline from the images with the board poses estimated.
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const TargetSet targets =
      ReadTargets(RenderTargets("calibrate_rendered_unknown", truth, 12, 3) + "/targets_unknown.yaml");
  REQUIRE_FALSE(targets.AllPosesKnown());
  const CalibrationResult r = Calibrate(targets, LoadTargetImages(targets), CalibrateOptions());
  const SensorParams<double>& p = r.calib.sensor.params;
  const double focal = p.focal_px / truth.sensor.params.focal_px - 1.0;
  const double radius = r.calib.sensor.mirror_radius() / truth.sensor.mirror_radius() - 1.0;
  const double distance = r.calib.sensor.mirror_distance() / truth.sensor.mirror_distance() - 1.0;
  WARN("unknown poses, 12 rendered boards: focal " << 100 * focal << " %, cx " << p.cx - truth.sensor.params.cx
                                                  << " px, cy " << p.cy - truth.sensor.params.cy << " px, radius "
                                                  << 100 * radius << " %, distance " << 100 * distance
                                                  << " %, RMS " << r.rms_px << " px, " << r.views.size()
                                                  << " boards");
  CHECK_FALSE(r.poses_known);
  CHECK(r.views.size() >= 11);
  // Measured 0.43 % focal, 0.42 % distance (0.22 % and 0.055 % before the
  // unwarped boards were searched again through the final model: new
  // corners on the boards near the limb move the fit along the valley of
  // focal length and mirror size that estimated poses leave); the issue's
  // bound for unknown poses is 1 %.
  CHECK(std::abs(focal) < 0.006);
  CHECK(std::abs(p.cx - truth.sensor.params.cx) < 0.01);   // measured 0.0032 px
  CHECK(std::abs(p.cy - truth.sensor.params.cy) < 0.03);   // measured 0.0107 px
  CHECK(std::abs(radius) < 0.002);  // measured 0.065 %
  CHECK(std::abs(distance) < 0.006);  // measured 0.42 %
  CHECK(r.rms_px < 0.3);
}

}  // namespace
}  // namespace pano

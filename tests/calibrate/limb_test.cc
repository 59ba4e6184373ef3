// The mirror's limb as a measurement (limb.h): measured on rendered images of
// an imperfect rig, it sits on the true limb; fitted on request.
#include <catch2/catch.hpp>

#include <cmath>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/limb.h"
#include "panotrack/io/targets.h"
#include "panotrack/render/presets.h"
#include "panotrack/pipeline/target_input.h"
#include "panotrack/pipeline/panocalib.h"
#include "rendered_targets.h"

namespace pano {
namespace {

using test::RenderTargets;

struct LimbStats {
  double mean = 0, rms = 0, first_harmonic = 0;  // pixels
};

// The limb points' distances from `sensor`'s limb: mean, RMS and the
// amplitude of their first harmonic about the image centre (a shifted limb).
LimbStats Stats(const LimbObservation& obs, const Sensor& sensor) {
  LimbStats st;
  double c = 0, s = 0;
  int n = 0;
  const std::vector<double> r = LimbResidualsPx(obs, sensor);
  for (size_t k = 0; k < r.size(); ++k) {
    if (!std::isfinite(r[k])) continue;
    const double a = std::atan2(obs.points[k].y() - sensor.params.cy, obs.points[k].x() - sensor.params.cx);
    st.mean += r[k];
    st.rms += r[k] * r[k];
    c += r[k] * std::cos(a);
    s += r[k] * std::sin(a);
    ++n;
  }
  REQUIRE(n > 0);
  st.mean /= n;
  st.rms = std::sqrt(st.rms / n);
  st.first_harmonic = 2.0 * std::hypot(c, s) / n;
  return st;
}

TEST_CASE("limb measured on rendered images of a faulty rig", "[limb]") {
  const Calibration truth = MakePreset("faulty-rig").calib;
  const TargetSet targets = ReadTargets(RenderTargets("calibrate_limb", truth, 6, 7) + "/targets_unknown.yaml");
  const std::vector<cv::Mat> images = LoadTargetImages(targets);
  // Predicted from the truth and from a sensor 2 px off: the points found are
  // on the edge either way (the prediction only says where to look).
  Sensor shifted = truth.sensor;
  shifted.params.cx += 2.0;
  const Sensor* const guesses[] = {&truth.sensor, &shifted};
  for (const Sensor* guess : guesses) {
    const LimbObservation obs = MeasureLimb(images, *guess, LimbOptions(), 2);
    CHECK(obs.points.size() >= 350);  // measured 360 of 360
    CHECK(obs.images_used == 6);
    CHECK(obs.point_sigma_px > 0.03);  // measured 0.063: the pixel grid's pattern
    CHECK(obs.point_sigma_px < 0.12);
    const LimbStats st = Stats(obs, truth.sensor);
    INFO("mean " << st.mean << " rms " << st.rms << " first harmonic " << st.first_harmonic);
    CHECK(std::abs(st.mean) < 0.02);       // measured 0.0075 px
    CHECK(st.rms < 0.1);                   // measured 0.072 px
    CHECK(st.first_harmonic < 0.015);      // measured 0.004 px
    CHECK(Stats(obs, shifted).first_harmonic > 1.5);  // the 2 px shift shows
  }
  // A conic has no silhouette of its own here: nothing measured.
  Sensor conic = truth.sensor;
  conic.model = MirrorModel::kConic;
  conic.params.conic_constant = -0.5;
  CHECK(MeasureLimb(images, conic, LimbOptions(), 2).Empty());
  CHECK(MeasureLimb({}, truth.sensor).Empty());  // no images
}

TEST_CASE("limb fitted with the corners on request", "[limb]") {
  const Calibration truth = MakePreset("faulty-rig").calib;
  const TargetSet targets =
      ReadTargets(RenderTargets("calibrate_limb_fit", truth, 14, 7) + "/targets_unknown.yaml");
  CalibrateOptions o;
  o.free_faults_auto = true;
  o.distortion_terms = 2;
  o.num_threads = 2;
  o.use_limb = true;
  const CalibrationResult r = Calibrate(targets, LoadTargetImages(targets), o);
  REQUIRE_FALSE(r.limb.Empty());
  CHECK(r.limb.points.size() >= 350);
  CHECK(r.limb_rms_px < 0.1);  // measured 0.069 px
  CHECK(r.rms_px < 0.12);      // measured 0.084 px
  CHECK(CalibrationSummary(r).find("mirror limb: ") != std::string::npos);
}

}  // namespace
}  // namespace pano

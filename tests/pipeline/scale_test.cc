// --scale: frames resized before tracking, the calibration scaled to match.
#include <catch2/catch.hpp>

#include <cmath>

#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/pipeline/panoloc.h"
#include "pipeline_fixture.h"

namespace pano {
namespace {

using test::OneInput;
using test::Scratch;

TEST_CASE("ScaledSensor: a point lands where cv::resize moves its pixel", "[scale]") {
  const Sensor s = ReadCalibration(test::GetSmallCase().calib).sensor;
  for (double scale : {0.5, 0.8, 0.37}) {
    const Sensor t = ScaledSensor(s, scale);
    CHECK(t.image_width == std::lround(s.image_width * scale));
    const double sx = double(t.image_width) / s.image_width, sy = double(t.image_height) / s.image_height;
    for (const Eigen::Vector3d& x : {Eigen::Vector3d(80, -30, 20), Eigen::Vector3d(-10, 50, -40)}) {
      Eigen::Vector2d p, q;
      REQUIRE(s.project(x, &p));
      REQUIRE(t.project(x, &q));
      CHECK(q.x() == Approx((p.x() + 0.5) * sx - 0.5).margin(1e-9));
      CHECK(q.y() == Approx((p.y() + 0.5) * sy - 0.5).margin(1e-9));
    }
  }
  CHECK_THROWS_AS(ScaledSensor(s, 0.0), Error);
}

TEST_CASE("panoloc --scale tracks the resized frames against the scaled calibration", "[scale]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_scale");
  for (double scale : {1.0, 0.8}) {
    PanolocOptions o = OneInput(c.video, dir + "/scale" + std::to_string(scale) + ".csv");
    o.scale = scale;
    o.gt = c.gt;
    const std::vector<VideoSummary> s = RunPanoloc(o);
    REQUIRE(s.size() == 1);
    INFO(s[0].error);
    REQUIRE(s[0].ok);
    CHECK(s[0].n_ok == c.n_frames);
    REQUIRE(s[0].has_accuracy);
    // Measured RMS: 0.0078 units at full size, 0.0076 at 0.8 (400 x 400).
    CHECK(s[0].accuracy.rms < 0.010);
  }
  PanolocOptions bad = OneInput(c.video, dir + "/bad.csv");
  bad.scale = 1.5;
  CHECK_THROWS_WITH(bad.Check(), Catch::Contains("--scale (scale)"));
}

}  // namespace
}  // namespace pano

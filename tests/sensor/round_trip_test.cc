// Round trips through every sensor model: pixel -> reflected ray -> point ->
// pixel, and point -> pixel -> ray through the point.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "sensor_models.h"
#include "test_rng.h"

namespace pano {
namespace {

// project(point on backproject(pixel)) must land on the pixel to rounding,
// over a dense polar grid of the mirror's annulus.
void CheckPixelRoundTrip(const test::NamedSensor& ns) {
  const Sensor& s = ns.sensor;
  const double limb = s.limb_radius();
  const double scale = s.params.vertex_distance + s.params.curvature_radius;
  double worst = 0.0;
  int n = 0;
  for (int ir = 0; ir < 240; ++ir) {
    // From near the axis to just inside the limb, denser near the limb.
    const double frac = 0.02 + 0.975 * std::sin(0.5 * M_PI * ir / 239.0);
    const double radius = frac * limb;
    for (int ia = 0; ia < 180; ++ia) {
      const double az = -M_PI + 2.0 * M_PI * (ia + 0.37) / 180.0;
      const Eigen::Vector2d px = s.from_polar(radius, az);
      Eigen::Vector3d o, d;
      REQUIRE(s.backproject(px, &o, &d));
      for (double t : {0.7 * scale, 6.0 * scale, 80.0 * scale}) {
        Eigen::Vector2d back;
        const bool ok = s.project(o + t * d, &back);
        INFO(ns.name << " radius " << radius << " az " << az << " t " << t);
        REQUIRE(ok);
        worst = std::max(worst, (back - px).norm());
        ++n;
      }
    }
  }
  INFO(ns.name << ": worst pixel round-trip error " << worst << " px over " << n << " points");
  CHECK(worst < 100 * std::numeric_limits<double>::epsilon() * std::max(s.image_width, s.image_height));
  WARN(ns.name << ": pixel round trip worst " << worst << " px over " << n << " points");
}

// The ray back-projected from project(X) passes through X (relative 2e-10:
// the solver's tolerance, measured 5.5e-11 at worst).
void CheckPointRoundTrip(const test::NamedSensor& ns, std::mt19937_64& rng) {
  const Sensor& s = ns.sensor;
  const double scale = s.params.vertex_distance + s.params.curvature_radius;
  std::uniform_real_distribution<double> uni(-40.0 * scale, 40.0 * scale);
  int visible = 0;
  double worst = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const double z = uni(rng), y = uni(rng), x = uni(rng);  // (drawn in a set order: a call's argument order is the compiler's)
    const Eigen::Vector3d X(x, y, z);
    Eigen::Vector2d px;
    if (!s.project(X, &px)) continue;
    ++visible;
    Eigen::Vector3d o, d;
    REQUIRE(s.backproject(px, &o, &d));
    const Eigen::Vector3d ox = X - o;
    const double dist = (ox - ox.dot(d) * d).norm();
    CHECK(ox.dot(d) > 0.0);
    worst = std::max(worst, dist / ox.norm());
  }
  INFO(ns.name << ": " << visible << " visible points, worst relative miss " << worst);
  CHECK(visible > 2000);
  CHECK(worst < 2e-10);
  WARN(ns.name << ": point round trip worst relative miss " << worst);
}

TEST_CASE("pixel -> ray -> point -> pixel to rounding, every model", "[round_trip]") {
  for (const auto& ns : test::AllSensorModels()) CheckPixelRoundTrip(ns);
}

TEST_CASE("point -> pixel -> ray through the point within 2e-10, every model", "[round_trip]") {
  PANO_SEEDED_RNG(20261122);
  for (const auto& ns : test::AllSensorModels()) CheckPointRoundTrip(ns, rng);
}

}  // namespace
}  // namespace pano

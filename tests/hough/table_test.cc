// The PH table (Eqns 5-7) against the exact composition through the sensor
// model, and against points of known horizontal lines.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "panotrack/core/error.h"
#include "hough_fixtures.h"
#include "test_rng.h"

namespace pano {
namespace {

TEST_CASE("PH table matches E(E^-1(R_i, Z) cos dtheta, Z) on lines of the room", "[table]") {
  PANO_SEEDED_RNG(11);
  const Sensor s = test::PaperSyntheticSensor();
  const auto table = test::BuildTestTable(s);
  std::uniform_real_distribution<double> ud(30.0, 250.0), udt(0.0, 80.0 * M_PI / 180);
  double worst_fwd = 0, worst_inv = 0, worst_exact_fn = 0;
  int n_checked = 0;
  for (double Z : {-30.0, -12.5, 15.0, 45.0, 70.0}) {
    const PhTable ph = PhTable::Build(*table, Z);
    CHECK(ph.height() == Z);
    for (int k = 0; k < 400; ++k) {
      const double d_main = ud(rng), dt = udt(rng) * (k % 2 ? 1 : -1);
      const double D = d_main / std::cos(dt);
      double r_main, r_i;
      if (D > 700 || !s.image_radius(d_main, Z, &r_main) || !s.image_radius(D, Z, &r_i)) continue;
      // Eqn 5: the point at dtheta maps back to the line's R_main.
      double got = 0;
      REQUIRE(ph.Main(r_i, dt, &got));
      worst_fwd = std::max(worst_fwd, std::abs(got - r_main));
      // Eqn 6: the curve through R_main passes through R_i.
      const double curve = CurveRadius(ph, r_main, dt);
      REQUIRE(std::isfinite(curve));
      worst_inv = std::max(worst_inv, std::abs(curve - r_i));
      // The exact reference functions agree with the direct projection.
      double ex = 0;
      REQUIRE(ExactPh(s, Z, r_i, dt, &ex));
      worst_exact_fn = std::max(worst_exact_fn, std::abs(ex - r_main));
      REQUIRE(ExactCurveRadius(s, Z, r_main, dt, &ex));
      worst_exact_fn = std::max(worst_exact_fn, std::abs(ex - r_i));
      ++n_checked;
    }
  }
  WARN("PH table vs exact over " << n_checked << " line points: PH worst " << worst_fwd
                                 << " px, PH^-1 worst " << worst_inv << " px");
  CHECK(n_checked > 1000);
  CHECK(worst_exact_fn < 100 * std::numeric_limits<double>::epsilon() * 250);  // rounding at radii up to 250 px
  // Tracking bins are 0.5 px and whole-image bins 1 px: the table's error must
  // be well below (a tenth of) the smaller.
  CHECK(worst_fwd < 0.05);
  CHECK(worst_inv < 0.05);
}

TEST_CASE("PH table built from the exact model equals the exact composition at the nodes", "[table]") {
  const Sensor s = test::PaperSyntheticSensor();
  const auto table = test::BuildTestTable(s);
  PhTableOptions o;
  o.exact = true;
  o.r_step = 1.0;
  o.dtheta_step = 2.0 * M_PI / 180;
  const PhTable ph = PhTable::Build(*table, -30.0, o);
  int n = 0;
  for (double r = 20.0; r < 150.0; r += 7.0)
    for (double dt = 0.0; dt < 1.3; dt += 4.0 * M_PI / 180) {
      double ex = 0, got = 0, D = 0;
      // Within the slices' distance range.
      if (!s.inverse_image_radius(r, -30.0, &D) || D > 3000 || D * std::cos(dt) < 25) continue;
      if (!ExactPh(s, -30.0, r, dt, &ex) || ex < 5.0) continue;
      REQUIRE(ph.Main(r, -dt, &got));  // even in dtheta
      CHECK(got == Approx(ex).margin(3e-5));
      ++n;
    }
  CHECK(n > 100);
}

TEST_CASE("PH table rejects bad heights and options with one-line errors", "[table]") {
  const Sensor s = test::PaperSyntheticSensor();
  const auto table = test::BuildTestTable(s);
  CHECK_THROWS_AS(PhTable::Build(*table, std::nan("")), Error);
  CHECK_THROWS_AS(PhTable::Build(*table, 500.0), Error);
  PhTableOptions o;
  o.r_step = 0.0;
  CHECK_THROWS_AS(PhTable::Build(*table, 0.0, o), Error);
  o = PhTableOptions();
  o.dtheta_max = M_PI / 2;
  CHECK_THROWS_AS(PhTable::Build(*table, 0.0, o), Error);
  CHECK_THROWS_AS(PhTable::Build(RadiusTable(), 0.0), Error);
  // The cache builds once per height.
  PhTableCache cache(table);
  auto a = cache.Get(-30.0), b = cache.Get(-30.0), c = cache.Get(70.0);
  CHECK(a.get() == b.get());
  CHECK(a.get() != c.get());
  CHECK(cache.size() == 2);
  // Outside the table: false, and CurveRadius NaN.
  double out;
  CHECK_FALSE(a->Main(1e4, 0.1, &out));
  CHECK_FALSE(a->Main(100.0, 1.56, &out));
  CHECK(std::isnan(CurveRadius(*a, std::nan(""), 0.1)));
}

}  // namespace
}  // namespace pano

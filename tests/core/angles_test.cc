// The toolkit's arc tangent against the C library's.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>

#include "panotrack/core/angles.h"
#include "test_rng.h"

namespace pano {
namespace {

// Units in the last place of `reference` between the two.
double UlpsApart(double value, double reference) {
  const double ulp = std::nextafter(std::abs(reference), std::numeric_limits<double>::infinity()) - std::abs(reference);
  return std::abs(value - reference) / ulp;
}

TEST_CASE("FastAtan2: within 2 ulp of std::atan2 in every octant and at the edges", "[fast_atan2]") {
  PANO_SEEDED_RNG(20261129);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> exponent(-30.0, 30.0);
  double worst = 0.0;
  for (int k = 0; k < 2000000; ++k) {
    // Mixed scales: rays near the axes and the diagonals, tiny and huge.
    // (One draw per statement: operand order is the compiler's choice.)
    const double y_unit = unit(rng), y_exp = exponent(rng);
    const double x_unit = unit(rng), x_exp = exponent(rng);
    const double y = y_unit * std::pow(2.0, y_exp * (k % 3 == 0));
    const double x = x_unit * std::pow(2.0, x_exp * (k % 5 == 0));
    worst = std::max(worst, UlpsApart(FastAtan2(y, x), std::atan2(y, x)));
  }
  INFO("worst " << worst << " ulp");
  CHECK(worst <= 2.0);
  // The sixteenths themselves, the diagonals and the axes.
  for (int i = 0; i <= 16; ++i)
    for (int sx : {1, -1})
      for (int sy : {1, -1}) {
        CHECK(UlpsApart(FastAtan2(sy * i / 16.0, sx * 1.0), std::atan2(sy * i / 16.0, sx * 1.0)) <= 2.0);
        CHECK(UlpsApart(FastAtan2(sy * 1.0, sx * i / 16.0), std::atan2(sy * 1.0, sx * i / 16.0)) <= 2.0);
      }
  // Zeros, infinities and NaN as the C library: signed zeros and pi included.
  const double inf = std::numeric_limits<double>::infinity(), nan = std::nan("");
  for (double y : {0.0, -0.0, 1.0, -1.0, inf, -inf})
    for (double x : {0.0, -0.0, 1.0, -1.0, inf, -inf}) {
      INFO("y " << y << " x " << x);
      CHECK(FastAtan2(y, x) == std::atan2(y, x));
      CHECK(std::signbit(FastAtan2(y, x)) == std::signbit(std::atan2(y, x)));
    }
  CHECK(std::isnan(FastAtan2(nan, 1.0)));
  CHECK(std::isnan(FastAtan2(1.0, nan)));
}

}  // namespace
}  // namespace pano

// The whole-image transform's per-pixel arithmetic against its reference:
// the gradient angle bin without the arctangent equals the single-precision
// arctangent's bin, and the rounding helpers equal std::floor / std::lround.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "panotrack/hough/gradient_bin.h"
#include "test_rng.h"

namespace pano {
namespace {

TEST_CASE("gradient angle bins without the arctangent equal the arctangent's", "[gradient_bin]") {
  PANO_SEEDED_RNG(17);
  const detail::GradientBinEdges edges;
  int64_t checked = 0;
  auto check = [&](double g_tan, double g_rad) {
    ++checked;
    const int exact = detail::GradientAngleBinExact(g_tan, g_rad);
    const int fast = detail::GradientAngleBin(g_tan, g_rad, edges);
    if (fast != exact)
      FAIL("gradient (" << g_rad << ", " << g_tan << "): bin " << fast << ", expected " << exact);
  };
  // Gradients as Prepare makes them: integer Sobel values rotated by a pixel azimuth.
  std::uniform_int_distribution<int> sobel(-1020, 1020);
  std::uniform_real_distribution<double> azimuth(0.0, 2.0 * M_PI);
  for (int i = 0; i < 2000000; ++i) {
    const double gx = sobel(rng), gy = sobel(rng), a = azimuth(rng);
    const double c = static_cast<float>(std::cos(a)), s = static_cast<float>(std::sin(a));
    check(-gx * s + gy * c, gx * c + gy * s);
  }
  // On and next to every bin edge, on the axes and near +-90 degrees.
  for (int b = 0; b <= detail::kGradientAngleBins; ++b) {
    const double phi = (b - 90) * M_PI / 180;
    for (double d : {0.0, 1e-9, -1e-9, 1e-7, -1e-7, 1e-6, -1e-6, 2e-5, -2e-5, 1e-3, -1e-3})
      for (double r : {1.0, 37.5, 1000.0}) {
        check(r * std::sin(phi + d), r * std::cos(phi + d));
        check(-r * std::sin(phi + d), -r * std::cos(phi + d));  // the opposite polarity
      }
  }
  for (double v : {0.0, -0.0, 1.0, -1.0, 1e-30})
    for (double w : {1.0, -1.0, 3.0, -250.0}) {
      check(v, w);
      check(w, v);
    }
  REQUIRE(checked > 2000000);
}

TEST_CASE("rounding helpers equal std::floor and std::lround", "[gradient_bin]") {
  PANO_SEEDED_RNG(18);
  std::uniform_real_distribution<double> any(-1e6, 1e6), positive(0.0, 1e6);
  for (int i = 0; i < 200000; ++i) {
    const double x = any(rng), y = positive(rng);
    REQUIRE(detail::FloorToInt(x) == static_cast<int>(std::floor(x)));
    REQUIRE(detail::RoundNonNegative(y) == static_cast<int>(std::lround(y)));
  }
  for (double x : {0.0, 0.5, 1.5, 2.5, 0.49999999999999994, 7.0, 255.5, 1e9 + 0.5}) {
    CHECK(detail::RoundNonNegative(x) == static_cast<int>(std::lround(x)));
    CHECK(detail::FloorToInt(-x) == static_cast<int>(std::floor(-x)));
  }
}

}  // namespace
}  // namespace pano

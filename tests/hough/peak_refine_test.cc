// The tracking accumulator's shortcuts against the plain versions they
// replace: the separable smoothing of a block and the peak search of a block
// are bit-identical to SmoothBinomial3x3 and FindAndRefinePeak of the whole
// zero-extended grid, PhTable's row lookup to Main, and a call to
// TrackHorizontalLine does not depend on the calls before it (its
// accumulator is reused).
#include <catch2/catch.hpp>

#include <cstring>
#include <vector>

#include "hough_fixtures.h"
#include "panotrack/hough/peak_refine.h"
#include "test_rng.h"

namespace pano {
namespace {

bool SameBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// A grid zero outside the block [y0, y0 + by) x [x0, x0 + bx), sparse
// positive votes inside (as the tracking accumulator).
std::vector<float> BlockGrid(int ny, int nx, int y0, int x0, int by, int bx, std::mt19937_64& rng) {
  std::vector<float> g(static_cast<size_t>(ny) * nx, 0.0f);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int y = y0; y < y0 + by; ++y)
    for (int x = x0; x < x0 + bx; ++x)
      if (u(rng) < 0.6f) g[static_cast<size_t>(y) * nx + x] = u(rng) * 3.0f;
  return g;
}

TEST_CASE("separable smoothing and block peak search equal the whole-grid ones bit for bit", "[peak_refine]") {
  PANO_SEEDED_RNG(31);
  std::uniform_int_distribution<int> size(1, 40);
  int cases = 0, interior_peaks = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int ny = size(rng), nx = size(rng);
    const int y0 = std::uniform_int_distribution<int>(0, ny - 1)(rng);
    const int x0 = std::uniform_int_distribution<int>(0, nx - 1)(rng);
    const int by = std::uniform_int_distribution<int>(1, ny - y0)(rng);
    const int bx = std::uniform_int_distribution<int>(1, nx - x0)(rng);
    std::vector<float> g = BlockGrid(ny, nx, y0, x0, by, bx, rng);
    g[static_cast<size_t>(y0) * nx + x0] += 0.5f;  // a positive maximum
    INFO("grid " << ny << "x" << nx << " block at " << y0 << "," << x0 << " size " << by << "x" << bx);

    std::vector<float> whole(g.size());
    SmoothBinomial3x3(g.data(), ny, nx, whole.data());
    std::vector<float> full_h(g.size()), full_sep(g.size());
    SmoothBinomial3x3Separable(g.data(), ny, nx, nx, full_h.data(), full_sep.data());
    for (size_t i = 0; i < g.size(); ++i) REQUIRE(SameBits(whole[i], full_sep[i]));

    // The block plus one cell (clipped to the grid), smoothed on its own.
    const int sy0 = std::max(y0 - 1, 0), sy1 = std::min(y0 + by, ny - 1);
    const int sx0 = std::max(x0 - 1, 0), sx1 = std::min(x0 + bx, nx - 1);
    const int sby = sy1 - sy0 + 1, sbx = sx1 - sx0 + 1;
    std::vector<float> h(static_cast<size_t>(sby) * sbx), block(h.size());
    SmoothBinomial3x3Separable(&g[static_cast<size_t>(sy0) * nx + sx0], sby, sbx, nx, h.data(), block.data());
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x) {
        const bool inside = y >= sy0 && y <= sy1 && x >= sx0 && x <= sx1;
        const float v = inside ? block[static_cast<size_t>(y - sy0) * sbx + (x - sx0)] : 0.0f;
        REQUIRE(SameBits(v, whole[static_cast<size_t>(y) * nx + x]));
      }

    const PeakFit ref = FindAndRefinePeak(whole.data(), ny, nx);
    const PeakFit got = FindAndRefinePeakInBlock(block.data(), sby, sbx, sbx, sy0, sx0, ny, nx);
    REQUIRE(SameBits(ref.x, got.x));
    REQUIRE(SameBits(ref.y, got.y));
    REQUIRE(SameBits(ref.value, got.value));
    REQUIRE(ref.at_border == got.at_border);
    // Unsmoothed: the block itself, rows nx apart.
    const PeakFit ref_raw = FindAndRefinePeak(g.data(), ny, nx);
    const PeakFit got_raw = FindAndRefinePeakInBlock(&g[static_cast<size_t>(y0) * nx + x0], by, bx, nx, y0, x0, ny, nx);
    REQUIRE(SameBits(ref_raw.x, got_raw.x));
    REQUIRE(SameBits(ref_raw.y, got_raw.y));
    REQUIRE(ref_raw.at_border == got_raw.at_border);
    ++cases;
    if (!ref.at_border) ++interior_peaks;
  }
  CHECK(cases == 400);
  CHECK(interior_peaks > 100);  // the sub-bin refinement is exercised
}

TEST_CASE("PhTable row lookups equal Main bit for bit", "[peak_refine]") {
  const Sensor s = test::PaperSyntheticSensor();
  const auto table = test::BuildTestTable(s);
  const PhTable ph = PhTable::Build(*table, -30.0);
  PANO_SEEDED_RNG(32);
  std::uniform_real_distribution<double> ur(-5.0, ph.r_max() + 5.0), ut(-1.7, 1.7);
  int defined = 0, undefined = 0;
  for (int k = 0; k < 20000; ++k) {
    const double r = ur(rng), dt = ut(rng);
    double a = -1.0, b = -1.0;
    const bool main_ok = ph.Main(r, dt, &a);
    PhTable::MainRow row;
    const bool row_ok = ph.RowAt(r, &row) && ph.MainOnRow(row, dt, &b);
    INFO("R_i " << r << " dtheta " << dt);
    REQUIRE(main_ok == row_ok);
    if (main_ok) {
      REQUIRE(SameBits(a, b));
      ++defined;
    } else {
      ++undefined;
    }
  }
  CHECK(defined > 5000);
  CHECK(undefined > 1000);
}

TEST_CASE("tracking results do not depend on the calls before", "[peak_refine]") {
  const Sensor s = test::PaperSyntheticSensor();
  const auto table = test::BuildTestTable(s);
  const PhTable ph = PhTable::Build(*table, -30.0);
  PANO_SEEDED_RNG(33);
  std::vector<TrackingResult> first;
  std::vector<TrackingWindow> windows;
  std::vector<std::vector<TrackingVote>> point_sets;
  for (double d_main : {45.0, 80.0, 140.0})
    for (double bearing : {0.3, 2.0, -2.5}) {
      const test::HLine line{-30.0, d_main, bearing};
      double r_true = 0, t_true = 0;
      REQUIRE(test::LineTruth(s, line, &r_true, &t_true));
      point_sets.push_back(test::LinePoints(s, line, -0.3, 0.6, 25, 0.3, rng));
      TrackingWindow w;
      w.r_main = r_true + 1.3;
      w.theta_main = t_true - 0.02;
      w.r_halfwidth = 4.0 + d_main / 20;  // windows of several sizes
      w.smooth = bearing > 0;
      windows.push_back(w);
    }
  for (size_t k = 0; k < windows.size(); ++k) first.push_back(TrackHorizontalLine(ph, windows[k], point_sets[k]));
  // Again in reverse order: each call must find a clean accumulator.
  for (size_t j = windows.size(); j-- > 0;) {
    const TrackingResult r = TrackHorizontalLine(ph, windows[j], point_sets[j]);
    INFO("case " << j);
    REQUIRE(r.found == first[j].found);
    CHECK(SameBits(r.r_main, first[j].r_main));
    CHECK(SameBits(r.theta_main, first[j].theta_main));
    CHECK(SameBits(r.peak, first[j].peak));
    CHECK(SameBits(r.score, first[j].score));
    CHECK(r.n_votes == first[j].n_votes);
    CHECK(r.n_inliers == first[j].n_inliers);
  }
  CHECK(first[0].found);
}

}  // namespace
}  // namespace pano

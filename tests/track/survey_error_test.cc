// The survey error estimate: the map's survey sigma as the localiser uses
// it, checked against bearing residuals at various distances.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "expect_error.h"
#include "panotrack/track/survey_error.h"
#include "test_rng.h"

namespace pano {
namespace {

constexpr double kUnstated = std::numeric_limits<double>::quiet_NaN();

// `frames` frames of `n` bearings at distances uniform in [50, 250]: each
// residual drawn from N(0, image^2 + (survey / d)^2).
// With `pairs`, each edge's two corners too: their residuals' difference
// (image noise alone).
void Feed(SurveyErrorEstimate* e, std::mt19937_64& rng, double survey, double image, int frames, int n = 15,
          bool pairs = false) {
  std::uniform_real_distribution<double> distance(50.0, 250.0);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int f = 0; f < frames; ++f) {
    std::vector<double> residuals, distances, differences;
    for (int i = 0; i < n; ++i) {
      const double d = distance(rng);
      distances.push_back(d);
      residuals.push_back(unit(rng) * std::hypot(image, survey / d));
      if (pairs) differences.push_back(unit(rng) * std::sqrt(2.0) * image);
    }
    // Residuals of a 3-parameter fit are smaller than the errors: feed them
    // without the pose's share (fitted = 0) so the scale is the error's.
    e->Update(residuals, distances, differences, 0);
  }
}

// One frame of 12 bearings at distances 110 - 130 (too close together to
// split the residuals) and `n_pairs` edges' pairs (image noise alone).
struct NarrowFrame {
  std::vector<double> residuals, distances, pairs;
};
NarrowFrame DrawNarrowFrame(std::mt19937_64& rng, double survey, double image, int n_pairs) {
  std::uniform_real_distribution<double> distance(110.0, 130.0);
  std::normal_distribution<double> unit(0.0, 1.0);
  NarrowFrame f;
  for (int i = 0; i < 12; ++i) {
    f.distances.push_back(distance(rng));
    f.residuals.push_back(unit(rng) * std::hypot(image, survey / f.distances.back()));
  }
  for (int k = 0; k < n_pairs; ++k) f.pairs.push_back(unit(rng) * std::sqrt(2.0) * image);
  return f;
}

TEST_CASE("survey error: the fit tells a map's error from the image noise by the landmarks' distances",
          "[survey_error]") {
  PANO_SEEDED_RNG(37);
  SurveyErrorOptions o;
  SurveyErrorEstimate e(o, 120.0);
  CHECK(!e.confident());
  // Comparable shares: the image noise is a third of the survey's at the
  // typical distance (1 / 120 rad).
  Feed(&e, rng, 1.0, 0.003, 60);
  REQUIRE(e.confident());
  INFO("survey " << e.estimated() << " image " << e.image_sigma());
  CHECK(e.estimated() == Approx(1.0).epsilon(0.25));
  // The split's image share is the noisier one (squared residuals are
  // heavy-tailed): bounded, not pinned.
  CHECK(e.image_sigma() < 0.006);
}

TEST_CASE("survey error: the near landmarks the pose fit leans on do not hide the map's error", "[survey_error]") {
  PANO_SEEDED_RNG(41);
  SurveyErrorEstimate e(SurveyErrorOptions(), 120.0);
  // Each frame: two landmarks at 40 whose errors the fit absorbs four
  // fifths of (leverage 0.8), and far ones at 160 - 220 it absorbs a tenth
  // of; a 2-unit survey error and little image noise.
  const double survey = 2.0, image = 0.0005;
  std::uniform_real_distribution<double> far(160.0, 220.0);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int f = 0; f < 30; ++f) {
    std::vector<double> residuals, distances, leverages;
    for (int i = 0; i < 12; ++i) {
      const double d = i < 2 ? 40.0 : far(rng);
      const double h = i < 2 ? 0.8 : 0.1;
      distances.push_back(d);
      leverages.push_back(h);
      residuals.push_back(unit(rng) * std::sqrt(1.0 - h) * std::hypot(image, survey / d));
    }
    e.Update(residuals, distances, {}, 3, leverages);
  }
  REQUIRE(e.confident());
  INFO("survey " << e.estimated() << " image " << e.image_sigma());
  CHECK(e.estimated() == Approx(survey).epsilon(0.15));
}

TEST_CASE("survey error: without edge pairs or spread distances the excess beyond a tracker's noise is the map's",
          "[survey_error]") {
  PANO_SEEDED_RNG(43);
  SurveyErrorOptions o;
  SurveyErrorEstimate e(o, 120.0);
  // Landmarks at 110 - 130 only: a 2-unit survey error (about 0.95 degree
  // there) cannot be told from image noise by the distances, and no pairs.
  std::uniform_real_distribution<double> distance(110.0, 130.0);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int f = 0; f < 30; ++f) {
    std::vector<double> residuals, distances;
    for (int i = 0; i < 12; ++i) {
      distances.push_back(distance(rng));
      residuals.push_back(unit(rng) * 2.0 / distances.back());
    }
    e.Update(residuals, distances, {}, 0);
  }
  REQUIRE(e.confident());
  INFO("survey " << e.estimated() << " image " << e.image_sigma());
  // The image holds at most the noisiest tracker's 0.3 degree; the rest
  // (sqrt(0.95^2 - 0.3^2) of 0.95: 0.95 of it) is the map's.
  CHECK(e.image_sigma() <= o.max_image_sigma * (1 + 1e-12));
  CHECK(e.estimated() == Approx(1.9).epsilon(0.15));
}

TEST_CASE("survey error: one edge pair with a wrong junction does not take the map's error for the image's",
          "[survey_error]") {
  PANO_SEEDED_RNG(47);
  SurveyErrorEstimate e(SurveyErrorOptions(), 120.0);
  // Landmarks at 110 - 130 (the distances cannot split the residuals), a
  // 1-unit survey error, image noise 0.0005 rad, two edges' pairs a frame:
  // the pairs alone bound the image's share.
  const double survey = 1.0, image = 0.0005;
  for (int f = 0; f < 12; ++f) {
    NarrowFrame frame = DrawNarrowFrame(rng, survey, image, 2);
    // On one frame one corner of an edge is a degree off (someone in front
    // of it): its pair's difference is no image noise.
    if (f == 8) frame.pairs.push_back(1.0 * M_PI / 180);
    e.Update(frame.residuals, frame.distances, frame.pairs, 0);
  }
  REQUIRE(e.confident());
  INFO("survey " << e.estimated() << " image " << e.image_sigma());
  CHECK(e.estimated() == Approx(survey).epsilon(0.15));
  CHECK(e.image_sigma() < 4.0 * image);
}

TEST_CASE("survey error: the edge pairs' order does not change the estimate", "[survey_error]") {
  // The pairs are kept in the order of their squared difference (their
  // median and core); a frame's pairs given in reverse must give the same
  // estimate, bit for bit.
  PANO_SEEDED_RNG(53);
  SurveyErrorEstimate forward(SurveyErrorOptions(), 120.0), reverse(SurveyErrorOptions(), 120.0);
  const double survey = 1.0, image = 0.0005;
  for (int f = 0; f < 20; ++f) {
    NarrowFrame frame = DrawNarrowFrame(rng, survey, image, 4);
    forward.Update(frame.residuals, frame.distances, frame.pairs, 0);
    std::reverse(frame.pairs.begin(), frame.pairs.end());
    reverse.Update(frame.residuals, frame.distances, frame.pairs, 0);
    INFO("frame " << f);
    CHECK(forward.estimated() == reverse.estimated());
    CHECK(forward.image_sigma() == reverse.image_sigma());
  }
  REQUIRE(forward.confident());
  // The pairs bound the image's share: the rest is the map's.
  CHECK(forward.estimated() == Approx(survey).epsilon(0.2));
}

TEST_CASE("survey error: the fit's sums are the same to the bit on the vector unit and without it",
          "[survey_error]") {
  // Every length from empty to a few vectors and a tail, samples at the
  // spread a run gives them (u = 1/d^2, y = r^2 / kept, forgotten weights).
  PANO_SEEDED_RNG(61);
  std::uniform_real_distribution<double> distance(40.0, 400.0), weight(1e-2, 1.0);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (size_t n = 0; n <= 41; ++n) {
    std::vector<double> u, y, w;
    for (size_t i = 0; i < n; ++i) {
      const double d = distance(rng), r = unit(rng) * std::hypot(0.001, 0.5 / d);
      u.push_back(1.0 / (d * d));
      y.push_back(r * r / 0.9);
      w.push_back(weight(rng));
    }
    for (const auto& [a, b] : {std::pair{0.0, 0.25}, std::pair{1e-6, 0.3}, std::pair{3e-7, 0.0}}) {
      const internal::NormalSums vector = internal::WeightedNormalSums(u.data(), y.data(), w.data(), n, a, b);
      const internal::NormalSums portable = internal::PortableNormalSums(u.data(), y.data(), w.data(), n, a, b);
      INFO(n << " samples, a " << a << " b " << b);
      CHECK(vector.s1 == portable.s1);
      CHECK(vector.su == portable.su);
      CHECK(vector.suu == portable.suu);
      CHECK(vector.sy == portable.sy);
      CHECK(vector.suy == portable.suy);
      // Lane order or not, the sums are the weighted normal equations'.
      double s1 = 0.0, suy = 0.0;
      for (size_t i = 0; i < n; ++i) {
        const double v = std::max(a + b * u[i], 1e-30), wi = w[i] / (v * v);
        s1 += wi;
        suy += wi * u[i] * y[i];
      }
      CHECK(portable.s1 == Approx(s1).epsilon(1e-12));
      CHECK(portable.suy == Approx(suy).epsilon(1e-12));
    }
  }
}

TEST_CASE("survey error: forgotten frames leave no trace, however long the run", "[survey_error]") {
  // Weights forgotten below a hundredth (0.99^459) are dropped: after 470
  // frames, a run that saw 4600 frames of another map before (its weights
  // rescaled on the way) holds the same evidence as one that saw only the
  // 470, and gives the same estimate to rounding.
  PANO_SEEDED_RNG(67);
  SurveyErrorEstimate long_run(SurveyErrorOptions(), 150.0), fresh(SurveyErrorOptions(), 150.0);
  Feed(&long_run, rng, 3.0, 0.002, 4600);
  INFO("after the other map: survey " << long_run.estimated());
  CHECK(long_run.estimated() == Approx(3.0).epsilon(0.15));
  std::mt19937_64 copy = rng;
  Feed(&long_run, rng, 0.5, 0.0005, 470);
  Feed(&fresh, copy, 0.5, 0.0005, 470);
  REQUIRE(fresh.confident());
  CHECK(long_run.confident());
  CHECK(long_run.estimated() == Approx(fresh.estimated()).epsilon(1e-9));
  CHECK(long_run.image_sigma() == Approx(fresh.image_sigma()).epsilon(1e-9));
  CHECK(fresh.estimated() == Approx(0.5).epsilon(0.25));
}

TEST_CASE("survey error: edges with both corners found are wanted until a few bound the image noise",
          "[survey_error]") {
  PANO_SEEDED_RNG(44);
  SurveyErrorEstimate e(SurveyErrorOptions(), 120.0);
  CHECK(e.WantsPairs());
  // Frames without pairs leave them wanted; two pairs a frame reach ten
  // (twice the five that bound the image noise) on the sixth frame: after
  // five, forgetting leaves 9.8.
  Feed(&e, rng, 1.0, 0.0005, 20, 12, false);
  CHECK(e.WantsPairs());
  std::normal_distribution<double> unit(0.0, 1.0);
  int frames = 0;
  for (; frames < 20 && e.WantsPairs(); ++frames)
    e.Update({unit(rng) * 0.01, unit(rng) * 0.01}, {100.0, 120.0}, {unit(rng) * 0.001, unit(rng) * 0.001}, 0);
  CHECK(frames == 6);
  CHECK(!e.WantsPairs());
}

TEST_CASE("survey error: an exact map's residuals show no survey error", "[survey_error]") {
  PANO_SEEDED_RNG(38);
  SurveyErrorEstimate e(SurveyErrorOptions(), 120.0);
  Feed(&e, rng, 0.0, 0.0005, 40);
  INFO("survey " << e.estimated());
  // Below the doubt of an exact map (0.05 % of 120).
  CHECK(e.estimated() < 0.06);
  CHECK(e.Sigma(0.0) == 0.0);
}

TEST_CASE("survey error: the sigma used for a stated, an unstated and an exact map", "[survey_error]") {
  PANO_SEEDED_RNG(39);
  SurveyErrorOptions o;
  SurveyErrorEstimate e(o, 120.0);
  // Before any evidence: the statement, or a careful tape survey.
  CHECK(e.Sigma(kUnstated) == Approx(o.unstated_fraction * 120.0));
  CHECK(e.Sigma(0.0) == 0.0);
  CHECK(e.Sigma(0.3) == 0.3);
  // A probe's finding holds until the residuals say more.
  e.Provisional(0.6);
  e.Provisional(0.3);  // never lowered
  CHECK(e.provisional() == 0.6);
  CHECK(e.Sigma(0.0) == 0.6);
  CHECK(e.Sigma(1.0) == 1.0);
  // Residuals of a 2 cm survey: an exact statement is doubted, a smaller
  // one raised, a larger one kept; an unstated map takes the estimate.
  Feed(&e, rng, 2.0, 0.0005, 40);
  REQUIRE(e.confident());
  CHECK(e.Sigma(0.0) == Approx(e.estimated()));
  CHECK(e.Sigma(0.5) == Approx(e.estimated()));
  CHECK(e.Sigma(3.0) == 3.0);
  CHECK(e.Sigma(kUnstated) == Approx(e.estimated()));
  // Where the estimate is all there is, the covariances reported hold it
  // with its margin (never beyond the cap, 3 % of the typical distance); a
  // stated sigma, raised to it where smaller, with the stated margin.
  const double with_margin = std::min(o.estimate_margin * e.estimated(), o.max_fraction * 120.0);
  CHECK(with_margin > e.estimated());
  CHECK(e.ReportedSigma(0.0) == Approx(with_margin));
  CHECK(e.ReportedSigma(kUnstated) == Approx(with_margin));
  CHECK(e.ReportedSigma(0.5) == Approx(o.stated_margin * e.estimated()));
  CHECK(e.ReportedSigma(3.0) == Approx(o.stated_margin * 3.0));
  CHECK(o.stated_margin == 1.25);
  CHECK(e.estimated() == Approx(2.0).epsilon(0.25));
  // The cap: beyond 3 % of the typical distance a corner is wrong, not
  // imprecise.
  Feed(&e, rng, 20.0, 0.0005, 100);
  CHECK(e.estimated() == Approx(o.max_fraction * 120.0));
  CHECK(e.ReportedSigma(kUnstated) == Approx(o.max_fraction * 120.0));
  e.Reset();
  CHECK(!e.confident());
  CHECK(e.provisional() == 0.0);
}

TEST_CASE("survey error: a few frames' clear error is told before the estimate is confident", "[survey_error]") {
  PANO_SEEDED_RNG(41);
  SurveyErrorOptions o;
  // A 1.5 cm survey stated exact (or not stated): three frames of ten
  // edges, both corners of each found.
  SurveyErrorEstimate e(o, 120.0);
  Feed(&e, rng, 1.5, 0.0005, 3, 10, true);
  REQUIRE(!e.confident());
  INFO("early " << e.Early() << " estimated " << e.estimated());
  CHECK(e.Early() == e.estimated());
  // Thirty squared residuals: a rough estimate (0.71-2.19 over 80 seeds),
  // beyond a careful tape survey's 0.48.
  CHECK(e.Early() > 0.6);
  CHECK(e.Early() < 2.4);
  // It counts once made provisional (by the localiser, for a frame it
  // reports), not before.
  CHECK(e.Sigma(0.0) == 0.0);
  // The covariances reported hold it (with its margin) at once.
  CHECK(e.ReportedSigma(0.0) == Approx(o.estimate_margin * e.Early()));
  CHECK(e.ReportedSigma(0.5) == Approx(o.stated_margin * 0.5));
  e.Provisional(e.Early());
  CHECK(e.Sigma(0.0) == e.Early());
  CHECK(e.Sigma(kUnstated) == std::max(e.Early(), o.unstated_fraction * 120.0));
  CHECK(e.Sigma(3.0) == 3.0);
  // An exact map's first frames show nothing like it.
  SurveyErrorEstimate exact(o, 120.0);
  Feed(&exact, rng, 0.0, 0.0005, 3, 10, true);
  REQUIRE(!exact.confident());
  CHECK(exact.Early() == 0.0);
  CHECK(exact.Sigma(0.0) == 0.0);
  CHECK(exact.ReportedSigma(0.0) == 0.0);
  // Four bearings are not a frame's evidence.
  SurveyErrorEstimate thin(o, 120.0);
  Feed(&thin, rng, 1.0, 0.0005, 1, 4, true);
  CHECK(thin.Early() == 0.0);
}

TEST_CASE("survey error: options out of range are named", "[survey_error]") {
  SurveyErrorOptions o;
  o.exact_doubt_fraction = -1.0;
  CHECK_THAT(test::ErrorOf([&] { o.Check(); }), Catch::Contains("exact_doubt_fraction"));
  o = SurveyErrorOptions();
  o.forgetting = 0.0;
  CHECK_THAT(test::ErrorOf([&] { o.Check(); }), Catch::Contains("forgetting"));
  o = SurveyErrorOptions();
  o.max_image_sigma = 0.0;
  CHECK_THAT(test::ErrorOf([&] { o.Check(); }), Catch::Contains("max_image_sigma"));
  o = SurveyErrorOptions();
  o.estimate_margin = 0.5;
  CHECK_THAT(test::ErrorOf([&] { o.Check(); }), Catch::Contains("estimate_margin"));
  CHECK_THAT(test::ErrorOf([] { SurveyErrorEstimate(SurveyErrorOptions(), 0.0); }),
             Catch::Contains("typical landmark distance"));
}

}  // namespace
}  // namespace pano

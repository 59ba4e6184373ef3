// The localiser on a map measured by hand: every corner coordinate and
// height off by 1 cm (standard deviation), the map stating that, stating
// itself exact (a rendered map edited after the fact) or stating nothing.
// Each must track the paper-real sequence with no frame reported ok far off.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "panotrack/pipeline/accuracy.h"
#include "panotrack/render/sequence.h"
#include "track_fixture.h"

namespace pano {
namespace {

const test::RenderedCase& PaperReal() {
  static const test::RenderedCase r = test::RenderPreset("paper-real", 57);
  return r;
}

AccuracySummary LocalizeOnMeasuredMap(TrackingMethod method, double stated_sigma) {
  const test::RenderedCase& truth = PaperReal();
  test::RenderedCase r = truth;
  r.c.map = PerturbedMap(truth.c.map, 1.0, 2);
  r.c.map.survey_sigma = stated_sigma;
  r.table = TableForMap(r.c.calib, r.c.map, true);
  LocalizerOptions o;
  o.method = method;
  const std::vector<PoseRow> rows = test::Localize(r, o, truth.c.poses.front());
  return CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
}

void CheckMeasuredMap(double stated_sigma, const char* statement) {
  for (TrackingMethod method : {TrackingMethod::kJunction, TrackingMethod::kVertex}) {
    const AccuracySummary a = LocalizeOnMeasuredMap(method, stated_sigma);
    INFO(statement << ", " << tracking_method_name(method) << ": " << FormatAccuracy(a, "cm"));
    CHECK(a.tracked >= 55);
    CHECK(a.outliers == 0);
    // A 1 cm survey limits the accuracy to about half of it in this room.
    CHECK(a.rms <= 0.8);
  }
}

TEST_CASE("a map measured to 1 cm that says so", "[measured_map]") { CheckMeasuredMap(1.0, "stated 1 cm"); }

TEST_CASE("a map measured to 1 cm that says nothing: the survey error is estimated", "[measured_map]") {
  CheckMeasuredMap(std::numeric_limits<double>::quiet_NaN(), "not stated");
}

TEST_CASE("a map measured to 1 cm that claims to be exact: the residuals overrule it", "[measured_map]") {
  CheckMeasuredMap(0.0, "stated exact");
}

}  // namespace
}  // namespace pano

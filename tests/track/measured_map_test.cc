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

// The fraction of the ok rows whose position lies inside the ellipse of
// three of their reported standard deviations (std_x, std_y).
double InsideThreeSigma(const std::vector<PoseRow>& rows, const std::vector<PoseRow>& truth) {
  int ok = 0, inside = 0;
  for (size_t i = 0; i < rows.size() && i < truth.size(); ++i) {
    if (rows[i].status != PoseStatus::kOk || rows[i].extra.size() < 2) continue;
    ++ok;
    const double dx = (rows[i].pose.x - truth[i].pose.x) / rows[i].extra[0];
    const double dy = (rows[i].pose.y - truth[i].pose.y) / rows[i].extra[1];
    inside += std::hypot(dx, dy) <= 3.0;
  }
  return ok > 0 ? static_cast<double>(inside) / ok : 0.0;
}

struct MeasuredMapRun {
  AccuracySummary accuracy;
  double inside_three_sigma = 0.0;
};

MeasuredMapRun LocalizeOnMeasuredMap(TrackingMethod method, double stated_sigma) {
  const test::RenderedCase& truth = PaperReal();
  test::RenderedCase r = truth;
  r.c.map = PerturbedMap(truth.c.map, 1.0, 2);
  r.c.map.survey_sigma = stated_sigma;
  r.table = TableForMap(r.c.calib, r.c.map, true);
  LocalizerOptions o;
  o.method = method;
  const std::vector<PoseRow> rows = test::Localize(r, o, truth.c.poses.front());
  MeasuredMapRun run;
  run.accuracy = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
  run.inside_three_sigma = InsideThreeSigma(rows, truth.truth);
  return run;
}

void CheckMeasuredMap(double stated_sigma, const char* statement, double min_inside = 0.98) {
  for (TrackingMethod method : {TrackingMethod::kJunction, TrackingMethod::kVertex}) {
    const MeasuredMapRun run = LocalizeOnMeasuredMap(method, stated_sigma);
    const AccuracySummary& a = run.accuracy;
    INFO(statement << ", " << tracking_method_name(method) << ": " << FormatAccuracy(a, "cm") << ", inside 3 sigma "
                   << run.inside_three_sigma);
    CHECK(a.tracked >= 55);
    CHECK(a.outliers == 0);
    // A 1 cm survey limits the accuracy to about half of it in this room.
    CHECK(a.rms <= 0.8);
    // The covariances reported hold the map's error, stated or not, where
    // the pose absorbs part of it too.
    CHECK(run.inside_three_sigma >= min_inside);
  }
}

TEST_CASE("a map measured to 1 cm that says so", "[measured_map]") { CheckMeasuredMap(1.0, "stated 1 cm"); }

TEST_CASE("a map measured to 1 cm that says nothing: the survey error is estimated", "[measured_map]") {
  CheckMeasuredMap(std::numeric_limits<double>::quiet_NaN(), "not stated");
}

TEST_CASE("a map measured to 1 cm that claims to be exact: the residuals overrule it", "[measured_map]") {
  // Measured 0.965 - 1: the vertex method's first two frames, before the
  // residuals have overruled the statement, lie outside.
  CheckMeasuredMap(0.0, "stated exact", 0.96);
}

}  // namespace
}  // namespace pano

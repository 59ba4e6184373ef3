// The localiser on a map measured by hand: every corner coordinate and
// height off by 1 cm (standard deviation), the map stating that, stating
// itself exact (a rendered map edited after the fact) or stating nothing.
// Each must track the paper-real sequence with no frame reported ok far off.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <utility>

#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/pipeline/accuracy.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/render/sequence.h"
#include "panotrack/render/writers.h"
#include "test_paths.h"
#include "track_fixture.h"

namespace pano {
namespace {

const test::RenderedCase& PaperReal() {
  static const test::RenderedCase r = test::RenderPreset("paper-real", 57);
  return r;
}

// `truth`'s frames on its map measured to `sigma` (map seed `seed`),
// the map stating `stated` (NaN: nothing).
test::RenderedCase OnMeasuredMap(const test::RenderedCase& truth, double sigma, uint64_t seed, double stated) {
  test::RenderedCase r = truth;
  r.c.map = PerturbedMap(truth.c.map, sigma, seed);
  r.c.map.survey_sigma = stated;
  r.table = test::TableForMapOnce(r.c.calib, r.c.map);
  return r;
}

// `r` localised without a start pose (the first frame found by the
// room-wide search), its frames `fps` apart.
std::vector<PoseRow> LocalizeWithoutStart(const test::RenderedCase& r, const LocalizerOptions& o, double fps) {
  Localizer loc(r.c.calib, r.c.map, r.table, o);
  loc.ResetUnknown();
  return test::ProcessFrames(&loc, r, fps);
}

// `preset` rendered through its H.264 video into `dir`/seq (its case.yaml,
// the start, removed where `with_start` is false); the map is then written
// to `dir`/map.yaml by the caller and localised with RunOnVideo.
SequenceCase RenderVideo(const std::string& dir, const std::string& preset, bool with_start) {
  SequenceCase c = MakePreset(preset);
  SequenceWriteOptions w;
  w.overwrite = true;
  WriteSequence(c, dir + "/seq", w);
  if (!with_start) std::filesystem::remove(dir + "/seq/case.yaml");
  return c;
}

// panoloc on RenderVideo's video and `dir`/map.yaml, scored against gt.csv.
VideoSummary RunOnVideo(const std::string& dir, const LocalizerOptions& localizer) {
  PanolocOptions o;
  o.inputs = {dir + "/seq/video.mp4"};
  o.output = dir + "/est.csv";
  o.overwrite = true;
  o.calib_path = dir + "/seq/calib.yaml";
  o.map_path = dir + "/map.yaml";
  o.gt = dir + "/seq/gt.csv";
  o.quiet = true;  // a start, where there is one, comes from case.yaml beside the video
  o.localizer = localizer;
  const std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 1);
  REQUIRE(s[0].has_accuracy);
  return s[0];
}

// The paper-real frames from their true start given as a guess (panoloc's
// --init, or a case.yaml), on the map measured to `sigma` (map seed
// `seed`) stating `stated_sigma`, 5 frames a second.
std::vector<PoseRow> FromGuessOnMeasuredMap(TrackingMethod method, double stated_sigma, double sigma, uint64_t seed) {
  const test::RenderedCase& truth = PaperReal();
  const test::RenderedCase r = OnMeasuredMap(truth, sigma, seed, stated_sigma);
  LocalizerOptions o;
  o.method = method;
  Localizer loc(r.c.calib, r.c.map, r.table, o);
  loc.Reset(truth.c.poses.front(), /*hint=*/true);
  return test::ProcessFrames(&loc, r, 5.0);
}

struct MeasuredMapRun {
  AccuracySummary accuracy;
  double inside_three_sigma = 0.0;
};

MeasuredMapRun LocalizeOnMeasuredMap(TrackingMethod method, double stated_sigma, double sigma, uint64_t seed = 2) {
  const test::RenderedCase& truth = PaperReal();
  const test::RenderedCase r = OnMeasuredMap(truth, sigma, seed, stated_sigma);
  LocalizerOptions o;
  o.method = method;
  const std::vector<PoseRow> rows = test::Localize(r, o, truth.c.poses.front());
  MeasuredMapRun run;
  run.accuracy = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
  run.inside_three_sigma = test::InsideThreeSigma(rows, truth.truth);
  return run;
}

// What a run on a measured map must hold, with either method.
struct Expected {
  int min_tracked = 55;  // of 57
  // A 1 cm survey limits the accuracy to about half of it in this room.
  double max_rms = 0.8;
  // The covariances reported hold the map's error, stated or not, where
  // the pose absorbs part of it too.
  double min_inside = 0.98;
};

// `sigma`: the map's survey error; `stated_sigma`: what the map says (NaN:
// nothing).
void CheckMeasuredMap(double sigma, double stated_sigma, const char* statement, const Expected& e = {}) {
  for (TrackingMethod method : {TrackingMethod::kJunction, TrackingMethod::kVertex}) {
    const MeasuredMapRun run = LocalizeOnMeasuredMap(method, stated_sigma, sigma);
    const AccuracySummary& a = run.accuracy;
    INFO(statement << ", " << TrackingMethodName(method) << ": " << FormatAccuracy(a, "cm") << ", inside 3 sigma "
                   << run.inside_three_sigma);
    CHECK(a.tracked >= e.min_tracked);
    CHECK(a.outliers == 0);
    CHECK(a.rms <= e.max_rms);
    CHECK(run.inside_three_sigma >= e.min_inside);
  }
}

TEST_CASE("a map measured to 1 cm that says so", "[measured_map]") { CheckMeasuredMap(1.0, 1.0, "stated 1 cm"); }

TEST_CASE("a map measured to 1 cm that says nothing: the survey error is estimated", "[measured_map]") {
  CheckMeasuredMap(1.0, std::numeric_limits<double>::quiet_NaN(), "not stated");
}

TEST_CASE("a map measured to 2 cm that says so: posters surveyed behind their wall stay in view",
          "[measured_map]") {
  // Measured: 57 / 57, RMS 1.21 (junction) and 1.17 cm (vertex), all inside;
  // with the corners behind their walls hidden, 49 and 54 frames, RMS 1.61
  // and 2.75 cm, 2 wrong.
  CheckMeasuredMap(2.0, 2.0, "stated 2 cm", {56, 1.5, 0.98});
}

TEST_CASE("a map measured to 2 cm that claims to be exact: the probe sees the corners behind their walls",
          "[measured_map]") {
  // Measured: 57 / 57 with the vertex method, 55 with the junction method
  // (two frames without a velocity withheld for their solution
  // separation; 55 also when the probe's ladder kept the exact map's
  // walls), RMS 1.07 / 0.98 cm, 98 - 100 % inside.
  CheckMeasuredMap(2.0, 0.0, "stated exact", {55, 1.4, 0.96});
}

TEST_CASE("a map measured to 1 cm that claims to be exact: the residuals overrule it", "[measured_map]") {
  // Measured 0.965 - 1: the vertex method's first two frames, before the
  // residuals have overruled the statement, lie outside.
  Expected e;
  e.min_inside = 0.96;
  CheckMeasuredMap(1.0, 0.0, "stated exact", e);
}

TEST_CASE("a map measured to 2 cm that claims to be exact: no start on four bearings that agree by chance",
          "[measured_map]") {
  // A consensus that leaves found bearings out must keep two spare ones:
  // on these maps a start of four distinct bearings (one spare) agreed on
  // a pose centimetres off, reported with the image noise's covariance.
  // Measured (junction on map seed 4, vertex on seed 12): inside 3 sigma
  // 0.91 -> 1.0 and 0.84 -> 0.95, RMS 2.38 -> 2.15 and 1.84 -> 1.27 cm;
  // with the survey estimate fitted by its likelihood (the estimate near
  // the true 2 cm, not half of it) RMS 2.48 cm on seed 4, whose map error
  // moves even a pose from every edge in view 0.8 - 1 sigma.
  const std::pair<TrackingMethod, uint64_t> cases[] = {{TrackingMethod::kJunction, 4}, {TrackingMethod::kVertex, 12}};
  for (const auto& [method, seed] : cases) {
    const MeasuredMapRun run = LocalizeOnMeasuredMap(method, 0.0, 2.0, seed);
    INFO(TrackingMethodName(method) << ", map seed " << seed << ": " << FormatAccuracy(run.accuracy, "cm")
                                      << ", inside 3 sigma " << run.inside_three_sigma);
    CHECK(run.accuracy.tracked >= 56);
    CHECK(run.accuracy.outliers == 0);
    CHECK(run.accuracy.rms <= 2.6);
    CHECK(run.inside_three_sigma >= 0.94);
  }
}

TEST_CASE("a map measured to 2 cm that claims to be exact: a loss in a fast turn is not ended by a twin",
          "[measured_map]") {
  // The frames played twice as fast as they were taken (an image folder
  // read at panoloc's default 10 frames/s; the sequence is 5) and a start
  // given as a hint: the robot turns fast enough around frame 32 to be lost
  // for a few frames, and the room-wide search then finds a partial twin
  // of the room (turned by half a turn about its middle; 17 of 32 bearings
  // agree) 1.5 - 2 m away. Measured before the rule that a pose beyond the
  // robot's reach must stand on its own evidence: frames 36 - 56 reported
  // ok 150 - 207 cm off (map seed 2), 80 cm RMS (seed 7).
  const test::RenderedCase& truth = PaperReal();
  for (uint64_t seed : {uint64_t{2}, uint64_t{7}}) {
    const test::RenderedCase r = OnMeasuredMap(truth, 2.0, seed, 0.0);
    LocalizerOptions o;
    Localizer loc(r.c.calib, r.c.map, r.table, o);
    loc.Reset(truth.c.poses.front(), true);
    const std::vector<PoseRow> rows = test::ProcessFrames(&loc, r, 10.0);
    const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
    INFO("map seed " << seed << ": " << FormatAccuracy(a, "cm") << ", inside 3 sigma "
                     << test::InsideThreeSigma(rows, truth.truth));
    CHECK(a.outliers == 0);
    CHECK(a.max <= 10.0);
  }
}

TEST_CASE("a map measured to 2 cm that claims to be exact: the start takes the survey error most bearings agree under",
          "[measured_map]") {
  // The first frame fails under the exact statement, and the probe's
  // ladder of survey errors used to stop at the first level under which
  // two thirds of the bearings found agreed: 0.6 cm, where 22 of 30
  // agreed on a pose 4 cm off, which the next 7 frames kept (reported ok
  // 5.5 - 5.7 cm off). Now the smallest level under which nearly as many
  // agree as under any (1.2 cm: 30 of 32). With the survey estimate fitted
  // by its likelihood: RMS 1.18 cm, max 2.88 cm (a frame 1.4 sigma off),
  // every frame inside its 3-sigma ellipse.
  const MeasuredMapRun run = LocalizeOnMeasuredMap(TrackingMethod::kVertex, 0.0, 2.0, 7);
  INFO(FormatAccuracy(run.accuracy, "cm") << ", inside 3 sigma " << run.inside_three_sigma);
  CHECK(run.accuracy.tracked == 57);
  CHECK(run.accuracy.outliers == 0);
  CHECK(run.accuracy.max <= 3.0);
  CHECK(run.accuracy.rms <= 1.3);
}

TEST_CASE("a map measured to 2 cm that says nothing: a first frame where few found bearings agree is not taken",
          "[measured_map]") {
  // Started from a guess (panoloc's --init or a case.yaml), the first frame
  // found 28 bearings, of which 11 (6 edges) agreed on a pose 15.9 cm off
  // under the tape survey's error assumed (0.5 cm), reported ok. Refused,
  // the survey probe tries it under larger errors: 24 of 31 agree on a pose
  // 1.4 cm off.
  const test::RenderedCase& truth = PaperReal();
  const std::vector<PoseRow> rows =
      FromGuessOnMeasuredMap(TrackingMethod::kVertex, std::numeric_limits<double>::quiet_NaN(), 2.0, 4);
  const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
  INFO(FormatAccuracy(a, "cm") << ", inside 3 sigma " << test::InsideThreeSigma(rows, truth.truth) << "; first frame "
                               << std::hypot(rows[0].pose.x - truth.truth[0].pose.x,
                                             rows[0].pose.y - truth.truth[0].pose.y)
                               << " cm off");
  REQUIRE(rows[0].status == PoseStatus::kOk);
  CHECK(std::hypot(rows[0].pose.x - truth.truth[0].pose.x, rows[0].pose.y - truth.truth[0].pose.y) <= 2.5);
  CHECK(a.tracked == 57);
  CHECK(a.max <= 5.0);
}

TEST_CASE("a map measured to 2 cm that claims to be exact: a first frame that leaves a fifth of its bearings out is "
          "not taken",
          "[measured_map]") {
  // Started from a guess, the first frame found 10 of the 12 bearings
  // chosen; 8 agreed, under the exact statement's tolerances, on a pose
  // 5.1 cm off (reported ok, 38 of its standard deviations off): corners
  // measured centimetres off leave a subset that agrees on a pose off by
  // the error of the rest. Refused, the survey probe tries it under larger
  // errors.
  const test::RenderedCase& truth = PaperReal();
  const std::vector<PoseRow> rows = FromGuessOnMeasuredMap(TrackingMethod::kVertex, 0.0, 2.0, 6);
  const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
  const double dx = rows[0].pose.x - truth.truth[0].pose.x, dy = rows[0].pose.y - truth.truth[0].pose.y;
  REQUIRE(rows[0].status == PoseStatus::kOk);
  REQUIRE(rows[0].extra.size() >= 2);
  INFO(FormatAccuracy(a, "cm") << "; first frame " << std::hypot(dx, dy) << " cm off, std " << rows[0].extra[0]
                               << ", " << rows[0].extra[1]);
  // Measured 1.56 cm off, 1.8 of its standard deviations.
  CHECK(std::hypot(dx, dy) <= 2.0);
  CHECK(std::hypot(dx / rows[0].extra[0], dy / rows[0].extra[1]) <= 3.0);
  CHECK(a.tracked == 57);
  CHECK(a.outliers == 0);
}

TEST_CASE("a map measured to 2 cm that claims to be exact, no start: a search's hypothesis gives way to a better one",
          "[measured_map]") {
  // No start: the room-wide search verifies its hypotheses within the
  // exact statement's tolerances, where a partial twin of the room (turned
  // by half a turn about its middle) fits as many of them as the true pose.
  // Measured before the hypothesis held for confirmation gave way to the
  // next search's better supported pose, was forgotten when the next frame
  // did not confirm it (its frame's lesson to the survey estimate undone),
  // and was checked against the room-wide search under the tolerances that
  // confirmed it: junction, map seed 7, the twin held on 6 bearings, then
  // kept against the true pose found on 16 (55 frames 1.6 - 2.1 m off);
  // vertex, seeds 1 and 2, a wrong pose tracked once the probe had widened
  // the tolerances (7 and 37 frames 0.8 - 2.2 m off). After: no frame
  // further off than 3.5 cm, 55, 50 and 45 of 57 tracked. Since then the
  // junction run's frames 30 - 36 are 2 - 5 cm off on this map that claims
  // to be exact; fused with the motion's prediction (LocalizerOptions::
  // report_fused_with_motion) frames 30 - 32 come nearer and frame 33
  // goes from 4.77 to 5.35 cm.
  const test::RenderedCase& truth = PaperReal();
  struct Case {
    TrackingMethod method;
    uint64_t seed;
    int min_tracked;
  };
  for (const Case& c : {Case{TrackingMethod::kJunction, 7, 52}, Case{TrackingMethod::kVertex, 1, 48},
                        Case{TrackingMethod::kVertex, 2, 42}}) {
    const test::RenderedCase r = OnMeasuredMap(truth, 2.0, c.seed, 0.0);
    LocalizerOptions o;
    o.method = c.method;
    const std::vector<PoseRow> rows = LocalizeWithoutStart(r, o, 5.0);
    const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
    INFO(TrackingMethodName(c.method) << ", map seed " << c.seed << ": " << FormatAccuracy(a, "cm"));
    CHECK(a.outliers == 0);
    CHECK(a.max <= 5.6);
    CHECK(a.tracked >= c.min_tracked);
  }
}

TEST_CASE("no start: a search's pose held for the next frame is reported once that frame confirms it",
          "[measured_map]") {
  // paper-synthetic on a map measured to 2 cm (seed 1) that says so: the
  // search's pose of frame 0 fits too few of the landmarks chosen to track
  // to be reported at once. Frame 1, tracked from it, confirms it; frame 0
  // is then tracked again from its pose under what frame 1 taught and
  // reported. Measured: 0.21 cm off, 0.28 of its standard deviations.
  // The search verifies 20 hypotheses, as while tracking: verifying 30, as
  // before a first pose by default, it finds a pose on 22 landmarks that
  // stands at once (1.2 cm off).
  const test::RenderedCase truth = test::RenderPreset("paper-synthetic", 3);
  const test::RenderedCase r = OnMeasuredMap(truth, 2.0, 1, 2.0);
  LocalizerOptions twenty;
  twenty.relocalize_untracked_hypotheses = twenty.relocalize.hypotheses;
  Localizer loc(r.c.calib, r.c.map, r.table, twenty);
  loc.ResetUnknown();
  const FrameResult first = loc.Process(r.frames[0], 0, 0.0);
  REQUIRE(first.unconfirmed);
  CHECK(first.row.status == PoseStatus::kLost);
  CHECK(loc.FramesHeld() == 1);
  CHECK(loc.TakeConfirmedHolds().empty());
  const FrameResult second = loc.Process(r.frames[1], 1, 0.1);
  CHECK(second.row.status == PoseStatus::kOk);
  CHECK(loc.FramesHeld() == 0);
  const std::vector<FrameResult> confirmed = loc.TakeConfirmedHolds();
  REQUIRE(confirmed.size() == 1);
  CHECK(loc.TakeConfirmedHolds().empty());  // once
  const FrameResult* held = &confirmed.front();
  CHECK(held->row.frame == 0);
  CHECK(held->row.time_s == 0.0);
  REQUIRE(held->row.status == PoseStatus::kOk);
  REQUIRE(held->row.extra.size() == 4);
  const Pose2& t = truth.truth[0].pose;
  const double off = std::hypot(held->row.pose.x - t.x, held->row.pose.y - t.y);
  const double sigmas =
      std::hypot((held->row.pose.x - t.x) / held->row.extra[0], (held->row.pose.y - t.y) / held->row.extra[1]);
  INFO("frame 0: " << off << " cm off, " << sigmas << " standard deviations");
  CHECK(off <= 0.5);
  CHECK(sigmas <= 1.0);
  // A frame not held has nothing to confirm.
  loc.Process(r.frames[2], 2, 0.2);
  CHECK(loc.TakeConfirmedHolds().empty());
}

TEST_CASE("a map measured to 2 cm that claims to be exact, no start: a twin found first gives way to the true pose",
          "[measured_map]") {
  // The fast-turns loop (frames 0.1 s apart), no start. Under the exact
  // statement's tolerances the room-wide search finds nothing for 16
  // frames, then the half-turned twin of the room on 8 bearings (its first
  // pose, reported at once). The twin's residuals then widen the survey
  // estimate, under which the search on frame 18 verifies the true pose on
  // 22 of the landmarks chosen to track against the twin's 10. Measured
  // before a pose tracked from a search's is checked against the search
  // until the map's error is known: the twin tracked from frame 16 to the
  // end (277 frames 0.9 - 1.7 m off); after, frames 16 and 17 only (95 cm
  // off), every later one within 1.2 cm. Since the corners of the walls
  // passed near are tracked, the twin's frames 16 and 17 widen the survey
  // estimate to 0.78 cm only, under which the search on frame 18 verifies
  // nothing; frame 18's own residuals widen it to 1.56, and the search on
  // frame 19 verifies the true pose on 28 against the twin's 14 (frames 16
  // - 18 off). (With the search's survey probe, below, the true pose is
  // found on frame 0: off here to keep the twin.) Hypotheses tracked again
  // from what they found (off here too) verify the true pose on frame 3
  // beside the twin, 20 inliers against 18: no place leads under the exact
  // statement, and neither is reported in the 40 frames (none wrong).
  const test::RenderedCase truth = test::RenderPreset("fast-turns", 40);
  const test::RenderedCase r = OnMeasuredMap(truth, 2.0, 2, 0.0);
  LocalizerOptions o;
  o.method = TrackingMethod::kJunction;
  o.relocalize_survey_probe = false;
  o.relocalize_retrack_passes = 0;
  const std::vector<PoseRow> rows = LocalizeWithoutStart(r, o, 10.0);
  const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
  INFO(FormatAccuracy(a, "cm"));
  CHECK(a.outliers <= 3);
  int later_ok = 0;
  double later_max = 0.0;
  for (size_t i = 19; i < rows.size(); ++i) {
    if (rows[i].status != PoseStatus::kOk) continue;
    ++later_ok;
    later_max = std::max(later_max, std::hypot(rows[i].pose.x - truth.truth[i].pose.x,
                                               rows[i].pose.y - truth.truth[i].pose.y));
  }
  INFO("frames 19 - 39: " << later_ok << " ok, at most " << later_max << " cm off");
  CHECK(later_ok >= 20);
  CHECK(later_max <= 2.5);
  o.relocalize_retrack_passes = LocalizerOptions().relocalize_retrack_passes;
  const std::vector<PoseRow> retracked = LocalizeWithoutStart(r, o, 10.0);
  for (size_t i = 0; i < retracked.size(); ++i) {
    if (retracked[i].status != PoseStatus::kOk) continue;
    INFO("tracked again from what they found: frame " << i);
    CHECK(std::hypot(retracked[i].pose.x - truth.truth[i].pose.x, retracked[i].pose.y - truth.truth[i].pose.y) <= 2.5);
  }
}

TEST_CASE("a map measured to 2 cm that states nothing or claims to be exact, no start: the search tries larger errors",
          "[measured_map]") {
  // Under the tolerances of the survey error assumed (a tape survey's
  // 0.5 cm, or none) the room-wide search verified the true pose on few
  // frames, and the first pose came late. Measured before the search was
  // tried again under larger survey errors (map seeds 1 - 3; stating
  // nothing / stating 0): vertex 30, 28, 70 / 88, 79, 96 % of the frames
  // tracked, junction 95, 70, 70 / 84, 84, 56 %; after 98 - 100 %, no
  // frame further off than 7 cm. With the first frame's held pose reported
  // once confirmed: 53 - 57 of 57 tracked, every ok frame inside its 3
  // sigma; one outlier (junction, stating nothing, seed 3: frame 31, 6.6 cm
  // off, 1.5 of its standard deviations, counts as one once frame 0 is
  // reported: the median error falls below a fifth of it). Since the
  // landmarks whose horizontal edges pass near are tracked besides the
  // chosen (not in the search), and a held pose is confirmed only on a
  // frame that finds half the landmarks it chose: 50 - 57 of 57 (stating
  // nothing, seed 1 vertex and seed 2 junction, 50: the first pose comes
  // later), no frame further off than 7 cm.
  const test::RenderedCase& truth = PaperReal();
  for (TrackingMethod method : {TrackingMethod::kVertex, TrackingMethod::kJunction}) {
    for (double stated : {std::numeric_limits<double>::quiet_NaN(), 0.0}) {
      for (uint64_t seed : {uint64_t{1}, uint64_t{2}, uint64_t{3}}) {
        const test::RenderedCase r = OnMeasuredMap(truth, 2.0, seed, stated);
        LocalizerOptions o;
        o.method = method;
        const std::vector<PoseRow> rows = LocalizeWithoutStart(r, o, 5.0);
        const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
        INFO(TrackingMethodName(method) << ", stated " << stated << ", map seed " << seed << ": "
                                          << FormatAccuracy(a, "cm"));
        CHECK(a.tracked >= 50);
        CHECK(a.outliers <= 1);
        CHECK(a.max <= 7.0);
        CHECK(test::InsideThreeSigma(rows, truth.truth) >= 0.98);
      }
    }
  }
}

TEST_CASE("a map measured to 0.5 cm that says so, no start: the room's half-turned twin does not take the start",
          "[measured_map]") {
  // The fast-turns loop, vertex method, no start. The search verifies
  // nothing under the map's 0.5 cm and the twin under the probe's widest
  // level (22 bearings, 3.5 cm RMS across them); the true pose fits as many
  // at a seventh of that. Measured before a pose found only under the
  // probe waited for the next frame and before the search weighed the
  // fit: the twin taken on frame 0 and tracked to the end (293 of 300
  // frames 1.3 - 1.7 m off, reported ok); after, frames 0 and 1 not
  // reported, every later one within 1 cm.
  const test::RenderedCase truth = test::RenderPreset("fast-turns", 12);
  const test::RenderedCase r = OnMeasuredMap(truth, 0.5, 1, 0.5);
  LocalizerOptions o;
  o.method = TrackingMethod::kVertex;
  const std::vector<PoseRow> rows = LocalizeWithoutStart(r, o, 10.0);
  const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
  INFO(FormatAccuracy(a, "cm"));
  CHECK(a.tracked >= 9);
  CHECK(a.max <= 1.5);
}

TEST_CASE("a map measured to 2 cm that says so, no start: the place that keeps leading its half-turned twin is taken",
          "[measured_map]") {
  // The fast-turns loop (frames 0.1 s apart), vertex method, no start, map
  // seeds 1 and 3. Under the map's 2 cm the room-wide search verifies the
  // true pose and the room's half-turned twin on about as many bearings,
  // frame after frame, neither clearly ahead; the true pose on as many or
  // more, and its residuals up to 2 times smaller. Measured before the
  // search took the place that led in three consecutive searches: 8 of 40
  // frames tracked on both seeds (the first pose at frame 32, where the
  // twin no longer verifies); after, 38 on both (from frame 2), none
  // further off than 1.7 cm, every one inside its 3 sigma. (On seed 7 the
  // twin fits better on some frames and neither leads for long: the
  // junction method's frames all wait, none is reported wrong.)
  const test::RenderedCase truth = test::RenderPreset("fast-turns", 40);
  for (uint64_t seed : {uint64_t{1}, uint64_t{3}}) {
    const test::RenderedCase r = OnMeasuredMap(truth, 2.0, seed, 2.0);
    LocalizerOptions o;
    o.method = TrackingMethod::kVertex;
    const std::vector<PoseRow> rows = LocalizeWithoutStart(r, o, 10.0);
    const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
    INFO("map seed " << seed << ": " << FormatAccuracy(a, "cm"));
    CHECK(a.tracked >= 36);
    CHECK(a.outliers == 0);
    CHECK(a.max <= 2.0);
    CHECK(test::InsideThreeSigma(rows, truth.truth) >= 0.98);
  }
  LocalizerOptions bad;
  bad.relocalize_rival_fit = 0.9;
  CHECK_THROWS_WITH(bad.Check(), Catch::Contains("relocalize_rival_fit"));
  bad = LocalizerOptions();
  bad.relocalize_rival_searches = -1;
  CHECK_THROWS_WITH(bad.Check(), Catch::Contains("relocalize_rival_searches"));
}

TEST_CASE("a map measured to 0.5 cm that claims to be exact, no start: the first frames' partial consensus is not "
          "taken",
          "[measured_map]") {
  // The paper-real sequence through its H.264 video, no start, the map as
  // panosim's --map-sigma 0.5 writes it (seeds 3 and 8) but stated exact.
  // Until 60 inlier bearings have confirmed the map's error, it is tracked
  // under the image noise's tolerances; the first frames' residuals already
  // show the error (the covariances hold it), but each frame's consensus
  // is a subset of the corners that agree under the narrow tolerances, on
  // a pose off by the error of the rest. Measured before such a frame went
  // to the survey probe: vertex, seed 3, frame 3 3.9 cm off on 6 of the 10
  // bearings found (5.8 of its standard deviations); junction, seed 8,
  // frames 1 - 9 on 6 - 9 of 10 - 11, up to 1.43 cm off (two outliers);
  // after, no frame further off than 1.01 cm, none an outlier.
  const std::string dir = test::ScratchDir("measured_map_partial");
  const SequenceCase c = RenderVideo(dir, "paper-real", /*with_start=*/false);
  const std::vector<PoseRow> truth = ReadPoseCsv(dir + "/seq/gt.csv");
  for (uint64_t seed : {uint64_t{3}, uint64_t{8}}) {
    Map measured = PerturbedMap(c.map, 0.5, seed);
    measured.survey_sigma = 0.0;
    WriteMap(dir + "/map.yaml", measured);
    for (TrackingMethod method : {TrackingMethod::kVertex, TrackingMethod::kJunction}) {
      LocalizerOptions o;
      o.method = method;
      const AccuracySummary a = RunOnVideo(dir, o).accuracy;
      INFO(TrackingMethodName(method) << ", map seed " << seed << ": " << FormatAccuracy(a, "cm") << ", inside 3 sigma "
                                      << test::InsideThreeSigma(ReadPoseCsv(dir + "/est.csv"), truth));
      CHECK(a.tracked >= 54);
      CHECK(a.outliers == 0);
      CHECK(a.max <= 1.2);
    }
  }
}

TEST_CASE("a map measured to 1 unit that claims to be exact: its error is found from the first frame, with or without "
          "edges seen at both corners",
          "[measured_map]") {
  // The kidnap preset through its H.264 video, junction method, the map as
  // panosim's --map-sigma 1 --map-seed 2 writes it but stated exact. Few of the landmarks spread in azimuth share an edge, so
  // the image noise was bounded only by a poor tracker's 0.3 degree, which
  // took in the whole of the residuals: the map stayed exact, its
  // tolerances kept 6 - 9 landmarks that agreed on a pose a unit or more
  // off, reported with the image noise's covariance, and after the kidnap
  // nothing verified under them for 8 frames. Measured without the pairs
  // (noise_pairs 0): 52 of 60 frames, 42 % inside 3 sigma, RMS 1.08, max
  // 2.31 units; with them 60, 70 %, 0.96 and 2.02 (the first frames, before
  // the pairs have bounded the image noise, lie outside). Since the corners
  // of the walls passed near are tracked, the run without the pairs tracked
  // every frame, but 35 % inside 3 sigma (RMS 1.05, max 2.31 units). Since
  // a first frame on a map stated exact that leaves more than a sixth of
  // its found bearings out goes to the survey probe (7 of 12 found agreed
  // on a pose 1.4 units off), both runs alike: every frame inside 3 sigma,
  // RMS 0.78, max 1.17 units, but 51 of 60 tracked: the search's pose after
  // the kidnap is confirmed only by 2/3 of the 32 landmarks chosen as
  // inliers, and the frames after it find 21 of them (19 inliers) until
  // frame 39.
  const std::string dir = test::ScratchDir("measured_map_video");
  const SequenceCase c = RenderVideo(dir, "kidnap", /*with_start=*/true);
  Map measured = PerturbedMap(c.map, 1.0, 2);
  measured.survey_sigma = 0.0;
  WriteMap(dir + "/map.yaml", measured);
  const std::vector<PoseRow> truth = ReadPoseCsv(dir + "/seq/gt.csv");
  for (int noise_pairs : {0, LocalizerOptions().noise_pairs}) {
    LocalizerOptions o;
    o.method = TrackingMethod::kJunction;
    o.noise_pairs = noise_pairs;
    const AccuracySummary a = RunOnVideo(dir, o).accuracy;
    const double inside = test::InsideThreeSigma(ReadPoseCsv(dir + "/est.csv"), truth);
    INFO("noise pairs " << noise_pairs << ": " << FormatAccuracy(a, "units") << ", inside 3 sigma " << inside);
    CHECK(a.outliers == 0);
    CHECK(a.tracked >= 51);
    CHECK(a.max <= 1.3);
    CHECK(inside >= 0.98);
  }
}

TEST_CASE("a map measured to 1 unit that says so: a kidnapped robot is not kept where it was", "[measured_map]") {
  // The kidnap preset (the robot carried 40 units off at frame 30), vertex
  // method. Under the survey's tolerances the place it was carried from
  // fits 7 - 9 of the 29 - 32 landmarks chosen, and the motion model
  // predicts it. Measured before a weakly supported pose was checked
  // against the room-wide search and a search's pose could overrule the
  // one near the prediction: frames reported ok up to 31.4 (map seed 2)
  // and 40.0 units (seed 3) off; now within 1.11 and 0.44 units.
  const test::RenderedCase truth = test::RenderPreset("kidnap", 60);
  for (uint64_t seed : {2, 3}) {
    const test::RenderedCase r = OnMeasuredMap(truth, 1.0, seed, 1.0);
    LocalizerOptions o;
    o.method = TrackingMethod::kVertex;
    const std::vector<PoseRow> rows = test::Localize(r, o, truth.c.poses.front());
    const AccuracySummary a = CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
    INFO("map seed " << seed << ": " << FormatAccuracy(a, "units"));
    CHECK(a.tracked >= 58);
    CHECK(a.max <= 1.5);
  }
}

}  // namespace
}  // namespace pano

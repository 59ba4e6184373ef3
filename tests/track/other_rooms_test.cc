// The localiser in a room other than the paper's: the worked office of
// docs/examples/office-map.yaml (4.2 x 3.6 m; a door, windows and boards
// whose tops image within a few pixels of the mirror's limb) seen by the
// paper-real sensor along a loop with the heading wiggling up to 9 degrees
// a frame, on the exact map and on maps measured to 2 cm; the lab of
// docs/examples/lab-map.yaml under real conditions; and the studio of
// docs/examples/studio-map.yaml, whose landmarks stand metres away.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/pipeline/accuracy.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/render/sequence.h"
#include "test_paths.h"
#include "track_fixture.h"

namespace pano {
namespace {

// The loop: an ellipse about the room's middle, 300 frames for a turn,
// 10 frames a second, the heading along the path plus 25 degrees of
// wiggle (sin(0.37 frame)).
Pose2 OfficeLoopPose(int i) {
  const double t = 2.0 * M_PI * i / 300.0;
  const double wiggle = 25.0 * M_PI / 180.0 * std::sin(0.37 * i);
  return Pose2{200.0 + 120.0 * std::cos(t), 150.0 + 70.0 * std::sin(t),
               std::atan2(70.0 * std::cos(t), -120.0 * std::sin(t)) + wiggle};
}

// The lab's loop (docs/examples/lab-map.yaml): a rounded rectangle about
// its column (a superellipse of exponent 0.5, 190 x 120 cm about (300,
// 200)) at constant speed, 300 frames for a turn, the heading along the
// path plus 15 degrees of wiggle (sin(0.23 frame)).
Pose2 LabLoopPose(int i) {
  static const std::vector<Pose2> loop = [] {
    constexpr int kSamples = 20000, kLoop = 300;
    std::vector<Eigen::Vector2d> curve(kSamples + 1);
    std::vector<double> along(kSamples + 1, 0.0);
    const auto root = [](double v) { return std::copysign(std::sqrt(std::abs(v)), v); };
    for (int k = 0; k <= kSamples; ++k) {
      const double t = 2.0 * M_PI * k / kSamples;
      curve[k] = Eigen::Vector2d(300.0 + 190.0 * root(std::cos(t)), 200.0 + 120.0 * root(std::sin(t)));
      if (k > 0) along[k] = along[k - 1] + (curve[k] - curve[k - 1]).norm();
    }
    std::vector<Eigen::Vector2d> points;
    for (int k = 0; k < kLoop; ++k) {
      const double u = along.back() * k / kLoop;
      const size_t j = static_cast<size_t>(std::upper_bound(along.begin(), along.end(), u) - along.begin());
      const double f = (u - along[j - 1]) / (along[j] - along[j - 1]);
      points.push_back(curve[j - 1] + f * (curve[j] - curve[j - 1]));
    }
    std::vector<Pose2> poses;
    for (int k = 0; k < kLoop; ++k) {
      const Eigen::Vector2d tangent =
          points[static_cast<size_t>((k + 1) % kLoop)] - points[static_cast<size_t>((k + kLoop - 1) % kLoop)];
      poses.push_back(Pose2{points[k].x(), points[k].y(),
                            std::atan2(tangent.y(), tangent.x()) + 15.0 * M_PI / 180.0 * std::sin(0.23 * k)});
    }
    return poses;
  }();
  return loop[static_cast<size_t>(i % static_cast<int>(loop.size()))];
}

constexpr int kFrames = 30;

// Frames `first` to `last` of a loop through the room of `map_file` (a
// path in the source tree) as the paper-real sensor sees it, with noise 3
// and a 3 x 3 blur; `pose_at(i)`: frame i's pose.
test::RenderedCase RenderLoop(const std::string& map_file, Pose2 (*pose_at)(int), int first, int last) {
  test::RenderedCase c;
  c.c.calib = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  c.c.map = ReadMap(test::SourcePath(map_file));
  c.c.fps = 10.0;
  c.c.options.noise_sigma = 3.0;
  c.c.options.blur = true;
  const Scene scene = Scene::FromMap(c.c.map, true);
  const Renderer renderer(c.c.calib.sensor, scene, c.c.map.sensor_height, c.c.options);
  for (int i = first; i <= last; ++i) {
    c.c.poses.push_back(pose_at(i));
    c.frames.push_back(renderer.Render(c.c.poses.back(), i));
    PoseRow row;
    row.frame = i - first;
    row.pose = c.c.poses.back();
    c.truth.push_back(row);
  }
  c.table = test::TableForMapOnce(c.c.calib, c.c.map);
  return c;
}

// The loop's first kFrames.
const test::RenderedCase& Office() {
  static const test::RenderedCase r = RenderLoop("docs/examples/office-map.yaml", OfficeLoopPose, 0, kFrames - 1);
  return r;
}

// `base`'s frames on its map measured to `sigma` (map seed `seed`),
// stating it; `sigma` 0: the exact map, stating nothing.
test::RenderedCase OnMap(const test::RenderedCase& base, double sigma, uint64_t seed) {
  test::RenderedCase r = base;
  if (sigma > 0) {
    r.c.map = PerturbedMap(r.c.map, sigma, seed);
    r.c.map.survey_sigma = sigma;
    r.table = test::TableForMapOnce(r.c.calib, r.c.map);
  }
  return r;
}
test::RenderedCase OnMap(double sigma, uint64_t seed) { return OnMap(Office(), sigma, seed); }

AccuracySummary Score(const std::vector<PoseRow>& rows) {
  const test::RenderedCase& truth = Office();
  return CompareToGroundTruth(rows, truth.truth, TypicalRange(truth.c.map, truth.truth));
}

TEST_CASE("office, no start: the junction method tracks from a search's pose through a fast turn",
          "[other_rooms]") {
  // The first frames turn 8 - 11 degrees each. The room-wide search finds
  // the pose on frame 0; the frame after it is tracked from that pose to
  // confirm it, and the junction tracker's windows need the turn: the
  // visual compass measures it from the searched frame. Measured before
  // the compass was kept for a searched pose: the first 2 frames lost on
  // the exact map (3 through H.264: each search found the pose again, and
  // the next frame, tracked from it with no turn predicted, found 3 - 4
  // corners); after: none.
  const test::RenderedCase r = OnMap(0.0, 0);
  LocalizerOptions o;
  o.method = TrackingMethod::kJunction;
  Localizer loc(r.c.calib, r.c.map, r.table, o);
  loc.ResetUnknown();
  const std::vector<PoseRow> rows = test::ProcessFrames(&loc, r, r.c.fps);
  const AccuracySummary a = Score(rows);
  INFO(FormatAccuracy(a, "cm"));
  CHECK(a.tracked == kFrames);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 0.3);  // measured 0.13 cm
}

TEST_CASE("office, maps measured to 2 cm that say so, no start: searched poses confirmed through the turns",
          "[other_rooms]") {
  // Map seeds 1 - 3. Frames wait while the room-wide search's pose is
  // confirmed by the next frame, which the compass now follows through the
  // loop's turns. Measured: 70 of the junction method's 90 frames tracked
  // before, 87 after (the rest wait where few of the corners chosen are
  // found: the tops of the door, the window and the boards image at the
  // mirror's limb, where the junction tracker finds few of them); the
  // vertex method 90 before and after.
  for (const auto& [method, min_tracked] :
       {std::pair{TrackingMethod::kJunction, 86}, std::pair{TrackingMethod::kVertex, 89}}) {
    int tracked = 0;
    for (uint64_t seed : {uint64_t{1}, uint64_t{2}, uint64_t{3}}) {
      const test::RenderedCase r = OnMap(2.0, seed);
      LocalizerOptions o;
      o.method = method;
      Localizer loc(r.c.calib, r.c.map, r.table, o);
      loc.ResetUnknown();
      const std::vector<PoseRow> rows = test::ProcessFrames(&loc, r, r.c.fps);
      const AccuracySummary a = Score(rows);
      INFO(TrackingMethodName(method) << ", map seed " << seed << ": " << FormatAccuracy(a, "cm"));
      // The map's error moves every pose by up to 2.5 cm here (map seed 3:
      // 2.3 cm on every frame); the junction method's first pose on map
      // seed 1, on the search's landmarks, 2.9 cm where the next are 0.5 -
      // 0.9 cm off: within the covariance reported, as every pose.
      CHECK(a.max <= 3.0);
      CHECK(test::InsideThreeSigma(rows, Office().truth) == 1.0);
      tracked += a.tracked;
    }
    INFO(TrackingMethodName(method) << ": " << tracked << " of " << 3 * kFrames << " frames tracked");
    CHECK(tracked >= min_tracked);
  }
}

TEST_CASE("office, a map measured to 2 cm that says so: the first frame keeps its bearings under the error it shows",
          "[other_rooms]") {
  // The start given, junction method, map seed 1. The first frame's
  // residuals show a survey error wider than the 2 cm stated, and the
  // frame is tracked again under it. The wider tolerance can let in a
  // wrong edge that pulls the pose (the loop rendered through H.264 with
  // another map: a neighbouring edge 4 degrees from its corner's
  // prediction, 10 bearings fitted where the first solution fitted 14,
  // the pose 4.7 cm off). Measured before a retrack had to fit as many
  // bearings: 2.70 cm off on frame 0 where the next frames are 0.4 - 0.9
  // (off by the 5x-median rule); after: 0.83 cm.
  const test::RenderedCase& office = Office();
  const test::RenderedCase r = OnMap(2.0, 1);
  LocalizerOptions o;
  o.method = TrackingMethod::kJunction;
  const std::vector<PoseRow> rows = test::Localize(r, o, office.c.poses.front());
  const AccuracySummary a = Score(rows);
  REQUIRE(rows.front().status == PoseStatus::kOk);
  const double first =
      std::hypot(rows.front().pose.x - office.truth.front().pose.x, rows.front().pose.y - office.truth.front().pose.y);
  INFO("frame 0 " << first << " cm off; " << FormatAccuracy(a, "cm"));
  CHECK(first <= 1.2);
  CHECK(a.outliers == 0);
  CHECK(a.tracked == kFrames);
}

// The first kFrames of a loop through the room of `map_file` (`pose_at(i)`:
// frame i's pose) under real conditions: a shutter open for
// `exposure` of the frame interval, an exposure that drifts, textured
// walls, two people walking (panosim's real-conditions factors, without
// covered or dropped frames), with noise `noise_sigma`; each frame
// compressed as a JPEG of `jpeg_quality` (0: not).
test::RenderedCase RenderUnderRealConditions(const std::string& map_file, Pose2 (*pose_at)(int), double noise_sigma,
                                             int jpeg_quality, double exposure) {
  test::RenderedCase c;
  c.c.name = "custom";
  c.c.calib = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  c.c.map = ReadMap(test::SourcePath(map_file));
  c.c.fps = 10.0;
  c.c.options.noise_sigma = noise_sigma;
  c.c.options.blur = true;
  c.c.options.exposure = exposure;
  c.c.options.auto_exposure = 0.2;
  c.c.options.texture = 0.1;
  c.c.options.people = 2;
  for (int i = 0; i < kFrames; ++i) c.c.poses.push_back(pose_at(i));
  const SequenceRenderer renderer(c.c);
  for (int i = 0; i < kFrames; ++i) {
    cv::Mat frame = renderer.RenderFrame(i);
    if (jpeg_quality > 0) {
      std::vector<uchar> jpeg;
      cv::imencode(".jpg", frame, jpeg, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
      frame = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
    }
    c.frames.push_back(frame);
    PoseRow row;
    row.frame = i;
    row.pose = c.c.poses[static_cast<size_t>(i)];
    c.truth.push_back(row);
  }
  c.table = test::TableForMapOnce(c.c.calib, c.c.map);
  return c;
}

// The office's loop under those conditions.
test::RenderedCase RenderOfficeUnderRealConditions(double noise_sigma, int jpeg_quality, double exposure = 0.5) {
  return RenderUnderRealConditions("docs/examples/office-map.yaml", OfficeLoopPose, noise_sigma, jpeg_quality, exposure);
}

// With the noise of the loop above (no video codec smooths it).
const test::RenderedCase& OfficeRealConditions() {
  static const test::RenderedCase r = RenderOfficeUnderRealConditions(3.0, 0);
  return r;
}

// As a video shows them: noise 4, each frame compressed (JPEG quality 40:
// blocks and ringing at the edges).
const test::RenderedCase& OfficeCompressed() {
  static const test::RenderedCase r = RenderOfficeUnderRealConditions(4.0, 40);
  return r;
}

// The same with the shutter open the whole frame interval (twice the blur).
const test::RenderedCase& OfficeCompressedShutterOpen() {
  static const test::RenderedCase r = RenderOfficeUnderRealConditions(4.0, 40, 1.0);
  return r;
}

// `r` tracked with options `o` (their method), from its first true pose
// (`start`) or without a start.
std::vector<PoseRow> Track(const test::RenderedCase& r, const LocalizerOptions& o, bool start,
                           std::vector<char>* held = nullptr) {
  Localizer loc(r.c.calib, r.c.map, r.table, o);
  if (start)
    loc.Reset(r.truth.front().pose);
  else
    loc.ResetUnknown();
  return test::ProcessFrames(&loc, r, r.c.fps, held);
}

// `method` on `r` (from its first true pose, or without a start), with the
// options `on` (by default the defaults) and `off` (a behaviour turned
// off), each scored; per frame whether it was held for a later frame to
// confirm.
struct AgainstOff {
  std::vector<PoseRow> rows, off_rows;
  AccuracySummary a, off;
  std::vector<char> held, off_held;
};
AgainstOff Against(const test::RenderedCase& r, LocalizerOptions off, bool start, TrackingMethod method,
                   LocalizerOptions on = {}) {
  on.method = off.method = method;
  AgainstOff out;
  out.rows = Track(r, on, start, &out.held);
  out.off_rows = Track(r, off, start, &out.off_held);
  out.a = CompareToGroundTruth(out.rows, r.truth, TypicalRange(r.c.map, r.truth));
  out.off = CompareToGroundTruth(out.off_rows, r.truth, TypicalRange(r.c.map, r.truth));
  return out;
}
AgainstOff JunctionAgainst(const test::RenderedCase& r, const LocalizerOptions& off, bool start) {
  return Against(r, off, start, TrackingMethod::kJunction);
}

// `method` on `r` from its first true pose with `options` and the solution
// separation check on (LocalizerOptions::separation_without_velocity): the
// rows and their score.
std::pair<std::vector<PoseRow>, AccuracySummary> WithSeparationCheck(const test::RenderedCase& r,
                                                                     LocalizerOptions options,
                                                                     TrackingMethod method) {
  options.method = method;
  options.separation_without_velocity = true;
  std::vector<PoseRow> rows = Track(r, options, true);
  const AccuracySummary score = CompareToGroundTruth(rows, r.truth, TypicalRange(r.c.map, r.truth));
  return {std::move(rows), score};
}

TEST_CASE("office under real conditions, no start: a sparse image's lead is taken after frames that follow it",
          "[other_rooms]") {
  // The map states no survey error (its prior applies, and with it the
  // share of the 32 landmarks chosen that a searched pose must fit). The
  // blurred, dim frames show the true pose 7 - 14 corners and every other
  // place tracked fewer than half as many: the search holds it as a sparse
  // lead, and reports it once the frames after it have tracked from it
  // with as strong a fit and along the motion they show; the frames held
  // on the lead are reported then too. Measured: 30 of 30 frames tracked,
  // max 0.90 cm; without sparse leads 4 (none while the searches backed
  // off after three failures).
  const test::RenderedCase& r = OfficeRealConditions();
  LocalizerOptions never;
  never.relocalize_sparse_frames = 0;
  const auto [rows, never_rows, a, without, held, never_held] = JunctionAgainst(r, never, false);
  INFO("sparse leads taken: " << FormatAccuracy(a, "cm") << "; never: " << FormatAccuracy(without, "cm"));
  int held_reported = 0;
  for (size_t i = 0; i < rows.size(); ++i) held_reported += held[i] && rows[i].status == PoseStatus::kOk;
  CHECK(held_reported >= 2);
  CHECK(a.tracked >= 29);
  CHECK(without.tracked <= 5);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 1.0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
}

TEST_CASE("office under real conditions, no start: panoloc writes a sparse lead's frames as the localiser reports them",
          "[other_rooms]") {
  // The first frames of the case above as image files through panoloc: a
  // lead held over frames in a row is written once confirmed, every row in
  // order, as the localiser's rows (the frames as lossless images).
  const test::RenderedCase& r = OfficeRealConditions();
  constexpr int kFrames = 6;
  const std::string dir = test::ScratchDir("sparse_lead_rows");
  std::filesystem::create_directories(dir + "/frames");
  for (int i = 0; i < kFrames; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/frame_%04d.png", i);
    REQUIRE(cv::imwrite(dir + "/frames" + name, r.frames[static_cast<size_t>(i)]));
  }
  WriteCalibration(dir + "/calib.yaml", r.c.calib);
  WriteMap(dir + "/map.yaml", r.c.map);
  test::RenderedCase first = r;
  first.frames.resize(kFrames);
  Localizer loc(ReadCalibration(dir + "/calib.yaml"), ReadMap(dir + "/map.yaml"), r.table, LocalizerOptions());
  loc.ResetUnknown();
  std::vector<char> held;
  const std::vector<PoseRow> expected = test::ProcessFrames(&loc, first, r.c.fps, &held);
  REQUIRE(std::count(held.begin(), held.end(), 1) >= 2);
  PanolocOptions o;
  o.inputs = {dir + "/frames"};
  o.output = dir + "/est.csv";
  o.calib_path = dir + "/calib.yaml";
  o.map_path = dir + "/map.yaml";
  o.fps = r.c.fps;
  o.quiet = true;
  const std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 1);
  INFO(s[0].error);
  const std::vector<PoseRow> rows = ReadPoseCsv(o.output);
  REQUIRE(rows.size() == expected.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    INFO("frame " << i << (held[i] ? ", held" : ""));
    CHECK(rows[i].frame == static_cast<int>(i));
    REQUIRE(rows[i].status == expected[i].status);
    if (rows[i].status != PoseStatus::kOk) continue;
    CHECK(rows[i].pose.x == Approx(expected[i].pose.x).margin(1e-3));
    CHECK(rows[i].pose.y == Approx(expected[i].pose.y).margin(1e-3));
  }
  CHECK(std::count_if(rows.begin(), rows.end(), [](const PoseRow& row) { return row.status == PoseStatus::kOk; }) >= 4);
}

TEST_CASE("office under real conditions, compressed, no start: the map's statement outlives the blurred first frames",
          "[other_rooms]") {
  // The exact map says so. The first frames, blurred in the loop's fastest
  // turn, agree only under a survey error of centimetres (the search's
  // probe); kept, that error let two later frames be reported 6.5 cm off
  // and every pose with a 3 cm deviation. Two later frames in a row agree
  // under the statement as well, so the estimate starts again from it.
  // Measured: 29 of 30 tracked, the held first frame 2.8 cm off within
  // its 2.8 cm deviation (its confirming frame did not agree under the
  // statement), then 1.92 cm at most, 0.85 cm from frame 5 on; without the
  // check 30, frames 16 and 18 6.5 and 6.6 cm off.
  const test::RenderedCase& r = OfficeCompressed();
  Map stated_exact = r.c.map;
  stated_exact.survey_sigma = 0.0;
  const auto run = [&](bool recheck) {
    LocalizerOptions o;
    o.method = TrackingMethod::kVertex;
    o.survey.recheck_statement = recheck;
    // The control reports each frame's own pose: fused with the motion's
    // prediction, frames 16 and 18 are 3.5 cm off.
    o.report_fused_with_motion = recheck;
    Localizer loc(r.c.calib, stated_exact, r.table, o);
    loc.ResetUnknown();
    return test::ProcessFrames(&loc, r, r.c.fps);
  };
  const auto largest_error = [&](const std::vector<PoseRow>& rows, int first) {
    double largest = 0.0;
    for (const PoseRow& row : rows) {
      const Pose2& truth = r.truth[static_cast<size_t>(row.frame)].pose;
      if (row.status == PoseStatus::kOk && row.frame >= first)
        largest = std::max(largest, std::hypot(row.pose.x - truth.x, row.pose.y - truth.y));
    }
    return largest;
  };
  const std::vector<PoseRow> rows = run(true);
  const std::vector<PoseRow> kept = run(false);
  const AccuracySummary a = CompareToGroundTruth(rows, r.truth, TypicalRange(r.c.map, r.truth));
  const AccuracySummary never = CompareToGroundTruth(kept, r.truth, TypicalRange(r.c.map, r.truth));
  INFO("statement checked: " << FormatAccuracy(a, "cm") << "; never: " << FormatAccuracy(never, "cm"));
  CHECK(a.tracked >= 28);
  CHECK(largest_error(rows, 1) <= 2.2);
  CHECK(largest_error(rows, 5) <= 1.0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
  CHECK(largest_error(kept, 5) >= 5.0);
}

TEST_CASE("office, shutter open the whole frame, compressed, no start: a held pose is confirmed only within reach",
          "[other_rooms]") {
  // The shutter open the whole frame interval blurs the loop's turns. The
  // search holds a sparse lead two metres off on frame 2; frame 3 fitted
  // a pose 37 cm from it under the survey probe's wider error (the robot
  // covers 10 cm a frame at most) and was reported 208 cm off. Measured:
  // frame 3 not confirmed (27 cm beyond reach, 4.4 combined deviations);
  // the searches, started again by the lead, find the true pose on frame 4:
  // 23 frames tracked, at most 1.86 cm off (frame 7, in a fast turn).
  const test::RenderedCase& r = OfficeCompressedShutterOpen();
  LocalizerOptions o;
  o.method = TrackingMethod::kVertex;
  Localizer loc(r.c.calib, r.c.map, r.table, o);
  loc.ResetUnknown();
  const std::vector<PoseRow> rows = test::ProcessFrames(&loc, r, r.c.fps);
  const AccuracySummary a = CompareToGroundTruth(rows, r.truth, TypicalRange(r.c.map, r.truth));
  INFO(FormatAccuracy(a, "cm"));
  CHECK(a.tracked >= 22);
  CHECK(a.max <= 2.0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
}

TEST_CASE("office, shutter open the whole frame, compressed, no start, 3 m/s: a held pose is confirmed only under its error",
          "[other_rooms]") {
  // A robot allowed 3 m/s: the sparse lead held two metres off on frame 2
  // lies within reach of the pose frame 3 fits 37 cm from it. That fit
  // needed the survey probe's widest error, three times the error the lead
  // was found under and beyond what a room-wide search verifies a pose
  // under: not a confirmation. Measured: 23 frames tracked, at most 1.86 cm
  // off; without the bound 9, frame 3 reported 208 cm off, until the pose
  // solver's geometry test became unit-free: the frames that led there are
  // now solved otherwise, and the run without the bound is the same.
  const test::RenderedCase& r = OfficeCompressedShutterOpen();
  LocalizerOptions fast;
  fast.motion.max_speed = 3.0;
  LocalizerOptions unbounded = fast;
  unbounded.held_survey_bounded = false;
  const auto [rows, unbounded_rows, a, without, held, unbounded_held] =
      Against(r, unbounded, false, TrackingMethod::kVertex, fast);
  INFO("bounded: " << FormatAccuracy(a, "cm") << "; not: " << FormatAccuracy(without, "cm"));
  CHECK(a.tracked >= 22);
  CHECK(a.max <= 2.0);
  CHECK(a.outliers == 0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
  CHECK(without.max <= 2.0);  // measured 1.86 cm (208 before the geometry test was unit-free)
}

TEST_CASE("office, shutter open the whole frame, compressed, start known: the first pose lies within its error of the start",
          "[other_rooms]") {
  // The start given as the robot's pose (not a guess). On the blurred
  // first frame 8 of the 10 corners found agree, under the survey probe's
  // 4 cm, on a pose 23 cm from the start (4.3 of its standard deviations):
  // frames taken where the start was given do not leave it by more than
  // their own error and the motion since allow, and the probe's levels
  // agree only where they do not. Measured: 26 of 30 frames tracked, at
  // most 4.2 cm off, every one inside its 3-sigma ellipse; without the
  // bound (and without the solution separation check, which withholds that
  // frame too: 23 frames tracked, at most 7.98 cm off, all inside) frame 0
  // is reported 23.1 cm off.
  const test::RenderedCase& r = OfficeCompressedShutterOpen();
  LocalizerOptions unbounded;
  unbounded.known_start_bounds_first_pose = false;
  unbounded.separation_without_velocity = false;
  const auto [rows, unbounded_rows, a, without, held, unbounded_held] =
      Against(r, unbounded, true, TrackingMethod::kVertex);
  const auto [separated_rows, separated] = WithSeparationCheck(r, unbounded, TrackingMethod::kVertex);
  INFO("bounded: " << FormatAccuracy(a, "cm") << "; not: " << FormatAccuracy(without, "cm")
                   << "; not, with the separation check: " << FormatAccuracy(separated, "cm"));
  CHECK(a.tracked >= 25);
  CHECK(a.max <= 5.0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
  CHECK(rows.front().status != PoseStatus::kOk);
  CHECK(without.max >= 20.0);
  CHECK(test::InsideThreeSigma(unbounded_rows, r.truth) < 1.0);
  CHECK(separated_rows.front().status != PoseStatus::kOk);
  CHECK(separated.tracked == 23);
  CHECK(separated.max <= 8.5);
  CHECK(test::InsideThreeSigma(separated_rows, r.truth) == 1.0);
}

TEST_CASE("office, compressed, 0.5 cm maps stating it, junction, start known: the extras found carry the pose",
          "[other_rooms]") {
  // At quality 40 the junctions of most of the 12 landmarks chosen (the
  // nearest, spread in azimuth) are not found at the true pose, and the
  // extras tracked in their place fit it: counted against the pose as if
  // they were missed chosen ones, every frame was refused. Measured (map
  // seeds 1 - 3): 29 - 30 of 30 frames tracked, at most 1.97 cm off (0.97
  // before the pose solver's geometry test was unit-free), every one
  // inside its 3-sigma ellipse; before: 24, 12 and 0 (54 in all since the
  // searches after a refused start run on every frame).
  int tracked_before = 0;
  for (uint64_t seed : {uint64_t{1}, uint64_t{2}, uint64_t{3}}) {
    const test::RenderedCase r = OnMap(OfficeCompressed(), 0.5, seed);
    LocalizerOptions every_extra;
    every_extra.extras_on_tracked_pose_count_for_it = false;
    const auto [rows, every_rows, a, before, held, every_held] = JunctionAgainst(r, every_extra, true);
    INFO("map seed " << seed << ": " << FormatAccuracy(a, "cm") << "; every extra: " << FormatAccuracy(before, "cm"));
    CHECK(a.tracked >= 28);
    CHECK(a.max <= 2.2);
    CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
    tracked_before += before.tracked;
  }
  CHECK(tracked_before <= 56);
}

TEST_CASE("office, shutter open the whole frame, compressed, no start: search hypotheses tracked again from what they found",
          "[other_rooms]") {
  // The search's grid puts its best hypotheses up to a grid step (10 cm)
  // from the true pose, where the junction tracker's windows find a few of
  // the blurred corners: too few to verify. The pose those few fit is
  // nearer, and tracked again from there finds enough. Measured: 26 of
  // 30 frames tracked, every one inside its 3-sigma ellipse, at most 3.54
  // cm off (one frame beyond five times the median: 1.98 cm before the
  // pose solver's geometry test was unit-free); without: 6 of 30. The
  // searches back off after three failures here, as they did: searching
  // on every frame until the first pose finds a lead on frame 3, in the
  // loop's fastest turn, whose third frame is then lost, and 10 frames
  // are tracked with or without the passes (the shutter-open runs of
  // tools/bench_rooms.sh gain 725 frames from it: BENCHMARKS.md).
  const test::RenderedCase& r = OfficeCompressedShutterOpen();
  LocalizerOptions backing_off;
  backing_off.relocalize_eager_searches = 0;
  LocalizerOptions never = backing_off;
  never.relocalize_retrack_passes = 0;
  const auto [rows, never_rows, a, without, held, never_held] =
      Against(r, never, false, TrackingMethod::kJunction, backing_off);
  INFO("tracked again: " << FormatAccuracy(a, "cm") << "; not: " << FormatAccuracy(without, "cm"));
  CHECK(a.tracked >= 25);
  CHECK(without.tracked <= 7);
  CHECK(a.outliers <= 1);
  CHECK(a.max <= 4.0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
}

TEST_CASE("office, shutter open the whole frame, compressed, a 0.5 cm map stating it: poses fused with the motion's prediction",
          "[other_rooms]") {
  // Vertex method, from the first true pose. The blurred frames hold few
  // bearings, and a wrong corner among them pulls a frame's own pose by
  // centimetres within its wide covariance; the motion the frames before
  // it showed carries most of the weight of the pose reported. The same
  // frames are tracked either way. Measured: 19 of 30 tracked both ways;
  // RMS 0.548 cm, at most 1.04 cm off, against 0.590 and 1.30 cm for the
  // frames' own poses.
  const test::RenderedCase r = OnMap(OfficeCompressedShutterOpen(), 0.5, 1);
  LocalizerOptions own;
  own.report_fused_with_motion = false;
  const AgainstOff x = Against(r, own, true, TrackingMethod::kVertex);
  INFO("fused: " << FormatAccuracy(x.a, "cm") << "; own: " << FormatAccuracy(x.off, "cm"));
  CHECK(x.a.tracked == x.off.tracked);
  for (size_t i = 0; i < x.rows.size(); ++i) CHECK(x.rows[i].status == x.off_rows[i].status);
  CHECK(x.a.rms <= 0.6);
  CHECK(x.a.max <= 1.15);
  CHECK(x.off.max >= 1.2);
  CHECK(x.a.rms < x.off.rms);
  CHECK(test::InsideThreeSigma(x.rows, r.truth) == 1.0);
}

TEST_CASE("office, shutter open the whole frame, compressed, a 0.5 cm map stating it: the statement outvotes a wide error's pose",
          "[other_rooms]") {
  // Vertex method, from the first true pose. The blurred first frames
  // agree only under a survey error of centimetres, and under that
  // tolerance a wrong edge pulls a later frame's pose off the consensus.
  // Tracked again under the statement, clearly more bearings agree on a
  // pose apart from it: the frame takes that pose and forgets what its
  // residuals taught the estimate. Measured: 19 of 30 frames tracked both
  // ways; at most 1.30 cm off and none beyond 2 cm, against 6.21 cm and six
  // frames beyond 2 cm with the wide error's poses kept.
  const test::RenderedCase r = OnMap(OfficeCompressedShutterOpen(), 0.5, 1);
  LocalizerOptions kept;
  kept.survey.statement_outvotes = false;
  const auto [rows, kept_rows, a, without, held, kept_held] = Against(r, kept, true, TrackingMethod::kVertex);
  INFO("outvoted: " << FormatAccuracy(a, "cm") << "; kept: " << FormatAccuracy(without, "cm"));
  auto beyond = [&](const std::vector<PoseRow>& reported, double limit) {
    int n = 0;
    for (size_t i = 0; i < reported.size(); ++i)
      n += reported[i].status == PoseStatus::kOk &&
           std::hypot(reported[i].pose.x - r.truth[i].pose.x, reported[i].pose.y - r.truth[i].pose.y) > limit;
    return n;
  };
  CHECK(a.tracked >= 18);
  CHECK(a.max <= 1.6);
  CHECK(beyond(rows, 2.0) == 0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
  CHECK(without.max >= 5.0);
  CHECK(beyond(kept_rows, 2.0) >= 4);
}

TEST_CASE("office under real conditions, a 0.5 cm map stating it, start known: the survey probe tries narrower errors from the consensus",
          "[other_rooms]") {
  // Junction method. Frame 1 fails from its prediction under the
  // statement. Tried from the prediction alone, the survey probe's ladder
  // agrees only under 4.2 and 6.2 cm: 9 bearings on a pose 23.2 cm off,
  // which was reported outside its 3-sigma ellipse (the statement's
  // recheck finds 10 on the true pose, not clearly more). From that
  // consensus, 10 agree under 1.0 cm on the true pose. Measured: 30 of 30
  // frames tracked both ways; at most 1.16 cm off, every frame inside its
  // ellipse, against 23.15 cm (with the solution separation check off: it
  // withholds that frame too, 29 tracked, at most 0.83 cm off).
  const test::RenderedCase r = OnMap(OfficeRealConditions(), 0.5, 1);
  LocalizerOptions from_prediction;
  from_prediction.survey.probe_from_consensus = false;
  from_prediction.separation_without_velocity = false;
  const auto [rows, prediction_rows, a, without, held, prediction_held] =
      Against(r, from_prediction, true, TrackingMethod::kJunction);
  const auto [separated_rows, separated] = WithSeparationCheck(r, from_prediction, TrackingMethod::kJunction);
  INFO("from the consensus: " << FormatAccuracy(a, "cm") << "; from the prediction: " << FormatAccuracy(without, "cm")
                              << "; inside 3 sigma " << test::InsideThreeSigma(rows, r.truth) << " and "
                              << test::InsideThreeSigma(prediction_rows, r.truth)
                              << "; from the prediction, with the separation check: "
                              << FormatAccuracy(separated, "cm"));
  CHECK(a.tracked == kFrames);
  CHECK(a.max <= 1.5);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
  CHECK(without.max >= 20.0);
  CHECK(separated.tracked == kFrames - 1);
  CHECK(separated.max <= 1.0);
}

// The office's frames with those at `covered` dark over the whole mirror
// (a hand over the lens).
test::RenderedCase WithFramesCovered(const test::RenderedCase& r, const std::vector<int>& covered) {
  test::RenderedCase out = r;
  for (int k : covered) {
    cv::Mat& frame = out.frames[static_cast<size_t>(k)];
    frame = frame.clone();
    cv::circle(frame, cv::Point(frame.cols / 2, frame.rows / 2), frame.rows / 2, cv::Scalar(10), cv::FILLED);
  }
  return out;
}

// The junction method from the start on the office under real conditions
// with the frames `covered`, with the options `on` and `off`.
AgainstOff CoveredAgainst(const std::vector<int>& covered, const LocalizerOptions& off, const LocalizerOptions& on = {}) {
  return Against(WithFramesCovered(OfficeRealConditions(), covered), off, true, TrackingMethod::kJunction, on);
}

TEST_CASE("office, real conditions, frames covered: the search's pose after one continues the track",
          "[other_rooms]") {
  // The loop's heading wiggles up to 9 degrees a frame; over a covered
  // frame the motion model's heading is degrees off and the junction
  // tracker's windows miss the frame after it. The room-wide search finds
  // the pose there on half of its landmarks, too few to report before the
  // next frame confirms it, but where the model predicted it. Measured (a
  // start given, frames 6, 12, 21 and 24 covered): every frame after a
  // cover tracked, 26 of 30 in all, at most 0.90 cm off; without, 16 of 30
  // (the held pose's motion not kept either: that alone tracks them too),
  // two of the four frames after a cover lost (all four before the pose
  // solver's geometry test was unit-free, three before the searches after
  // an unconfirmed pose ran on every frame).
  const std::vector<int> covered{6, 12, 21, 24};
  LocalizerOptions without_resuming;
  without_resuming.resume_after_lost_frame = false;
  without_resuming.hold_keeps_motion = false;
  const auto [rows, without_rows, a, without, held, without_held] = CoveredAgainst(covered, without_resuming);
  INFO("resumed: " << FormatAccuracy(a, "cm") << "; not: " << FormatAccuracy(without, "cm"));
  int lost_without = 0;
  for (int k : covered) {
    INFO("frame " << k + 1);
    CHECK(rows[static_cast<size_t>(k + 1)].status == PoseStatus::kOk);
    lost_without += without_rows[static_cast<size_t>(k + 1)].status == PoseStatus::kLost;
  }
  CHECK(lost_without >= 2);
  CHECK(a.tracked >= 25);
  CHECK(without.tracked <= 17);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 1.0);
  CHECK(test::InsideThreeSigma(rows, OfficeRealConditions().truth) == 1.0);
}

TEST_CASE("office, real conditions, frames covered: the compass turns the frame after one from the last tracked",
          "[other_rooms]") {
  // The loop's heading wiggles up to 9 degrees a frame; over a covered
  // frame the motion model's heading is degrees off. The compass's turn
  // measured from the covered frame's image finds nothing (or a wrong
  // turn, added to the model's guess), from the frame before it the turn
  // over both intervals. Without the search's help (it finds these poses
  // too): measured, a start given, frames 3, 11, 15 and 21 covered, every
  // frame after a cover tracked, 26 of 30 in all, at most 0.90 cm off;
  // from the covered frames' images 21 of 30 (18, frame 12 among those
  // lost, before the pose solver's geometry test was unit-free).
  const std::vector<int> covered{3, 11, 15, 21};
  LocalizerOptions from_tracked;
  from_tracked.resume_after_lost_frame = false;
  from_tracked.hold_keeps_motion = false;
  LocalizerOptions from_covered = from_tracked;
  from_covered.compass_from_measured = false;
  const auto [rows, covered_rows, a, b, held, covered_held] = CoveredAgainst(covered, from_covered, from_tracked);
  INFO("from the last tracked frame: " << FormatAccuracy(a, "cm") << "; from the covered: " << FormatAccuracy(b, "cm"));
  for (int k : covered) CHECK(rows[static_cast<size_t>(k + 1)].status == PoseStatus::kOk);
  CHECK(a.tracked >= 25);
  CHECK(b.tracked <= 22);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 1.0);
  CHECK(test::InsideThreeSigma(rows, OfficeRealConditions().truth) == 1.0);
}

TEST_CASE("office, real conditions, frames covered in a row: a held search pose keeps the motion before them",
          "[other_rooms]") {
  // Three frames covered in a row: the search's pose a frame after them
  // fits too few of its landmarks to report at once and is held for the
  // next frame to confirm. It lies where the motion before the covers
  // predicted it; tracked from it at a standstill (any speed and turn) the
  // next frame misses the turn's edges and the search starts over. Measured
  // (a start given, frames 8 - 10 covered): 26 of 30 tracked, frames 12 and
  // 13 held and confirmed, at most 0.90 cm off; without keeping the motion
  // 18 of 30 (frames 11 - 19 lost) until the pose solver's geometry test
  // became unit-free: since, the frames after the covers are tracked
  // either way on this render (26 of 30 without).
  LocalizerOptions standstill;
  standstill.hold_keeps_motion = false;
  const auto [rows, standstill_rows, a, without, held, standstill_held] = CoveredAgainst({8, 9, 10}, standstill);
  INFO("kept: " << FormatAccuracy(a, "cm") << "; standstill: " << FormatAccuracy(without, "cm"));
  for (size_t i = 12; i < rows.size(); ++i) {
    INFO("frame " << i);
    CHECK(rows[i].status == PoseStatus::kOk);
  }
  CHECK(held[12]);
  CHECK(a.tracked >= 26);
  CHECK(without.tracked >= 26);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 1.0);
  CHECK(test::InsideThreeSigma(rows, OfficeRealConditions().truth) == 1.0);
}

TEST_CASE("office, compressed, a map measured to 2 cm, no start: a tracked pose the search refutes gives way",
          "[other_rooms]") {
  // Frame 16 turns faster than the one before; the vertex tracker's
  // windows take the wrong corners on some of the landmarks and the pose
  // they fit, 8 cm off, passes every test. The room-wide search that
  // checks a frame tracked on few of its chosen landmarks finds the pose
  // beside it on 15 landmarks (the tracked one on 10) with half its
  // residual, 3.7 deviations from it: that pose is taken, and the track
  // goes on from it. Measured: 29 of 30 frames tracked, at most 2.35 cm
  // off; without the refutation frame 16 is reported 7.99 cm off.
  const test::RenderedCase r = OnMap(OfficeCompressed(), 2.0, 2);
  LocalizerOptions kept;
  kept.relocalize_refutes = false;
  // The control reports each frame's own pose: fused with the motion's
  // prediction, frame 16's is 4.75 cm off.
  kept.report_fused_with_motion = false;
  const auto [rows, kept_rows, a, without, held, kept_held] = Against(r, kept, false, TrackingMethod::kVertex);
  INFO("refuted: " << FormatAccuracy(a, "cm") << "; kept: " << FormatAccuracy(without, "cm"));
  CHECK(a.tracked >= 28);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 2.6);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
  CHECK(without.max >= 7.0);
}

// The office's frames with those at `dropped` left out, the timestamps
// still a frame interval apart (as a camera losing frames at a constant
// frame rate records them).
test::RenderedCase WithFramesDropped(const test::RenderedCase& r, const std::vector<int>& dropped) {
  test::RenderedCase out = r;
  out.frames.clear();
  out.truth.clear();
  for (int i = 0; i < static_cast<int>(r.frames.size()); ++i) {
    if (std::find(dropped.begin(), dropped.end(), i) != dropped.end()) continue;
    out.frames.push_back(r.frames[static_cast<size_t>(i)]);
    PoseRow row = r.truth[static_cast<size_t>(i)];
    row.frame = static_cast<int>(out.truth.size());
    out.truth.push_back(row);
  }
  return out;
}

TEST_CASE("office, real conditions, frames dropped at a constant rate: the frames after them are tracked",
          "[other_rooms]") {
  // The loop's heading wiggles up to 9 degrees a frame, the people and the
  // blur leave few landmarks found; after a dropped frame the pose lies two
  // intervals along the motion while the timestamps say one. Measured (a
  // start given): 26 of 26 tracked, every frame after a drop tracked from
  // the motion, at most 0.90 cm off; without the dropped-frame hypothesis
  // the motion gate refused the frame after the third drop: the room-wide
  // search found it, held until later frames confirmed it.
  const std::vector<int> after_drops{5, 10, 15, 20};
  const test::RenderedCase r = WithFramesDropped(OfficeRealConditions(), {5, 11, 17, 23});
  LocalizerOptions without_drops;
  without_drops.dropped_frames = false;
  const auto [rows, without_rows, a, without, held, without_held] = JunctionAgainst(r, without_drops, true);
  INFO("dropped frames considered: " << FormatAccuracy(a, "cm") << "; not: " << FormatAccuracy(without, "cm"));
  for (int k : after_drops) {
    INFO("frame " << k);
    CHECK(rows[static_cast<size_t>(k)].status == PoseStatus::kOk);
    CHECK_FALSE(held[static_cast<size_t>(k)]);
  }
  CHECK(without_held[15]);
  CHECK(a.tracked >= 25);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 1.0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
}

// The studio's loop (tools/bench_rooms.sh): a wavy ellipse that passes
// 20 cm south of a low sofa, 300 frames for a turn, the heading along the
// path plus 40 degrees of wiggle (sin(0.07 frame)).
Pose2 StudioLoopPose(int i) {
  const auto at = [](double k) {
    const double t = 2.0 * M_PI * k / 300.0;
    return Eigen::Vector2d(360.0 + 180.0 * std::cos(t) + 30.0 * std::sin(3.0 * t), 200.0 + 110.0 * std::sin(t));
  };
  const Eigen::Vector2d along = at(i + 0.5) - at(i - 0.5);
  return Pose2{at(i).x(), at(i).y(), std::atan2(along.y(), along.x()) + 40.0 * M_PI / 180.0 * std::sin(0.07 * i)};
}

TEST_CASE("studio, exact map: frames whose landmarks stand metres away are not taken for a degenerate geometry",
          "[other_rooms]") {
  // Passing the sofa, the junction method found 11 - 21 corners all round
  // and the pose solver called their geometry degenerate: its eigenvalue
  // test compared the position's rows (one over a landmark's distance, in
  // map units) with the heading's. Measured before the rows were
  // normalised: the start frame and frame 15 lost, frame 1 1.6 cm off
  // (the 300-frame loop through H.264: 2 - 6 frames lost with the junction
  // method, exact to 2 cm maps); after: 21 of 21, at most 0.23 cm off,
  // every frame inside its 3-sigma ellipse.
  // docs/examples/studio-map.yaml: 7.5 x 5 m, most landmarks metres away.
  test::RenderedCase r = RenderLoop("docs/examples/studio-map.yaml", StudioLoopPose, 55, 75);
  r.c.map.survey_sigma = 0.0;  // stated exact
  LocalizerOptions o;
  o.method = TrackingMethod::kJunction;
  const std::vector<PoseRow> rows = test::Localize(r, o, r.c.poses.front());
  const AccuracySummary a = CompareToGroundTruth(rows, r.truth, TypicalRange(r.c.map, r.truth));
  INFO(FormatAccuracy(a, "cm"));
  CHECK(a.tracked == static_cast<int>(r.frames.size()));
  CHECK(a.outliers == 0);
  CHECK(a.max <= 0.5);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
}

TEST_CASE("office under real conditions, 0.5 cm maps stating it, no start: the search runs on every frame until the first pose",
          "[other_rooms]") {
  // Map seeds 2 and 3, junction method. The searches on the first frames
  // verify nothing, and after three failures they waited 2, 4, 8 frames
  // in turn: the first poses came on frames 25 and 24, though a search on
  // frames 13 and 6 finds them. Before the first pose there is nothing
  // else to report: the search runs on every frame (for 50 failed
  // searches). Measured: 17 and 24 of 30 frames tracked, at most 0.85 cm
  // off, every one inside its 3-sigma ellipse; backing off after three
  // failures: 10 and 6 of 30 (5 and 6 verifying 20 hypotheses a search).
  LocalizerOptions backs_off;
  backs_off.relocalize_eager_searches = 0;
  int tracked = 0, tracked_backing_off = 0;
  for (uint64_t seed : {uint64_t{2}, uint64_t{3}}) {
    const test::RenderedCase r = OnMap(OfficeRealConditions(), 0.5, seed);
    const auto [rows, off_rows, a, off, held, off_held] = JunctionAgainst(r, backs_off, false);
    INFO("seed " << seed << ": " << FormatAccuracy(a, "cm") << "; backing off after three failures: " << FormatAccuracy(off, "cm"));
    CHECK(a.tracked >= off.tracked + 5);
    CHECK(a.outliers == 0);
    CHECK(a.max <= 1.0);
    CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
    tracked += a.tracked;
    tracked_backing_off += off.tracked;
  }
  CHECK(tracked >= 40);
  CHECK(tracked_backing_off <= 17);
}

// The lab's first kFrames under the real conditions above (noise 3, not
// compressed).
const test::RenderedCase& LabRealConditions() {
  static const test::RenderedCase r =
      RenderUnderRealConditions("docs/examples/lab-map.yaml", LabLoopPose, 3.0, 0, 0.5);
  return r;
}

TEST_CASE("lab under real conditions, exact map, no start: a held pose found with either polarity is verified so again",
          "[other_rooms]") {
  // Vertex method. People stand about the robot's first position: on frame
  // 0 the map's polarities track 14 of the 32 corners chosen at the true
  // pose, too few for a searched pose, and with either polarity 17, which
  // the search holds. Frame 1 confirms it; the held frame is then tracked
  // again to be reported, and with the map's polarities alone it fell
  // short of the support it was found with and was lost. Verified again
  // with either polarity, as found: measured 30 of 30 frames tracked, frame
  // 0 0.69 cm off; with the map's alone 29 (frame 0 lost).
  const test::RenderedCase& r = LabRealConditions();
  LocalizerOptions map_polarities;
  map_polarities.held_polarity_as_found = false;
  const auto [rows, off_rows, a, off, held, off_held] = Against(r, map_polarities, false, TrackingMethod::kVertex);
  INFO("as found: " << FormatAccuracy(a, "cm") << "; with the map's polarities: " << FormatAccuracy(off, "cm"));
  CHECK(rows.front().status == PoseStatus::kOk);
  CHECK(off_rows.front().status == PoseStatus::kLost);
  CHECK(held.front());
  CHECK(a.tracked == 30);
  CHECK(off.tracked == 29);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 1.0);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
}

TEST_CASE("office under real conditions, a 0.5 cm map stating it, no start: the search verifies more hypotheses before the first pose",
          "[other_rooms]") {
  // Map seed 1, vertex method. A person hides part of the first frames'
  // view, which lowers the true place's rank among the room-wide search's
  // hypotheses (in the office's video of tools/bench_rooms.sh it ranked
  // 21st - 30th on frames 0 and 1). Before the first pose the search
  // verifies 30, not the 20 it verifies while tracking. Measured: frame 0
  // found (held, and tracked from; its row withheld by the solution
  // separation check, as the first pose has no velocity), 29 of 30 frames
  // tracked, at most 0.90 cm off; with 20: 28 (frames 0 and 1 lost).
  const test::RenderedCase r = OnMap(OfficeRealConditions(), 0.5, 1);
  LocalizerOptions twenty;
  twenty.relocalize_untracked_hypotheses = twenty.relocalize.hypotheses;
  const auto [rows, off_rows, a, off, held, off_held] = Against(r, twenty, false, TrackingMethod::kVertex);
  INFO("30 hypotheses: " << FormatAccuracy(a, "cm") << "; 20: " << FormatAccuracy(off, "cm"));
  CHECK(held.front());
  CHECK(rows.front().status == PoseStatus::kLost);
  CHECK(rows[1].status == PoseStatus::kOk);
  CHECK(off_rows[1].status != PoseStatus::kOk);
  CHECK(a.tracked == 29);
  CHECK(off.tracked <= 28);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 1.3);
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
}

TEST_CASE("office, compressed, a 1 cm map stating it, vertex, start known: a pose without a velocity that one bearing could have pulled is not reported",
          "[other_rooms]") {
  // Map seed 1. The first frames have no velocity to check their poses
  // against, and rest on few bearings of a JPEG-blurred image: frame 1
  // was reported 2.24 cm off, more than 1 % of the landmarks' distance and
  // 5 times the median error. Its protection level plus the largest shift
  // of its position when one distinct bearing is left out is beyond the
  // alert limit the map's stated 1 cm gives: the row is lost, the track
  // goes on from the pose, and every other row is as before. Measured: 29
  // of 30 frames tracked, at most 1.08 cm off, no outlier; without the
  // check 30, at most 2.24 cm, one outlier.
  const test::RenderedCase r = OnMap(OfficeCompressed(), 1.0, 1);
  LocalizerOptions unchecked;
  unchecked.separation_without_velocity = false;
  const auto [rows, unchecked_rows, a, without, held, unchecked_held] =
      Against(r, unchecked, true, TrackingMethod::kVertex);
  INFO("checked: " << FormatAccuracy(a, "cm") << "; not: " << FormatAccuracy(without, "cm"));
  CHECK(a.tracked == kFrames - 1);
  CHECK(a.outliers == 0);
  CHECK(a.max <= 1.2);
  CHECK(without.tracked == kFrames);
  CHECK(without.outliers == 1);
  CHECK(without.max >= 2.0);
  REQUIRE(rows.size() == unchecked_rows.size());
  int withheld = 0;
  size_t withheld_frame = rows.size();
  for (size_t i = 0; i < rows.size(); ++i) {
    if (rows[i].status != unchecked_rows[i].status) {
      ++withheld;
      withheld_frame = i;
      CHECK(rows[i].status == PoseStatus::kLost);
      continue;
    }
    INFO("frame " << i);
    CHECK(rows[i].pose.x == unchecked_rows[i].pose.x);
    CHECK(rows[i].pose.y == unchecked_rows[i].pose.y);
    CHECK(rows[i].pose.theta == unchecked_rows[i].pose.theta);
  }
  CHECK(withheld == 1);
  CHECK(withheld_frame == 1);  // the first frame after the start
  CHECK(test::InsideThreeSigma(rows, r.truth) == 1.0);
}
}  // namespace
}  // namespace pano

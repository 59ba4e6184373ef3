// End to end: rendered sequences of the paper's experiments through the
// localiser, with the error bounds of the issue (paper: 0.4 units std on the
// synthetic sequence, 3.7 cm on the real one; the team's aim 0.1 and 1 cm).
#include <catch2/catch.hpp>

#include <filesystem>

#include "panotrack/render/writers.h"
#include "test_paths.h"
#include "track_fixture.h"

namespace pano {
namespace {

TEST_CASE("paper-synthetic, 20 frames: std and max well below the paper's 0.4 units, none lost", "[end_to_end]") {
  const test::RenderedCase r = test::RenderPreset("paper-synthetic", 20);
  const std::vector<PoseRow> rows = test::Localize(r, LocalizerOptions(), r.c.poses.front());
  const AccuracySummary a = CompareToGroundTruth(rows, r.truth);
  INFO(FormatAccuracy(a, "units"));
  CHECK(a.tracked == 20);
  CHECK(a.std <= 0.025);  // measured 0.0078; the paper's line-junction figure is 0.4
  CHECK(a.max <= 0.05);   // measured 0.0165
  CHECK(a.outliers == 0);
  CHECK(a.heading_max_deg < 0.025);  // measured 0.0076 deg
  WARN("paper-synthetic 20 frames: " << FormatAccuracy(a, "units"));
}

TEST_CASE("paper-real, 20 frames with noise and blur: std and max far below the paper's 3.7 cm", "[end_to_end]") {
  const test::RenderedCase r = test::RenderPreset("paper-real", 20);
  const std::vector<PoseRow> rows = test::Localize(r, LocalizerOptions(), r.c.poses.front());
  const AccuracySummary a = CompareToGroundTruth(rows, r.truth);
  INFO(FormatAccuracy(a, "cm"));
  CHECK(a.tracked == 20);
  CHECK(a.std <= 0.03);  // measured 0.0097 cm
  CHECK(a.max <= 0.06);  // measured 0.018 cm; the paper reports 3.7 cm
  WARN("paper-real 20 frames: " << FormatAccuracy(a, "cm"));
}

TEST_CASE("panoloc's video path: H.264 video in, pose CSV out, accuracy against gt.csv", "[video]") {
  const std::string dir = test::ScratchDir("track_video");
  SequenceCase c = MakePreset("paper-synthetic");
  c.poses.resize(12);
  SequenceWriteOptions w;
  w.overwrite = true;
  WriteSequence(c, dir + "/seq", w);
  PanolocOptions o;
  o.inputs = {dir + "/seq/video.mp4"};
  o.output = dir + "/est.csv";
  o.calib_path = dir + "/seq/calib.yaml";
  o.map_path = dir + "/seq/map.yaml";
  o.gt = dir + "/seq/gt.csv";
  o.plot = dir + "/plot.png";
  o.quiet = true;  // the initial pose comes from case.yaml beside the video
  const std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 1);
  INFO(s[0].error);
  REQUIRE(s[0].ok);
  CHECK(s[0].frames == 12);
  CHECK(s[0].n_ok == 12);
  REQUIRE(s[0].has_accuracy);
  CHECK(s[0].accuracy.std <= 0.02);  // measured 0.0068 with libx264
  const std::vector<PoseRow> rows = ReadPoseCsv(o.output);
  CHECK(rows.size() == 12);
  CHECK(rows[5].extra.size() == 4);  // std_x, std_y, std_theta, quality
  CHECK(std::filesystem::exists(o.plot));
}

// Tracks the rendered frames from the first true pose with `opt`, and counts
// the frames whose FrameResult has `flag` set.
AccuracySummary TrackCounting(const test::RenderedCase& r, const LocalizerOptions& opt, bool FrameResult::*flag,
                              int* n_flagged) {
  Localizer loc(r.c.calib, r.c.map, r.table, opt);
  loc.Reset(r.c.poses.front());
  std::vector<PoseRow> rows;
  *n_flagged = 0;
  for (size_t i = 0; i < r.frames.size(); ++i) {
    const FrameResult fr = loc.Process(r.frames[i], static_cast<int>(i), i / r.c.fps);
    *n_flagged += fr.*flag;
    rows.push_back(fr.row);
  }
  return CompareToGroundTruth(rows, r.truth);
}

TEST_CASE("long-run's fast turns: the compass's heading goes first where the model's would miss, as accurate",
          "[compass_first]") {
  // Turns of up to 10 degrees per frame that change from frame to frame:
  // the constant-velocity model's heading misses the search windows on many
  // frames, the compass's rarely.
  const test::RenderedCase r = test::RenderPreset("long-run", 80);
  LocalizerOptions never_opt;
  never_opt.compass_first_turn = M_PI;
  int n_first = 0, n_never = 0;
  const AccuracySummary a = TrackCounting(r, LocalizerOptions(), &FrameResult::compass_first, &n_first);
  const AccuracySummary never = TrackCounting(r, never_opt, &FrameResult::compass_first, &n_never);
  INFO(FormatAccuracy(a, "units") << "; model first always: " << FormatAccuracy(never, "units"));
  CHECK(n_never == 0);
  // Measured 19; the switch compares float headings, so a compiler's
  // rounding may move a frame or two across it.
  CHECK(n_first >= 16);
  CHECK(n_first <= 22);
  CHECK(a.tracked == 80);
  CHECK(never.tracked == 80);
  CHECK(a.outliers == never.outliers);
  CHECK(a.rms <= 0.0109);  // measured 0.01068 units; model first: 0.01043
  CHECK(a.max <= 0.061);   // measured 0.0589 (both)
  // Measured 1.023 (the compass's frames measured with the blur of the
  // turn it measured; 1.017 with the model's).
  CHECK(a.rms <= 1.03 * never.rms);
  WARN("long-run 80 frames, compass first on " << n_first << ": " << FormatAccuracy(a, "units")
                                               << "; model first: " << FormatAccuracy(never, "units"));
}

TEST_CASE("long-run's fast turns: azimuths first where most frames need a second pass, as accurate",
          "[coarse_to_fine]") {
  // The motion model's prediction misses by more than a pixel on most of
  // these frames: the azimuth-only first pass and one full pass around its
  // pose replace a full pass and a refinement.
  const test::RenderedCase r = test::RenderPreset("long-run", 80);
  LocalizerOptions never_opt;
  never_opt.coarse_to_fine_rate = 2.0;
  int n_coarse = 0, n_never = 0;
  const AccuracySummary a = TrackCounting(r, LocalizerOptions(), &FrameResult::coarse_to_fine, &n_coarse);
  const AccuracySummary never = TrackCounting(r, never_opt, &FrameResult::coarse_to_fine, &n_never);
  INFO(FormatAccuracy(a, "units") << "; full passes only: " << FormatAccuracy(never, "units"));
  CHECK(n_never == 0);
  // Measured 48 (it starts once ten frames or so have needed a second pass).
  CHECK(n_coarse >= 44);
  CHECK(n_coarse <= 52);
  CHECK(a.tracked == 80);
  CHECK(never.tracked == 80);
  CHECK(a.outliers == never.outliers);
  CHECK(a.rms <= 0.0109);  // measured 0.01053 units; full passes only: 0.01031
  CHECK(a.max <= 0.061);   // measured 0.0589 (both)
  CHECK(a.rms <= 1.03 * never.rms);
  WARN("long-run 80 frames, coarse to fine on " << n_coarse << ": " << FormatAccuracy(a, "units")
                                                 << "; full passes only: " << FormatAccuracy(never, "units"));
  // The first pass on 8 landmarks (the default) centres the second as well
  // as one on all 12 (0: max_landmarks).
  LocalizerOptions all_opt;
  all_opt.coarse_landmarks = 0;
  int n_all = 0;
  const AccuracySummary all = TrackCounting(r, all_opt, &FrameResult::coarse_to_fine, &n_all);
  INFO("first pass on all: " << FormatAccuracy(all, "units"));
  CHECK(all.tracked == 80);
  CHECK(std::abs(n_all - n_coarse) <= 2);  // measured 48 both
  CHECK(a.rms <= 1.01 * all.rms);           // measured 0.01053 against 0.01057
  LocalizerOptions bad;
  bad.coarse_landmarks = 2;
  CHECK_THROWS_WITH(bad.Check(), Catch::Contains("coarse_landmarks"));
  LocalizerOptions negative_pairs;
  negative_pairs.noise_pairs = -1;
  CHECK_THROWS_WITH(negative_pairs.Check(), Catch::Contains("noise_pairs"));
}

}  // namespace
}  // namespace pano

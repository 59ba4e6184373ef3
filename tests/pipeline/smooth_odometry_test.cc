// panoloc's --smooth (a second pose CSV from the fixed-lag smoother) and
// --odometry (wheel odometry as the prediction's input), on the small
// rendered case.
#include <catch2/catch.hpp>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "panotrack/core/error.h"
#include "panotrack/io/odometry.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/pipeline/panoloc.h"
#include "pipeline_fixture.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::Scratch;
using test::FilesIn;

namespace fs = std::filesystem;

PanolocOptions OneInput(const std::string& input, const std::string& output) {
  PanolocOptions o = test::OneInput(input, output);
  o.gt = test::GetSmallCase().gt;
  return o;
}

std::vector<std::string> Panoloc(const std::string& args) {
  std::vector<std::string> argv = {test::Program("panoloc")};
  for (const std::string& w : test::Words(args + " " + test::GetSmallCase().Args())) argv.push_back(w);
  return argv;
}

// An odometry log of the ground truth's first `n` poses in a unit 100 times
// the map's, in a frame turned by 0.7 rad and shifted: only the increments
// matter, which are the same in any frame.
std::string WriteOdometryFromTruth(const std::string& path, int n) {
  const std::vector<PoseRow> gt = ReadPoseCsv(test::GetSmallCase().gt);
  const double a = 0.7, c = std::cos(a), s = std::sin(a);
  std::ofstream f(path);
  f << kOdometryCsvHeader << "\n";
  for (int k = 0; k < n && k < static_cast<int>(gt.size()); ++k) {
    const Pose2& p = gt[k].pose;
    char line[160];
    std::snprintf(line, sizeof line, "%.6f,%.8f,%.8f,%.8f\n", gt[k].time_s, 3.0 + (c * p.x - s * p.y) / 100,
                  -2.0 + (s * p.x + c * p.y) / 100, p.theta + a);
    f << line;
  }
  return path;
}

TEST_CASE("--smooth: a second CSV of every frame, in order, at least as close to the truth", "[smooth]") {
  const std::string dir = Scratch("pipeline_smooth");
  PanolocOptions o = OneInput(test::GetSmallCase().video, dir + "/est.csv");
  o.smooth = true;
  o.smooth_lag = 4;  // shorter than the sequence: rows are held back, then flushed at the end
  const std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 1);
  INFO(s[0].error);
  REQUIRE(s[0].ok);
  CHECK(s[0].smoothed_output == dir + "/est.smoothed.csv");
  CHECK(FilesIn(dir) == std::vector<std::string>{"est.csv", "est.smoothed.csv"});
  const std::vector<PoseRow> filtered = ReadPoseCsv(dir + "/est.csv");
  const std::vector<PoseRow> smoothed = ReadPoseCsv(dir + "/est.smoothed.csv");
  REQUIRE(smoothed.size() == filtered.size());
  test::RequireConsecutive(smoothed);
  int moved = 0;
  for (size_t k = 0; k < filtered.size(); ++k) {
    CHECK(smoothed[k].status == filtered[k].status);
    CHECK(smoothed[k].time_s == filtered[k].time_s);
    CHECK(smoothed[k].n_landmarks == filtered[k].n_landmarks);
    REQUIRE(smoothed[k].extra.size() == 4);
    CHECK(smoothed[k].extra[3] == filtered[k].extra[3]);  // quality
    moved += std::hypot(smoothed[k].pose.x - filtered[k].pose.x, smoothed[k].pose.y - filtered[k].pose.y) > 1e-3;
  }
  CHECK(moved > 0);
  // The standard deviations are the motion model's (with the floors the
  // localiser gives each measurement): widest at the ends of the sequence,
  // where no frame before or after constrains the pose.
  REQUIRE(smoothed.size() == 12);
  CHECK(smoothed[5].extra[0] == Approx(0.1241).epsilon(0.02));
  CHECK(smoothed[5].extra[2] == Approx(0.00173).epsilon(0.02));
  CHECK(smoothed[0].extra[0] > 1.1 * smoothed[5].extra[0]);
  CHECK(smoothed[11].extra[0] > 1.1 * smoothed[5].extra[0]);
  REQUIRE(s[0].has_accuracy);
  REQUIRE(s[0].has_smoothed_accuracy);
  CHECK(s[0].smoothed_accuracy.compared == s[0].accuracy.compared);
  // Measured: 0.00777 filtered, 0.00670 smoothed.
  CHECK(s[0].accuracy.rms == Approx(0.00777).margin(0.0004));
  CHECK(s[0].smoothed_accuracy.rms == Approx(0.00670).margin(0.0004));
  CHECK(s[0].smoothed_accuracy.rms < s[0].accuracy.rms);
}

TEST_CASE("--smooth needs a file output; --odometry one input", "[smooth]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_smooth_stdout");
  const test::RunResult r = test::Run(Panoloc(c.video + " --smooth -o -"), dir);
  CHECK(r.code == 1);
  CHECK(r.out.empty());
  CHECK(r.err ==
        "panoloc: --smooth (smooth): needs a file output (-o FILE.csv or --out-dir DIR) beside which to "
        "write the smoothed CSV\n");
  // --smooth-lag alone turns smoothing on.
  const test::RunResult lag = test::Run(Panoloc(c.video + " --smooth-lag 3 -o -"), dir);
  CHECK(lag.code == 1);
  CHECK(lag.err.find("--smooth (smooth)") != std::string::npos);
  PanolocOptions two = OneInput(c.video, "");
  two.inputs.push_back(c.frames);
  two.out_dir = dir + "/out";
  two.gt = "";
  two.odometry = dir + "/odo.csv";
  CHECK_THROWS_WITH(two.Check(), "--odometry (odometry): takes one input");
}

TEST_CASE("--smooth under --out-dir: <name>.smoothed.csv per input", "[smooth]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_smooth_dir");
  const test::RunResult r = test::Run(Panoloc(c.video + " --smooth --gt auto --out-dir " + dir + "/out"), dir);
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK(FilesIn(dir + "/out") == std::vector<std::string>{"seq_video.csv", "seq_video.smoothed.csv"});
  CHECK(r.out.find("\n  smoothed: ") != std::string::npos);
  CHECK(ReadPoseCsv(dir + "/out/seq_video.smoothed.csv").size() == static_cast<size_t>(c.n_frames));
}

TEST_CASE("--odometry from the ground truth, in another frame and unit: tracks as well", "[odometry]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_odometry");
  const std::vector<VideoSummary> plain = RunPanoloc(OneInput(c.video, dir + "/plain.csv"));
  PanolocOptions o = OneInput(c.video, dir + "/odo.csv");
  o.odometry = WriteOdometryFromTruth(dir + "/odometry.csv", c.n_frames);
  o.odometry_scale = 100;  // the log's unit in map units
  const std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 1);
  REQUIRE(plain.size() == 1);
  INFO(s[0].error);
  REQUIRE(s[0].ok);
  CHECK(s[0].frames_without_odometry == 0);
  CHECK(s[0].n_ok == plain[0].n_ok);
  // Measured: 0.00802 with, 0.00777 without. The odometry shapes the
  // prediction and the search; the pose is the images' own.
  CHECK(s[0].accuracy.rms == Approx(0.00802).margin(0.0004));
  CHECK(s[0].accuracy.rms <= 1.1 * plain[0].accuracy.rms);

  // A log of the first 6 frames: the later ones are predicted without it.
  PanolocOptions part = OneInput(c.video, dir + "/part.csv");
  part.odometry = WriteOdometryFromTruth(dir + "/first6.csv", 6);
  part.odometry_scale = 100;
  const std::vector<VideoSummary> p = RunPanoloc(part);
  REQUIRE(p.size() == 1);
  CHECK(p[0].ok);
  CHECK(p[0].frames_without_odometry == c.n_frames - 6);
}

TEST_CASE("--odometry keeps tracking where every 8th frame alone is too far apart", "[odometry]") {
  const std::string dir = Scratch("pipeline_odometry_sparse");
  SequenceCase sc = MakePreset("paper-synthetic");
  SequenceWriteOptions w;
  w.frames = true;
  w.video = false;
  WriteSequence(sc, dir + "/seq", w);
  // Frames 0, 8, 16, ... as an input at 10/8 frames/s: their times are those
  // of the whole sequence, which the odometry log covers.
  const int step = 8;
  fs::create_directories(dir + "/sparse");
  std::ofstream gt(dir + "/sparse_gt.csv");
  gt << kPoseCsvHeader << "\n";
  std::ofstream odo(dir + "/odometry.csv");
  odo << kOdometryCsvHeader << "\n";
  for (int k = 0; k < static_cast<int>(sc.poses.size()); ++k) {
    const Pose2& p = sc.poses[k];
    char line[160];
    std::snprintf(line, sizeof line, "%.6f,%.8f,%.8f,%.8f\n", k / sc.fps, p.x, p.y, p.theta);
    odo << line;
    if (k % step) continue;
    char name[64];
    std::snprintf(name, sizeof name, "/frame_%04d.png", k);
    fs::create_symlink(dir + "/seq/frames" + name, dir + "/sparse" + name);
    PoseRow row;
    row.frame = k / step;
    row.time_s = k / sc.fps;
    row.pose = p;
    gt << FormatPoseRow(row) << "\n";
  }
  gt.close();
  odo.close();
  PanolocOptions o = OneInput(dir + "/sparse", dir + "/plain.csv");
  o.init = sc.poses.front();
  o.map_path = dir + "/seq/map.yaml";
  o.calib_path = dir + "/seq/calib.yaml";
  o.gt = dir + "/sparse_gt.csv";
  o.fps = sc.fps / step;
  const std::vector<VideoSummary> plain = RunPanoloc(o);
  o.output = dir + "/odo.csv";
  o.odometry = dir + "/odometry.csv";
  const std::vector<VideoSummary> with = RunPanoloc(o);
  REQUIRE(plain.size() == 1);
  REQUIRE(with.size() == 1);
  // Measured: all 9 frames tracked without odometry too (the frame a
  // prediction without it loses is found again by the room-wide search, RMS
  // 0.0313), 9 with it (RMS 0.0102).
  INFO(with[0].error);
  REQUIRE(with[0].frames == 9);
  CHECK(with[0].frames_without_odometry == 0);
  CHECK(with[0].n_ok == 9);
  CHECK(plain[0].n_ok <= with[0].n_ok);
  CHECK(with[0].accuracy.rms == Approx(0.0102).margin(0.001));
  CHECK(with[0].accuracy.rms < plain[0].accuracy.rms);
}

TEST_CASE("a bad odometry file: one line naming it, nothing written", "[odometry]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_odometry_bad");
  fs::create_directories(dir + "/out");
  std::ofstream(dir + "/odo.csv") << "time,x,y\n0,0,0\n";
  const test::RunResult r =
      test::Run(Panoloc(c.video + " --smooth --odometry " + dir + "/odo.csv -o " + dir + "/out/est.csv"), dir);
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.err) == 1);
  CHECK(r.err.rfind("panoloc: ", 0) == 0);
  CHECK(r.err.find(dir + "/odo.csv") != std::string::npos);
  CHECK(FilesIn(dir + "/out").empty());
}

}  // namespace
}  // namespace pano

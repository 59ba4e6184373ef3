// panoloc's run summary as JSON (--summary-json), and the rule that no
// existing output file is replaced without `overwrite` (--force), checked for
// every planned output before any work.
#include <catch2/catch.hpp>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "expect_error.h"
#include "panotrack/config.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/pipeline/summary_json.h"
#include "pipeline_fixture.h"
#include "test_paths.h"

namespace pano {
namespace {

using nlohmann::json;
using test::ErrorOf;
using test::Scratch;

namespace fs = std::filesystem;

// Every field of the accuracy object equals the summary's (doubles are
// written with all their digits, so they read back exactly).
void CheckAccuracy(const json& j, const AccuracySummary& a) {
  CHECK(j.at("frames") == a.frames);
  CHECK(j.at("tracked") == a.tracked);
  CHECK(j.at("compared") == a.compared);
  CHECK(j.at("rms").get<double>() == a.rms);
  CHECK(j.at("std").get<double>() == a.std);
  CHECK(j.at("mean").get<double>() == a.mean);
  CHECK(j.at("max").get<double>() == a.max);
  CHECK(j.at("heading_rms_deg").get<double>() == a.heading_rms_deg);
  CHECK(j.at("heading_max_deg").get<double>() == a.heading_max_deg);
  CHECK(j.at("outliers") == a.outliers);
  CHECK(j.at("std_inliers").get<double>() == a.std_inliers);
  CHECK(j.at("outlier_percent").get<double>() == (a.compared ? 100.0 * a.outliers / a.compared : 0.0));
}

TEST_CASE("--summary-json: the printed figures per input, accuracy, version and command line",
          "[summary_json]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_summary_json");
  PanolocOptions o = test::OneInput(c.video, dir + "/est.csv");
  o.gt = c.gt;
  o.smooth = true;
  o.tum = dir + "/est.tum";
  o.plot = dir + "/plot.png";
  o.summary_json = dir + "/summary.json";
  const std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 1);
  INFO(s[0].error);
  REQUIRE(s[0].ok);
  REQUIRE(s[0].has_accuracy);
  REQUIRE(s[0].has_smoothed_accuracy);
  CHECK_FALSE(fs::exists(o.summary_json));  // written by the caller, after the run
  const std::vector<std::string> argv = {"panoloc", c.video, "-o", dir + "/est.csv", "--summary-json", "x y.json"};
  WritePanolocSummaryJson(o, s, argv);
  const json j = json::parse(test::ReadText(o.summary_json));
  CHECK(j.at("tool") == "panoloc");
  CHECK(j.at("version") == PANO_VERSION);
  CHECK(j.at("command_line").get<std::vector<std::string>>() == argv);
  REQUIRE(j.at("inputs").size() == 1);
  const json& in = j.at("inputs")[0];
  CHECK(in.at("input") == c.video);
  CHECK(in.at("end") == "done");
  CHECK(in.at("done") == true);
  CHECK(in.at("error").is_null());
  CHECK(in.at("frames") == 12);
  CHECK(in.at("ok") == s[0].n_ok);
  CHECK(in.at("lost") == s[0].n_lost);
  CHECK(in.at("seconds").get<double>() == s[0].seconds);
  CHECK(in.at("frames_per_s").get<double>() == s[0].frames / s[0].seconds);
  const json& out = in.at("outputs");
  CHECK(out.at("poses") == dir + "/est.csv");
  CHECK(out.at("smoothed") == dir + "/est.smoothed.csv");
  CHECK(out.at("tum") == dir + "/est.tum");
  CHECK(out.at("plot") == dir + "/plot.png");
  CHECK_FALSE(out.contains("debug_video"));
  for (const auto& [name, path] : out.items()) CHECK(fs::exists(path.get<std::string>()));
  CheckAccuracy(in.at("accuracy"), s[0].accuracy);
  CheckAccuracy(in.at("smoothed_accuracy"), s[0].smoothed_accuracy);
  // The file is replaced only as a whole: no temporary file is left beside it.
  CHECK(test::FilesIn(dir) == std::vector<std::string>{"est.csv", "est.smoothed.csv", "est.tum", "plot.png",
                                                      "plot_error.png", "summary.json"});

  // An input that failed: its error, no outputs, no accuracy.
  VideoSummary failed;
  failed.input = dir + "/none.mp4";
  failed.output = dir + "/none.csv";
  failed.end = VideoEnd::kFailed;
  failed.error = dir + "/none.mp4: no such file";
  PanolocOptions two = o;
  two.plot.clear();
  const json f = json::parse(PanolocSummaryJson(two, {s[0], failed}, {"panoloc"}));
  REQUIRE(f.at("inputs").size() == 2);
  const json& bad = f.at("inputs")[1];
  CHECK(bad.at("end") == "failed");
  CHECK(bad.at("done") == false);
  CHECK(bad.at("error") == failed.error);
  CHECK(bad.at("frames") == 0);
  CHECK(bad.at("frames_per_s") == 0.0);
  CHECK(bad.at("outputs").empty());
  CHECK_FALSE(bad.contains("accuracy"));
  CHECK(f.at("inputs")[0].at("outputs").size() == 3);  // poses, smoothed, TUM

  // Standard output cannot carry both the CSV and the JSON.
  PanolocOptions both = test::OneInput(c.video, "-");
  both.summary_json = "-";
  CHECK(ErrorOf([&] { RunPanoloc(both); }).find("--summary-json") != std::string::npos);
}

TEST_CASE("existing outputs are refused before any work unless overwrite; - and devices never exist",
          "[overwrite]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_overwrite");
  CHECK_FALSE(WouldReplaceFile("-"));
  CHECK_FALSE(WouldReplaceFile("/dev/null"));
  CHECK_FALSE(WouldReplaceFile(dir));
  CHECK_FALSE(WouldReplaceFile(dir + "/missing.csv"));
  std::ofstream(dir + "/old.csv") << "keep\n";
  CHECK(WouldReplaceFile(dir + "/old.csv"));
  fs::create_symlink(dir + "/old.csv", dir + "/link.csv");
  CHECK(WouldReplaceFile(dir + "/link.csv"));

  // Each kind of output, existing alone: refused, naming it; nothing written.
  const std::vector<std::pair<std::string, std::string>> kinds = {
      {"output", "/est.csv"}, {"smooth", "/est.smoothed.csv"}, {"tum", "/est.tum"},
      {"plot", "/plot.png"},  {"debug", "/dbg.mp4"},          {"summary", "/summary.json"}};
  for (const auto& [kind, existing] : kinds) {
    const std::string sub = dir + "/" + kind;
    fs::create_directories(sub);
    PanolocOptions o = test::OneInput(c.video, sub + "/est.csv");
    o.smooth = true;
    o.tum = sub + "/est.tum";
    o.plot = sub + "/plot.png";
    o.debug_video = sub + "/dbg.mp4";
    o.summary_json = sub + "/summary.json";
    std::ofstream(sub + existing) << "keep\n";
    INFO(kind);
    CHECK(ErrorOf([&] { RunPanoloc(o); }) == sub + existing + " exists (use --force to replace it)");
    CHECK(test::FilesIn(sub) == std::vector<std::string>{existing.substr(1)});
    CHECK(test::ReadText(sub + existing) == "keep\n");
  }
  // Under --out-dir: the planned name is checked; the folder is not created for nothing.
  fs::create_directories(dir + "/out");
  std::ofstream(dir + "/out/seq_video.csv") << "keep\n";
  PanolocOptions many = test::OneInput(c.video, "");
  many.out_dir = dir + "/out";
  CHECK(ErrorOf([&] { RunPanoloc(many); }) == dir + "/out/seq_video.csv exists (use --force to replace it)");
  many.overwrite = true;
  std::vector<VideoSummary> s = RunPanoloc(many);
  REQUIRE(s.size() == 1);
  CHECK(s[0].ok);
  CHECK(ReadPoseCsv(dir + "/out/seq_video.csv").size() == 12);
  // A link to an existing file counts as that file.
  PanolocOptions linked = test::OneInput(c.video, dir + "/link.csv");
  CHECK(ErrorOf([&] { RunPanoloc(linked); }).find("link.csv exists (use --force") != std::string::npos);
  linked.overwrite = true;
  s = RunPanoloc(linked);
  REQUIRE(s.size() == 1);
  CHECK(s[0].ok);
  CHECK(ReadPoseCsv(dir + "/link.csv").size() == 12);
  // A device is written in place, never "existing".
  s = RunPanoloc(test::OneInput(c.video, "/dev/null"));
  REQUIRE(s.size() == 1);
  CHECK(s[0].ok);
}

}  // namespace
}  // namespace pano

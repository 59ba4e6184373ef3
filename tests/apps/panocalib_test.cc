// panocalib calibrate as users run it: its thread count, the libraries' logs
// (quiet unless --verbose), one-line errors, existing outputs kept unless
// --force, and the summary JSON.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "panotrack/io/calibration.h"
#include "run_command.h"
#include "test_paths.h"
#include "test_skip.h"

namespace pano {
namespace {

using Run = test::CommandRun;
Run Exec(const std::string& args) { return test::RunProgram(args); }
int Lines(const std::string& s) { return test::CountLines(s); }

bool Contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST_CASE("panocalib calibrate: -j/--threads, quiet libraries unless --verbose, one-line errors, --summary-json",
          "[panocalib_calibrate]") {
  namespace fs = std::filesystem;
  const std::string dir = test::ScratchDir("panocalib_calibrate");
  Run r = Exec("panosim targets --calib " + test::SourcePath("calib/paper-real.yaml") +
               " --board 9,6,3 --auto 6 --noise 2 --seed 4 -q -o " + dir + "/t");
  INFO(r.out);
  REQUIRE(r.code == 0);
  const std::string targets = dir + "/t/targets.yaml";

  // Quiet: the summary, no step timings. -j is --threads.
  r = Exec("panocalib calibrate " + targets + " -o " + dir + "/two.yaml -j 2 --summary-json " + dir + "/two.json");
  INFO(r.out);
  CHECK(r.code == 0);
  const size_t at = r.out.find("RMS reprojection error ");
  REQUIRE(at != std::string::npos);
  const double printed_rms = std::stod(r.out.substr(at + 23));
  CHECK_FALSE(Contains(r.out, "[raw detection:"));
  // The summary JSON: the printed figures and the calibration file's.
  std::ifstream json_file(dir + "/two.json");
  const nlohmann::json j = nlohmann::json::parse(json_file);
  const Calibration written = ReadCalibration(dir + "/two.yaml");
  CHECK(std::abs(j.at("rms_px").get<double>() - printed_rms) <= 0.00005);
  CHECK(j.at("rms_px").get<double>() == Approx(written.extras.at("rms_px")).epsilon(1e-6));
  CHECK(j.at("boards_used") == 6);
  CHECK(j.at("image_rms_px").size() == 6);
  CHECK(j.at("image_rms_px").contains("cal_000.png"));
  CHECK(j.at("parameters").at("focal_px").at("value").get<double>() ==
        Approx(written.sensor.params.focal_px).epsilon(1e-9));
  CHECK(j.at("parameters").at("focal_px").at("stddev").get<double>() ==
        Approx(written.extras.at("focal_px_std")).epsilon(1e-6));
  CHECK(j.at("images_not_found").empty());
  CHECK(j.at("iterations").get<int>() > 0);
  // The default --model auto: the model chosen by held-out error, and why.
  CHECK(Contains(r.out, "\nchosen: "));
  CHECK(j.at("model_selection").at("chosen").is_string());
  CHECK(j.at("model_selection").at("candidates").size() == 9);
  CHECK(j.at("outputs").at("calibration") == dir + "/two.yaml");
  // Again: the outputs exist, so nothing is done without --force; -q prints nothing else.
  const auto yaml_time = fs::last_write_time(dir + "/two.yaml");
  r = Exec("panocalib calibrate " + targets + " -o " + dir + "/two.yaml -q");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: " + dir + "/two.yaml exists (use --force to replace it)\n");
  CHECK(fs::last_write_time(dir + "/two.yaml") == yaml_time);
  r = Exec("panocalib calibrate " + targets + " -o " + dir + "/other.yaml --summary-json " + dir + "/two.json");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: " + dir + "/two.json exists (use --force to replace it)\n");
  CHECK_FALSE(fs::exists(dir + "/other.yaml"));
  // Verbose: step timings and the solver's progress; the same calibration on one thread.
  r = Exec("panocalib calibrate " + targets + " -o " + dir + "/one.yaml --threads 1 --verbose");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK(Contains(r.out, "[raw detection:"));
  CHECK(Contains(r.out, "iter      cost"));
  const Calibration one = ReadCalibration(dir + "/one.yaml"), two = ReadCalibration(dir + "/two.yaml");
  CHECK(std::abs(one.sensor.params.focal_px / two.sensor.params.focal_px - 1.0) < 1e-9);
  CHECK(std::abs(one.sensor.mirror_distance() / two.sensor.mirror_distance() - 1.0) < 1e-9);

  // A bad thread count: one line, nothing written.
  r = Exec("panocalib calibrate " + targets + " -o " + dir + "/bad.yaml --threads -1");
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK(Lines(r.out) == 1);
  CHECK(Contains(r.out, "panocalib: --threads:"));
  CHECK_FALSE(fs::exists(dir + "/bad.yaml"));

  // A missing image: OpenCV's own warning about it only with --verbose.
  std::ofstream(dir + "/missing.yaml") << "units: cm\nboard:\n  type: chessboard\n  cols: 9\n  rows: 6\n"
                                          "  square: 3.0\nimages:\n  - file: nowhere.png\n"
                                          "  - file: nowhere2.png\n";
  r = Exec("panocalib calibrate " + dir + "/missing.yaml -o " + dir + "/m.yaml");
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK(Lines(r.out) == 1);
  CHECK(Contains(r.out, "nowhere.png: cannot read the image"));
  r = Exec("panocalib calibrate " + dir + "/missing.yaml -o " + dir + "/m.yaml --verbose");
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK(Contains(r.out, "[ WARN"));
  CHECK_FALSE(fs::exists(dir + "/m.yaml"));
}

TEST_CASE("panocalib calibrate and evaluate: a truncated board video fails as panoloc's would, quietly",
          "[board_video_damaged]") {
  namespace fs = std::filesystem;
  if (std::system("ffmpeg -version > /dev/null 2>&1") != 0) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("panocalib_video");
  Run r = Exec("panosim targets --calib " + test::SourcePath("calib/paper-real.yaml") +
               " --board 9,6,3 --auto 12 --seed 4 -q -o " + dir + "/t");
  INFO(r.out);
  REQUIRE(r.code == 0);
  const std::string video = dir + "/boards.mp4";
  REQUIRE(std::system(("ffmpeg -hide_banner -loglevel error -nostdin -y -framerate 5 -i " + dir +
                       "/t/cal_%03d.png -c:v libx264 -pix_fmt yuv420p -movflags +faststart " + video)
                          .c_str()) == 0);
  // Cut in half: the frames before the cut would calibrate, but the video is damaged.
  fs::resize_file(video, fs::file_size(video) / 2);
  const std::string board = " --board 9x6 --square 3 --every 1";
  for (const std::string& run :
       {"panocalib calibrate " + video + board + " -o " + dir + "/c.yaml -q",
        "panocalib evaluate --calib " + test::SourcePath("calib/paper-real.yaml") + " " + video + board + " -q"}) {
    r = Exec(run);
    INFO(run);
    INFO(r.out);
    CHECK(r.code == 1);
    CHECK(Lines(r.out) == 1);  // no FFmpeg lines without --verbose
    CHECK(r.out.rfind("panocalib: " + video + ": decode error at frame ", 0) == 0);
    CHECK(Contains(r.out, "truncated"));
  }
  CHECK_FALSE(fs::exists(dir + "/c.yaml"));
}

}  // namespace
}  // namespace pano

// panocalib calibrate as users run it: its thread count, the libraries' logs
// (quiet unless --verbose), and one-line errors.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "panotrack/io/calibration.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

using Run = test::CommandRun;
Run Exec(const std::string& args) { return test::RunProgram(args); }
int Lines(const std::string& s) { return test::CountLines(s); }

bool Contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST_CASE("panocalib calibrate: --threads, quiet libraries unless --verbose, one-line errors",
          "[panocalib_calibrate]") {
  namespace fs = std::filesystem;
  const std::string dir = test::ScratchDir("panocalib_calibrate");
  Run r = Exec("panosim targets --calib " + test::SourcePath("calib/paper-real.yaml") +
               " --board 9,6,3 --auto 6 --noise 2 --seed 4 -q -o " + dir + "/t");
  INFO(r.out);
  REQUIRE(r.code == 0);
  const std::string targets = dir + "/t/targets.yaml";

  // Quiet: the summary, no step timings.
  r = Exec("panocalib calibrate " + targets + " -o " + dir + "/two.yaml --threads 2");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK(Contains(r.out, "RMS reprojection error"));
  CHECK_FALSE(Contains(r.out, "[raw detection:"));
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

}  // namespace
}  // namespace pano

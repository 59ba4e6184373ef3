// panocalib's checks of a calibration as users run them: project and
// backproject on a file of points (the single-point output line for line,
// one-line errors naming the file and line, nothing written on an error),
// and evaluate on rendered boards (exit 1 when no board is found).
#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::RunProgram;

std::string ReadText(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

void WriteText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST_CASE("panocalib project/backproject --points/--pixels: the single-point lines; errors name file:line",
          "[panocalib_check]") {
  namespace fs = std::filesystem;
  const std::string dir = test::ScratchDir("panocalib_check");
  const std::string calib = test::SourcePath("calib/paper-real.yaml");
  const char* points[] = {"100,0,10", "50,20,-5", "-30,40,0", "0,0,100", "12.5,-80,-20"};
  std::string csv = "x,y,z  # header\n";
  for (const char* p : points) csv += std::string(p) + "\n";
  WriteText(dir + "/points.csv", csv);
  test::CommandRun r = RunProgram("panocalib project --calib " + calib + " --points " + dir + "/points.csv -o " +
                                  dir + "/pixels.txt");
  INFO(r.out);
  REQUIRE(r.code == 0);
  // (0,0,100) looks straight up into the camera: not visible.
  CHECK(r.out == "panocalib: note: 5 points: 1 not visible (nan lines)\n");
  std::istringstream pixels(ReadText(dir + "/pixels.txt"));
  std::string pixel_csv;
  for (const char* p : points) {
    std::string line;
    REQUIRE(std::getline(pixels, line));
    const test::CommandRun single = RunProgram("panocalib project --calib " + calib + " --point " + p);
    CHECK(single.code == 0);
    if (single.out == "not visible\n") {
      CHECK(line == "nan nan");
    } else {
      CHECK(line + "\n" == single.out);
      pixel_csv += line + "\n";
    }
  }
  // Pixels from standard input to standard output.
  WriteText(dir + "/pixels.csv", pixel_csv);
  r = RunProgram("panocalib backproject --calib " + calib + " --pixels - < " + dir + "/pixels.csv");
  CHECK(r.code == 0);
  std::istringstream rays(r.out), px(pixel_csv);
  std::string ray, pixel;
  while (std::getline(px, pixel)) {
    REQUIRE(std::getline(rays, ray));
    const std::string uv = pixel.substr(0, pixel.find(' ')) + "," + pixel.substr(pixel.find(' ') + 1);
    CHECK(ray + "\n" == RunProgram("panocalib backproject --calib " + calib + " --pixel " + uv).out);
  }
  CHECK_FALSE(std::getline(rays, ray));

  // The output exists: refused without --force, replaced with it.
  r = RunProgram("panocalib project --calib " + calib + " --points " + dir + "/points.csv -o " + dir +
                 "/pixels.txt -q");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: " + dir + "/pixels.txt exists (use --force to replace it)\n");
  r = RunProgram("panocalib project --calib " + calib + " --points " + dir + "/points.csv -o " + dir +
                 "/pixels.txt -q --force");
  CHECK(r.code == 0);
  CHECK(r.out.empty());
  // A bad line: one line naming file and line, exit 1, nothing written.
  WriteText(dir + "/bad.csv", "# c\n1,2,3\n4,5\n");
  r = RunProgram("panocalib project --calib " + calib + " --points " + dir + "/bad.csv -o " + dir + "/bad.txt");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: " + dir + "/bad.csv:3: expected 3 finite numbers (x y z), got 2 fields\n");
  CHECK_FALSE(fs::exists(dir + "/bad.txt"));
  r = RunProgram("panocalib backproject --calib " + calib + " --pixels - < " + dir + "/bad.csv");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: <stdin>:2: expected 2 finite numbers (u v), got 3 fields\n");
  // One of the single and the batch form.
  r = RunProgram("panocalib project --calib " + calib);
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: --point or --points: one is required\n");
  r = RunProgram("panocalib project --calib " + calib + " --point 1,2,3 --points " + dir + "/points.csv");
  CHECK(r.code == 1);
}

TEST_CASE("panocalib evaluate: per-image lines, overall RMS, --summary-json; exit 1 without any board",
          "[panocalib_check]") {
  namespace fs = std::filesystem;
  const std::string dir = test::ScratchDir("panocalib_evaluate");
  test::CommandRun r = RunProgram("panosim targets --calib " + test::SourcePath("calib/paper-real.yaml") +
                                  " --board 9,6,3 --auto 8 --noise 2 --seed 7 -q -o " + dir + "/t");
  INFO(r.out);
  REQUIRE(r.code == 0);
  // --no-unwarp: the raw search alone, which misses the board of cal_007.png.
  r = RunProgram("panocalib evaluate --calib " + dir + "/t/truth.yaml " + dir +
                 "/t/targets.yaml -j 2 --no-unwarp --summary-json " + dir + "/ev.json");
  CHECK(r.code == 0);
  CHECK(r.out.find("  cal_000.png: 54 corners, RMS ") == 0);
  CHECK(r.out.find("  cal_007.png: no board\n") != std::string::npos);
  CHECK(r.out.find("held-out RMS reprojection error 0.05") != std::string::npos);
  std::ifstream json_file(dir + "/ev.json");
  const nlohmann::json j = nlohmann::json::parse(json_file);
  CHECK(j.at("tool") == "panocalib evaluate");
  CHECK(j.at("boards_found") == 7);
  CHECK(j.at("corners") == 7 * 54);
  CHECK(j.at("rms_px").get<double>() == Approx(0.0568).margin(0.006));
  CHECK(j.at("per_image").size() == 8);
  CHECK(j.at("per_image")[7].at("found") == false);
  CHECK(j.at("per_image")[7].at("rms_px").is_null());
  // A folder with --board, as for calibrate; the JSON exists: refused.
  r = RunProgram("panocalib evaluate --calib " + dir + "/t/truth.yaml " + dir + "/t --board 9x6 --square 3 -q " +
                 "--summary-json " + dir + "/ev.json");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: " + dir + "/ev.json exists (use --force to replace it)\n");
  r = RunProgram("panocalib evaluate --calib " + dir + "/t/truth.yaml " + dir + "/t --board 9x6 --square 3 --no-refine");
  CHECK(r.code == 0);
  CHECK(r.out.find("held-out RMS reprojection error 0.19") != std::string::npos);
  // By default the image without a board is searched in views unwarped
  // through the calibration, as calibrate does: every board found.
  r = RunProgram("panocalib evaluate --calib " + dir + "/t/truth.yaml " + dir + "/t --board 9x6 --square 3");
  CHECK(r.code == 0);
  CHECK(r.out.find("board found in 8 of 8 images, 8 fitted") != std::string::npos);
  // No board anywhere (a still of the paper's room): exit 1, one line. The
  // board's units must be the calibration's.
  const std::string synthetic = test::SourcePath("calib/paper-synthetic.yaml");
  fs::create_directories(dir + "/none");
  r = RunProgram("panosim still --preset paper-synthetic --supersample 1 -j 2 -q -o " + dir + "/none/a.png");
  REQUIRE(r.code == 0);
  r = RunProgram("panocalib evaluate --calib " + synthetic + " " + dir + "/none --board 9x6 --square 3");
  CHECK(r.code == 1);
  CHECK(r.out.find("panocalib: the calibration's units (units) differ from the targets' (cm)") == 0);
  r = RunProgram("panocalib evaluate --calib " + synthetic + " " + dir + "/none --board 9x6 --square 3 --units units");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: no board found in the image\n");
  // The shared options.
  r = RunProgram("panocalib evaluate --help");
  CHECK(r.code == 0);
  for (const char* option : {"--force", "--summary-json", "-j,--jobs,--threads", "-q,--quiet", "-v,--verbose",
                             "Exit status: 0 success"})
    CHECK(r.out.find(option) != std::string::npos);
}

}  // namespace
}  // namespace pano

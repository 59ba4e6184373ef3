// Bad input (each a clear pano::Error and, through the app, a non-zero exit
// with no calibration written), the output files, and the real miniomni set.
#include <catch2/catch.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/config.h"
#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/targets.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/pipeline/target_input.h"
#include "panotrack/pipeline/panocalib.h"
#include "panotrack/pipeline/calibration_report.h"
#include "synthetic.h"
#include "test_paths.h"
#include "test_rng.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
}

std::string TargetsYaml(const std::vector<std::string>& files, int cols = 7, int rows = 11) {
  std::string s = "units: mm\nboard:\n  type: chessboard\n  cols: " + std::to_string(cols) +
                  "\n  rows: " + std::to_string(rows) + "\n  square: 30.0\nimages:\n";
  for (const std::string& f : files) s += "  - file: " + f + "\n";
  return s;
}

std::string Miniomni() { return test::SourcePath("../shared/data/real/miniomni"); }

// Runs panocalib when it has been built; returns its exit status, or -1.
int RunPanocalib(const std::string& args) {
  const char* bin = std::getenv("PANO_BIN_DIR");
  if (!bin || !fs::exists(std::string(bin) + "/panocalib")) return -1;
  return std::system((std::string(bin) + "/panocalib " + args + " > /dev/null 2>&1").c_str());
}

TEST_CASE("bad input: clear errors, non-zero exit, no calibration written", "[bad_input]") {
  const std::string dir = test::ScratchDir("calib_bad_input");
  const std::string out = dir + "/calib.yaml";
  auto expect_error = [&](const std::string& targets, const std::string& words) {
    INFO(targets << ": expecting an error with '" << words << "'");
    try {
      const TargetSet t = ReadTargets(targets);
      Calibrate(t, LoadTargetImages(t), CalibrateOptions());
      FAIL("no error");
    } catch (const Error& e) {
      INFO("message: " << e.what());
      CHECK(std::string(e.what()).find(words) != std::string::npos);
    }
    const int rc = RunPanocalib("calibrate " + targets + " -o " + out + " --lut " + dir + "/s.lut --report " +
                                dir + "/r.png");
    if (rc != -1) CHECK(rc != 0);
    CHECK_FALSE(fs::exists(out));
    CHECK_FALSE(fs::exists(dir + "/s.lut"));
  };

  SECTION("no board found in any image") {
    cv::Mat blank(240, 320, CV_8U, cv::Scalar(128));
    cv::circle(blank, {160, 120}, 80, cv::Scalar(200), -1);
    for (int i = 0; i < 3; ++i) cv::imwrite(dir + "/blank" + std::to_string(i) + ".png", blank);
    WriteText(dir + "/t.yaml", TargetsYaml({"blank0.png", "blank1.png", "blank2.png"}));
    expect_error(dir + "/t.yaml", "no chessboard found in any of the 3 images");
  }
  SECTION("images of different sizes") {
    cv::imwrite(dir + "/a.png", cv::Mat(240, 320, CV_8U, cv::Scalar(100)));
    cv::imwrite(dir + "/b.png", cv::Mat(200, 320, CV_8U, cv::Scalar(100)));
    WriteText(dir + "/t.yaml", TargetsYaml({"a.png", "b.png"}));
    expect_error(dir + "/t.yaml", "differs from");
  }
  SECTION("a missing image") {
    WriteText(dir + "/t.yaml", TargetsYaml({"nowhere.png"}));
    expect_error(dir + "/t.yaml", "cannot read the image");
  }
  SECTION("a target file that breaks the spec") {
    WriteText(dir + "/t.yaml", "units: mm\nboard:\n  type: chessboard\n  rows: 11\n  square: 30\nimages:\n  - file: a.png\n");
    expect_error(dir + "/t.yaml", "board.cols");
    WriteText(dir + "/t.yaml", "units: mm\nboard:\n  type: circles\n  cols: 7\n  rows: 11\n  square: 30\nimages:\n  - file: a.png\n");
    expect_error(dir + "/t.yaml", "board.type");
    WriteText(dir + "/t.yaml", "units: mm\nboard: {cols: 7, rows: 11, square: 30}\nimages:\n  - file: a.png\n    rvec: [0, 0, 0]\n");
    expect_error(dir + "/t.yaml", "rvec and tvec");
  }
  SECTION("fewer images with a board than the fit needs") {
    if (!fs::exists(Miniomni() + "/MiniOmni1.jpg")) {
      WARN("skipped: " << Miniomni() << " not found");
    } else {
      WriteText(dir + "/t.yaml", TargetsYaml({Miniomni() + "/MiniOmni1.jpg", Miniomni() + "/MiniOmni2.jpg"}));
      expect_error(dir + "/t.yaml", "found in only 2 of 2 images");
    }
    // The same through the library on synthetic corners.
    PANO_SEEDED_RNG(71);
    const Sensor s = ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor;
    TargetBoard b;
    b.cols = 9;
    b.rows = 6;
    b.square = 3.0;
    const auto set = test::MakeSyntheticSet(s, b, 2, 12.0, 30.0, -30.0, 10.0, 0.05, rng);
    CHECK_THROWS_WITH(CalibrateViews(test::WithoutPoses(set.views), b, 640, 480, "cm", CalibrateOptions()),
                      Catch::Contains("needs at least 3"));
  }
  SECTION("a wrong board size: the fit fails loudly instead of writing nonsense") {
    PANO_SEEDED_RNG(72);
    const Sensor s = ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor;
    TargetBoard b;
    b.cols = 9;
    b.rows = 6;
    b.square = 3.0;
    auto set = test::MakeSyntheticSet(s, b, 6, 12.0, 30.0, -30.0, 10.0, 0.05, rng);
    // Scramble the corners: no sensor explains them.
    std::mt19937 shuffle_rng(3);
    for (BoardView& v : set.views) std::shuffle(v.corners.begin(), v.corners.end(), shuffle_rng);
    CHECK_THROWS_AS(CalibrateViews(test::WithoutPoses(set.views), b, 640, 480, "cm", CalibrateOptions()), Error);
  }
  SECTION("bad options") {
    CalibrateOptions o;
    o.distortion_terms = 3;
    CHECK_THROWS_WITH(o.Check(), Catch::Contains("--distortion"));
    CHECK(RunPanocalib("calibrate " + dir + "/t.yaml -o " + out + " --model parabola") != 0);
  }
}

TEST_CASE("outputs: calibration YAML with standard deviations, LUT, report", "[outputs]") {
  PANO_SEEDED_RNG(73);
  const std::string dir = test::ScratchDir("calib_outputs");
  const Sensor s = ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor;
  TargetBoard b;
  b.cols = 9;
  b.rows = 6;
  b.square = 3.0;
  const auto set = test::MakeSyntheticSet(s, b, 8, 12.0, 30.0, -30.0, 10.0, 0.1, rng);
  const CalibrationResult r = CalibrateViews(set.views, b, 640, 480, "cm", CalibrateOptions());
  const cv::Mat report = DrawReport(r, cv::Mat(), 0);
  CHECK(report.cols > 640);
  CalibrationOutputs out;
  out.calibration = dir + "/calib.yaml";
  out.lut = dir + "/tables/sensor.lut";
  out.report = dir + "/report.png";
  fs::create_directories(dir + "/tables");
  WriteCalibrationOutputs(r, out, report);
  const Calibration c = ReadCalibration(out.calibration);
  CHECK(c.sensor.model == MirrorModel::kSphere);
  CHECK(c.units == "cm");
  CHECK(c.lut == "tables/sensor.lut");
  CHECK(c.sensor.params.focal_px == Approx(r.calib.sensor.params.focal_px));
  CHECK(c.extras.count("focal_px_std") == 1);
  CHECK(c.extras.count("mirror_radius_std") == 1);
  CHECK(c.extras.count("mirror_distance_std") == 1);
  CHECK(c.extras.at("rms_px") == Approx(r.rms_px));
  // Per-image results keyed by file name, with the fitted board poses; counts as integers.
  REQUIRE(c.images.size() == r.views.size());
  for (size_t i = 0; i < r.views.size(); ++i) {
    CHECK(c.images[i].file == r.views[i].file);
    CHECK(c.images[i].rms_px == r.image_rms[i]);
    CHECK(c.images[i].corners == static_cast<int>(r.views[i].corners.size()));
    CHECK((c.images[i].rvec - r.views[i].rvec).norm() == 0.0);
    CHECK((c.images[i].tvec - r.views[i].tvec).norm() == 0.0);
  }
  CHECK(c.software == std::string("panotrack ") + PANO_VERSION);
  CHECK(c.extras.count("images_used") == 0);
  const std::string yaml = CalibrationToYaml(r.calib);
  CHECK(yaml.find("images_used: " + std::to_string(r.views.size()) + "\n") != std::string::npos);
  const RadiusTable t = RadiusTable::Load(c.lut_resolved, &c.sensor);
  CHECK_FALSE(t.empty());
  CHECK_FALSE(cv::imread(out.report).empty());
  const std::string text = CalibrationSummary(r);
  CHECK(text.find("focal_px") != std::string::npos);
  CHECK(text.find("RMS reprojection error") != std::string::npos);
  // A failure while preparing (an unwritable report) writes nothing.
  CalibrationOutputs bad = out;
  bad.calibration = dir + "/other.yaml";
  bad.lut = dir + "/other.lut";
  CHECK_THROWS_AS(WriteCalibrationOutputs(r, bad, cv::Mat()), Error);
  CHECK_FALSE(fs::exists(bad.calibration));
  CHECK_FALSE(fs::exists(bad.lut));
}

TEST_CASE("outputs: a calibration file of an earlier version still reads", "[outputs]") {
  const std::string dir = test::ScratchDir("calib_old_format");
  const std::string path = dir + "/old.yaml";
  {
    std::ofstream f(path);
    f << "model: sphere\nunits: cm\nimage_width: 640\nimage_height: 480\nfocal_px: 590\ncx: 319.5\n"
         "cy: 239.5\naspect: 1\nmirror_radius: 4.9\nmirror_distance: 15.1\nazimuth_offset: 0\n"
         "rms_px: 0.25\nimages_used: 12.0\nimages_total: 14.0\nrms_image_3: 0.31\nrms_image_10: 0.2\n";
  }
  const Calibration c = ReadCalibration(path);
  CHECK(c.images_total == 14);
  CHECK(c.images.empty());
  CHECK(c.extras.at("rms_image_10") == 0.2);
  CHECK(c.extras.count("images_used") == 0);
  // A count that is not one is named.
  {
    std::ofstream f(path, std::ios::app);
    f << "images_total_bad: 1\n";
  }
  std::string text;
  {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  const size_t at = text.find("images_total: 14.0");
  REQUIRE(at != std::string::npos);
  text.replace(at, 18, "images_total: 2.5");
  {
    std::ofstream f(path);
    f << text;
  }
  CHECK_THROWS_WITH(ReadCalibration(path), Catch::Contains("images_total") && Catch::Contains("2.5"));
}

}  // namespace
}  // namespace pano

// panocalib calibrate's summary as JSON (--summary-json): read back, every
// figure equals the CalibrationResult's.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "panotrack/pipeline/calibration_json.h"
#include "panotrack/config.h"
#include "panotrack/io/calibration.h"
#include "panotrack/pipeline/panocalib.h"
#include "synthetic.h"
#include "test_paths.h"
#include "test_rng.h"

namespace pano {
namespace {

using nlohmann::json;

TEST_CASE("summary JSON: RMS, per-image RMS by file, parameters with standard deviations, warnings",
          "[summary_json]") {
  PANO_SEEDED_RNG(73);
  const Sensor s = ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor;
  TargetBoard b;
  b.cols = 9;
  b.rows = 6;
  b.square = 3.0;
  const auto set = test::MakeSyntheticSet(s, b, 8, 12.0, 30.0, -30.0, 10.0, 0.1, rng);
  CalibrationResult r = CalibrateViews(set.views, b, 640, 480, "cm", CalibrateOptions());
  REQUIRE(r.views.size() == 8);
  // What a run on image files adds: images without a board, a warning, timings.
  r.not_found_files = {"cal_008.png", "cal_009.png"};
  r.warnings.push_back("cal_003.png: RMS 4.2 px, more than four times the overall RMS");
  r.seconds_detect = 1.25;
  // A parameter the data do not determine.
  r.parameters.push_back({"k1", 0.5, NAN, false});
  CalibrationOutputs out;
  out.calibration = "calib.yaml";
  out.report = "report.png";
  const std::vector<std::string> argv = {"panocalib", "calibrate", "targets.yaml", "-o", "calib.yaml"};

  const json j = json::parse(CalibrationSummaryJson(r, out, argv));
  CHECK(j.at("tool") == "panocalib calibrate");
  CHECK(j.at("version") == PANO_VERSION);
  CHECK(j.at("command_line").get<std::vector<std::string>>() == argv);
  CHECK(j.at("model") == "sphere");
  CHECK(j.at("image_width") == 640);
  CHECK(j.at("image_height") == 480);
  CHECK(j.at("poses_known") == r.poses_known);
  CHECK(j.at("boards_used") == 8);
  // Doubles are written with all their digits: they read back exactly.
  CHECK(j.at("rms_px").get<double>() == r.rms_px);
  REQUIRE(j.at("image_rms_px").size() == 8);
  for (size_t i = 0; i < r.views.size(); ++i) {
    CHECK(j.at("image_rms_px").at(r.views[i].file).get<double>() == r.image_rms[i]);
    CHECK(j.at("detection").at(r.views[i].file) == r.views[i].method);
  }
  REQUIRE(j.at("parameters").size() == r.parameters.size());
  for (const ParameterEstimate& p : r.parameters) {
    INFO(p.name);
    const json& e = j.at("parameters").at(p.name);
    CHECK(e.at("value").get<double>() == p.value);
    CHECK(e.at("fixed") == p.fixed);
    if (std::isfinite(p.stddev)) CHECK(e.at("stddev").get<double>() == p.stddev);
    else CHECK(e.at("stddev").is_null());
  }
  CHECK(j.at("parameters").at("focal_px").at("stddev").get<double>() > 0);
  CHECK(j.at("parameters").at("k1").at("stddev").is_null());
  CHECK(j.at("images_not_found").get<std::vector<std::string>>() == r.not_found_files);
  CHECK(j.at("warnings").get<std::vector<std::string>>() == r.warnings);
  CHECK(j.at("iterations") == r.iterations);
  CHECK(r.iterations > 0);
  CHECK(j.at("seconds").at("detection") == 1.25);
  CHECK(j.at("seconds").at("fit").get<double>() == r.seconds_fit);
  CHECK(j.at("outputs") == json({{"calibration", "calib.yaml"}, {"report", "report.png"}}));
  // Written with the calibration, prepared before either file: both there,
  // nothing else left in the folder.
  const std::string dir = test::ScratchDir("calib_summary_json");
  CalibrationOutputs files;
  files.calibration = dir + "/calib.yaml";
  files.summary_json = dir + "/summary.json";
  files.command_line = argv;
  WriteCalibrationOutputs(r, files, cv::Mat());
  std::ifstream in(files.summary_json);
  std::stringstream text;
  text << in.rdbuf();
  CHECK(text.str() == CalibrationSummaryJson(r, files, argv));
  int entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++entries;
  CHECK(entries == 2);
  // A summary whose folder does not exist stops everything before any write.
  CalibrationOutputs bad = files;
  bad.calibration = dir + "/other.yaml";
  bad.summary_json = dir + "/missing/summary.json";
  CHECK_THROWS_WITH(WriteCalibrationOutputs(r, bad, cv::Mat()), Catch::Contains("missing/summary.json"));
  CHECK_FALSE(std::filesystem::exists(bad.calibration));
}

}  // namespace
}  // namespace pano

// panocalib's jobs (pipeline/panocalib.h): calibrate, evaluate, export and
// tilt run on files as the program runs them.
#include <catch2/catch.hpp>

#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "expect_error.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/command_line.h"
#include "panotrack/io/map.h"
#include "panotrack/pipeline/panocalib.h"
#include "panotrack/pipeline/unwarp_files.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/render/targets_render.h"
#include "panotrack/scene/scene.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

// Eight rendered boards of the paper-real sphere in a folder (no target
// file: the board is given as on panocalib's command line).
std::string RenderBoardFolder(const std::string& name, const Calibration& truth, TargetBoard* board) {
  const std::string dir = test::ScratchDir(name) + "/boards";
  board->cols = 9;
  board->rows = 6;
  board->square = 3.0;
  RenderOptions ro;
  ro.noise_sigma = 2.0;
  ro.seed = 11;
  TargetsWriteOptions wo;
  wo.overwrite = true;
  WriteTargetImages(dir, truth, *board, AutoBoardPoses(truth.sensor, *board, 8, 11), ro, wo);
  // Only the images: the folder is read as a user's folder of photographs.
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() != ".png") fs::remove(e.path());
  return dir;
}

CalibrateJob SphereJob(const std::string& folder, const TargetBoard& board, const std::string& out_dir) {
  CalibrateJob job;
  job.targets = folder;
  job.board.board_given = true;
  job.board.board = board;
  job.options.model = MirrorModel::kSphere;
  job.options.num_threads = 2;
  job.outputs = {out_dir + "/calib.yaml", out_dir + "/calib.lut", out_dir + "/report.png",
                 out_dir + "/summary.json", {"panocalib", "calibrate", folder, "-o", out_dir + "/calib.yaml"}};
  job.names.outputs = {{"-o", job.outputs.calibration}, {"--lut", job.outputs.lut},
                       {"--report", job.outputs.report}, {"--summary-json", job.outputs.summary_json}};
  return job;
}

TEST_CASE("calibrate job: a folder of boards calibrated, every output written; evaluate agrees",
          "[panocalib_jobs]") {
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  TargetBoard board;
  const std::string folder = RenderBoardFolder("panocalib_jobs", truth, &board);
  const std::string out = test::ScratchDir("panocalib_jobs_out");
  const CalibrateJob job = SphereJob(folder, board, out);
  const CalibrationResult r = RunCalibrate(job);
  REQUIRE(r.views.size() == 8);
  // Rendered with 2 grey levels of noise: measured 0.085 px.
  CHECK(r.rms_px < 0.2);
  const Calibration written = ReadCalibration(job.outputs.calibration);
  CHECK(written.sensor.params.curvature_radius == Approx(r.calib.sensor.params.curvature_radius).epsilon(1e-12));
  CHECK(written.command_line == ShellCommandLine(job.outputs.command_line));
  CHECK(written.lut == "calib.lut");
  CHECK(fs::file_size(job.outputs.lut) > 0);
  const cv::Mat report = cv::imread(job.outputs.report);
  CHECK(report.cols > 0);
  const nlohmann::json summary = nlohmann::json::parse(ReadFile(job.outputs.summary_json));
  CHECK(summary.at("rms_px").get<double>() == r.rms_px);
  CHECK(summary.at("boards_used") == 8);
  CHECK(CalibrationSummary(r).find("8 boards used") != std::string::npos);

  // evaluate on the same images: the figure calibrate reported (measured
  // 0.0867 against 0.0855 px).
  EvaluateJob eval;
  eval.calibration = job.outputs.calibration;
  eval.targets = folder;
  eval.board = job.board;
  eval.options.num_threads = 2;
  eval.summary_json = out + "/evaluate.json";
  eval.command_line = {"panocalib", "evaluate"};
  eval.names = {{{"--calib", eval.calibration}}, {{"--summary-json", eval.summary_json}}};
  const EvaluationResult e = RunEvaluate(eval);
  CHECK(e.boards_fitted == 8);
  CHECK(e.rms_px == Approx(r.rms_px).epsilon(0.10));
  CHECK(nlohmann::json::parse(ReadFile(eval.summary_json)).at("rms_px").get<double>() == e.rms_px);
}

TEST_CASE("calibrate job: an output that is a board image is refused, nothing written", "[panocalib_jobs]") {
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  TargetBoard board;
  const std::string folder = RenderBoardFolder("panocalib_jobs_guard", truth, &board);
  const std::string out = test::ScratchDir("panocalib_jobs_guard_out");
  CalibrateJob job = SphereJob(folder, board, out);
  const std::string image = folder + "/cal_003.png";
  REQUIRE(fs::exists(image));
  const std::string before = ReadFile(image);
  job.outputs.report = image;
  job.names.outputs[2].second = image;
  test::ExpectError([&] { RunCalibrate(job); }, image, {"--report", "the same file as", "refusing to overwrite"});
  CHECK(ReadFile(image) == before);
  CHECK_FALSE(fs::exists(job.outputs.calibration));
  CHECK_FALSE(fs::exists(job.outputs.lut));
}

TEST_CASE("export job: the calibration in OpenCV's terms, its omnidir fit returned", "[panocalib_jobs]") {
  const std::string out = test::ScratchDir("panocalib_jobs_export") + "/opencv.yml";
  const ExportResult r = RunExport({test::SourcePath("calib/paper-real.yaml"), out, {}});
  CHECK(r.units == "cm");
  CHECK(r.omnidir.rms_px < 1.0);  // a sphere: no single viewpoint; measured 0.47 px far field
  cv::FileStorage fs(out, cv::FileStorage::READ);
  REQUIRE(fs.isOpened());
  double xi = 0.0;
  fs["omnidir_xi"] >> xi;
  CHECK(xi == Approx(r.omnidir.xi).epsilon(1e-9));
}

// A few frames of the faulty rig as a folder, its map and its calibration
// without the tilt, written as a user's files.
struct TiltFiles {
  std::string calibration, map, frames;
};
TiltFiles WriteTiltFiles(const std::string& dir, int n_frames) {
  SequenceCase c = MakePreset("faulty-rig");
  const Scene scene = Scene::FromMap(c.map, true);
  const Renderer renderer(c.calib.sensor, scene, c.map.sensor_height, c.options);
  TiltFiles f{dir + "/calib.yaml", dir + "/map.yaml", dir + "/frames"};
  fs::create_directories(f.frames);
  for (int i = 0; i < n_frames; ++i) {
    char name[64];
    std::snprintf(name, sizeof name, "/frame_%03d.png", i);
    cv::imwrite(f.frames + name, renderer.Render(c.poses[static_cast<size_t>(i)], i));
  }
  Calibration calib = c.calib;
  calib.sensor.faults.sensor_tilt[0] = calib.sensor.faults.sensor_tilt[1] = 0.0;
  WriteCalibration(f.calibration, calib);
  c.map.distractors.clear();
  WriteMap(f.map, c.map);
  return f;
}

TEST_CASE("tilt job: the tilt measured from a folder of frames, written into a copy of the calibration",
          "[panocalib_jobs]") {
  const std::string dir = test::ScratchDir("panocalib_jobs_tilt");
  const TiltFiles f = WriteTiltFiles(dir, 12);
  const std::string calib_before = ReadFile(f.calibration);
  TiltJob job{f.calibration, f.map, f.frames, dir + "/tilted.yaml", {}};
  job.tilt.max_frames = 12;
  job.tilt.init = MakePreset("faulty-rig").poses.front();
  const TiltResult r = RunTilt(job);
  CHECK(ReadFile(f.calibration) == calib_before);
  CHECK(r.measured.frames == 12);
  CHECK(r.measured.tracked_after == 12);
  CHECK(r.measured.residual_after < r.measured.residual_before);
  const Calibration written = ReadCalibration(job.output);
  CHECK(written.sensor.faults.sensor_tilt[0] == Approx(r.measured.tilt[0]).margin(1e-12));
  CHECK(written.sensor.faults.sensor_tilt[1] == Approx(r.measured.tilt[1]).margin(1e-12));
  // The rig is tilted 0.4 degrees about x (measured 0.453 on 12 frames).
  CHECK(std::abs(r.measured.tilt[0] * 180 / M_PI - 0.4) < 0.15);

  // A map in other units than the calibration's: refused before any work.
  Map other = ReadMap(f.map);
  other.units = "mm";
  const std::string mm_map = dir + "/map_mm.yaml";
  WriteMap(mm_map, other);
  job.map = mm_map;
  job.output = dir + "/never.yaml";
  test::ExpectError([&] { RunTilt(job); }, mm_map, {"units 'mm'", "calibration's 'cm'"});
  CHECK_FALSE(fs::exists(job.output));
}

TEST_CASE("unwarp job: an image or a video by the output's extension", "[panocalib_jobs]") {
  const std::string dir = test::ScratchDir("panocalib_jobs_unwarp");
  const TiltFiles f = WriteTiltFiles(dir, 3);
  UnwarpJob job{f.calibration, f.frames + "/frame_000.png", dir + "/panorama.png", {}, false};
  const UnwarpResult image = RunUnwarp(job);
  CHECK(image.frames == -1);
  const cv::Mat written = cv::imread(job.output, cv::IMREAD_UNCHANGED);
  CHECK(written.cols == image.view.width());
  CHECK(written.rows == image.view.height());
  // The same output again: refused without overwrite, replaced with it.
  test::ExpectError([&] { RunUnwarp(job); }, job.output, {"exists"});
  job.overwrite = true;
  CHECK_NOTHROW(RunUnwarp(job));

  job.input = f.frames;
  job.output = dir + "/panorama.mp4";
  const UnwarpResult video = RunUnwarp(job);
  CHECK(video.frames == 3);
  CHECK(fs::file_size(job.output) > 0);
}

TEST_CASE("projection jobs: a file of points and one of pixels, line for line; the lookup table",
          "[panocalib_jobs]") {
  const std::string dir = test::ScratchDir("panocalib_jobs_batch");
  const std::string calib = test::SourcePath("calib/paper-real.yaml");
  const Sensor sensor = ReadCalibration(calib).sensor;
  {
    std::ofstream points(dir + "/points.csv");
    points << "x,y,z\n100, 0, 40\n0 0 -5  # below the mirror\n-60,80,10\n";
  }
  const BatchProjection projected = RunProjectPoints({calib, dir + "/points.csv", dir + "/pixels.txt", false});
  CHECK(projected.count == 3);
  CHECK(projected.no_result == 1);
  Eigen::Vector2d px;
  REQUIRE(sensor.project({100, 0, 40}, &px));
  const std::string lines = ReadFile(dir + "/pixels.txt");
  CHECK(lines.rfind(FormatPixel(px) + "\nnan nan\n", 0) == 0);
  // Pixels back through the calibration: a ray per line, nan off the mirror.
  {
    std::ofstream pixels(dir + "/pixels.csv");
    pixels << "400.5 240\n5 5\n";
  }
  const BatchProjection rays = RunBackprojectPixels({calib, dir + "/pixels.csv", dir + "/rays.txt", false});
  CHECK(rays.count == 2);
  CHECK(rays.no_result == 1);  // the image's corner lies off the mirror
  Eigen::Vector3d origin, direction;
  REQUIRE(sensor.backproject({400.5, 240.0}, &origin, &direction));
  CHECK(ReadFile(dir + "/rays.txt") == FormatRay(origin, direction) + "\nnan nan nan nan nan nan\n");
  // Never over an input.
  test::ExpectError([&] { RunProjectPoints({calib, dir + "/points.csv", dir + "/points.csv", true}); },
                    dir + "/points.csv", {"the same file as"});

  const LutResult lut = RunLut({calib, "", dir + "/table.lut", 64, false});
  CHECK(lut.units == "cm");
  CHECK(lut.ranges.d_max > lut.ranges.d_min);
  CHECK(RadiusTable::Load(dir + "/table.lut", &sensor).ranges().d_max == lut.ranges.d_max);
}

}  // namespace
}  // namespace pano

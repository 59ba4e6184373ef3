// Checking a calibration: many points through it at once (batch project /
// backproject, the single-point commands' output line for line), and its
// reprojection error on other images with only the board poses fitted.
#include <catch2/catch.hpp>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "expect_error.h"
#include "panotrack/calibrate/batch_projection.h"
#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/evaluate.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/target_input.h"
#include "rendered_targets.h"
#include "test_paths.h"
#include "test_rng.h"

namespace pano {
namespace {

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string l;
  while (std::getline(in, l)) lines.push_back(l);
  return lines;
}

TEST_CASE("batch projection: 1000 points and their pixels, line for line the single-point form",
          "[batch_projection]") {
  PANO_SEEDED_RNG(11);
  const Sensor sensor = ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor;
  std::uniform_real_distribution<double> azimuth(-M_PI, M_PI), elevation(-0.9, 0.9), distance(20.0, 800.0);
  // Comma, whitespace and mixed separators; a comment, a header, blank lines.
  std::string csv = "# points in the sensor frame\nx, y, z\n\n";
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 1000; ++i) {
    const double a = azimuth(rng), e = elevation(rng), d = distance(rng);
    points.emplace_back(d * std::cos(e) * std::cos(a), d * std::cos(e) * std::sin(a), d * std::sin(e));
    char line[160];
    std::snprintf(line, sizeof line, i % 3 == 0 ? "%.17g,%.17g,%.17g\n" : i % 3 == 1 ? "%.17g %.17g\t%.17g  # c\n"
                                                                                    : " %.17g, %.17g %.17g\r\n",
                  points.back().x(), points.back().y(), points.back().z());
    csv += line;
  }
  const BatchProjection proj = ProjectPointsCsv(sensor, csv, "points.csv");
  const std::vector<std::string> pixel_lines = Lines(proj.text);
  REQUIRE(pixel_lines.size() == 1000);
  CHECK(proj.count == 1000);
  std::string pixel_csv;
  std::vector<Eigen::Vector2d> pixels;
  int nan_lines = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d px;
    if (sensor.project(points[i], &px) && sensor.inside_image(px)) {
      CHECK(pixel_lines[i] == FormatPixel(px));
      pixel_csv += pixel_lines[i] + "\n";
      pixels.push_back(px);
    } else {
      CHECK(pixel_lines[i] == "nan nan");
      ++nan_lines;
    }
  }
  CHECK(nan_lines == proj.no_result + proj.outside_image);
  // Most points are seen (elevations within +-52 degrees, some below the limb).
  CHECK(pixels.size() > 600);

  // Back: each ray is the single-point form's, and passes through its point
  // (to the 6 decimals of the printed pixel).
  const BatchProjection back = BackprojectPixelsCsv(sensor, "u,v\n" + pixel_csv, "pixels.csv");
  const std::vector<std::string> ray_lines = Lines(back.text);
  REQUIRE(ray_lines.size() == pixels.size());
  CHECK(back.no_result == 0);
  CHECK(back.outside_image == 0);
  double worst_angle = 0.0;
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (pixel_lines[i] == "nan nan") continue;
    // The pixel as printed, as the single-point command would read it.
    double u, v;
    REQUIRE(std::sscanf(pixel_lines[i].c_str(), "%lf %lf", &u, &v) == 2);
    Eigen::Vector3d o, d;
    REQUIRE(sensor.backproject({u, v}, &o, &d));
    CHECK(ray_lines[k] == FormatRay(o, d));
    const Eigen::Vector3d to_point = (points[i] - o).normalized();
    worst_angle = std::max(worst_angle, std::acos(std::min(1.0, to_point.dot(d))));
    ++k;
  }
  WARN("round trip: worst angle between ray and point " << worst_angle << " rad");
  CHECK(worst_angle < 1e-7);  // measured 3.7e-8 rad

  // A pixel off the mirror or outside the image: a nan line, counted.
  const BatchProjection odd = BackprojectPixelsCsv(sensor, "0 0\n-5,100\n", "-");
  CHECK(odd.text == "nan nan nan nan nan nan\nnan nan nan nan nan nan\n");
  CHECK(odd.no_result == 1);
  CHECK(odd.outside_image == 1);
  CHECK(BatchNote(odd, true) == "2 pixels: 1 off the mirror, 1 outside the image (nan lines)");
  CHECK(BatchNote(back, true).empty());
}

TEST_CASE("batch projection: a line that cannot be read names the file and line", "[batch_projection]") {
  const Sensor sensor = ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor;
  CHECK(test::ErrorOf([&] { ProjectPointsCsv(sensor, "x,y,z\n1,2,3\n4,abc,6\n", "p.csv"); }) ==
        "p.csv:3: expected 3 finite numbers (x y z), got 'abc'");
  CHECK(test::ErrorOf([&] { ProjectPointsCsv(sensor, "# c\n1,2,3\n1,2\n", "p.csv"); }) ==
        "p.csv:3: expected 3 finite numbers (x y z), got 2 fields");
  CHECK(test::ErrorOf([&] { ProjectPointsCsv(sensor, "1,2,3\nx,y,z\n", "p.csv"); }) ==
        "p.csv:2: expected 3 finite numbers (x y z), got 'x'");  // a header only first
  CHECK(test::ErrorOf([&] { BackprojectPixelsCsv(sensor, "1 nan\n", "<stdin>"); }) ==
        "<stdin>:1: expected 2 finite numbers (u v), got 'nan'");
  CHECK(ProjectPointsCsv(sensor, "# nothing\n\n", "p.csv").count == 0);
  // Binary data: neither a header nor an empty file.
  CHECK(test::ErrorOf([&] { BackprojectPixelsCsv(sensor, std::string("\x7f" "ELF\x02\x01\x01\0\0", 9), "-"); }) ==
        "-:1: not a text file of numbers (byte 0x7F at column 1)");
  CHECK(test::ErrorOf([&] { BackprojectPixelsCsv(sensor, "u v\n1 2\n3\x01 4\n", "p.csv"); }) ==
        "p.csv:3: not a text file of numbers (byte 0x01 at column 2)");
  // A first line of other words than the fields' count is no header.
  CHECK(test::ErrorOf([&] { BackprojectPixelsCsv(sensor, "\xe9\xff garbage bytes here\n", "p.csv"); }) ==
        "p.csv:1: expected 2 finite numbers (u v), got 4 fields");
}

TEST_CASE("evaluate: the true calibration scores near the corner noise, a 2 % focal error far above",
          "[evaluate]") {
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const TargetSet targets =
      ReadTargets(test::RenderTargets("calibrate_evaluate", truth, 8, 7) + "/targets_unknown.yaml");
  const std::vector<cv::Mat> images = LoadTargetImages(targets);
  EvaluateOptions options;
  options.num_threads = 2;
  options.unwarp_fallback = false;  // the raw search alone
  const EvaluationResult r = EvaluateCalibration(targets, images, truth, options);
  REQUIRE(r.images.size() == 8);
  CHECK(r.boards_found == 7);  // measured: the 8th board is not found in the raw image
  CHECK(r.boards_fitted == 7);
  CHECK(r.corners == 7 * 54);
  for (const ImageEvaluation& im : r.images)
    if (im.found) CHECK(im.fit.max_px < 0.3);
  Calibration off = truth;
  off.sensor.params.focal_px *= 1.02;
  const EvaluationResult r_off = EvaluateCalibration(targets, images, off, options);
  WARN("true calibration: RMS " << r.rms_px << " px (max " << r.max_px << "); focal +2 %: RMS " << r_off.rms_px
                                << " px (max " << r_off.max_px << ")");
  // Measured 0.0568 px (rendered corners refined through the model) and 0.708 px.
  CHECK(r.rms_px == Approx(0.0568).margin(0.006));
  CHECK(r_off.rms_px == Approx(0.708).margin(0.05));
  CHECK(r_off.boards_fitted == 7);
  // The detector's corners as found: a larger error, the same order.
  options.refine_passes = 0;
  const EvaluationResult raw = EvaluateCalibration(targets, images, truth, options);
  WARN("unrefined corners: RMS " << raw.rms_px << " px");
  CHECK(raw.rms_px == Approx(0.1935).margin(0.02));  // measured (the raw search with CALIB_CB_ACCURACY)

  // As calibrate does, the image without a board in the raw search is
  // searched in views unwarped through the calibration: 8 of 8 boards.
  EvaluateOptions unwarp;
  unwarp.num_threads = 2;
  const EvaluationResult all = EvaluateCalibration(targets, images, truth, unwarp);
  WARN("with the unwarped search: " << all.boards_found << " boards, RMS " << all.rms_px << " px");
  CHECK(all.boards_found == 8);
  CHECK(all.boards_fitted == 8);
  CHECK(all.rms_px == Approx(0.0684).margin(0.006));  // measured (the 8th board lies near the limb)

  // The text and JSON name every image; a calibration for other units or
  // images with no board at all are errors.
  const std::string text = EvaluationSummary(r);
  CHECK(text.find("cal_007.png: no board") != std::string::npos);
  CHECK(text.find("held-out RMS reprojection error 0.05") != std::string::npos);
  Calibration mm = truth;
  mm.units = "mm";
  CHECK(test::ErrorOf([&] { EvaluateCalibration(targets, images, mm, options); })
            .find("the calibration's units (mm) differ from the targets' (cm)") == 0);
  std::vector<cv::Mat> blank;
  for (const cv::Mat& im : images) blank.push_back(cv::Mat(im.size(), im.type(), cv::Scalar(128)));
  CHECK(test::ErrorOf([&] { EvaluateCalibration(targets, blank, truth, options); }) ==
        "no board found in any of the 8 images");
}

// The RMS of `view`'s corners through `sensor` at the pose (rvec, tvec).
double RmsAtPose(const BoardView& view, const TargetBoard& board, const Sensor& sensor, const Eigen::Vector3d& rvec,
                 const Eigen::Vector3d& tvec) {
  const std::vector<Eigen::Vector3d> points = BoardPoints(board);
  const Eigen::AngleAxisd turn(rvec.norm(), rvec.normalized());
  double s2 = 0.0;
  for (size_t k = 0; k < view.corners.size(); ++k) {
    Eigen::Vector2d px;
    REQUIRE(sensor.project(turn * points[static_cast<size_t>(view.PointId(k))] + tvec, &px));
    s2 += (px - view.corners[k]).squaredNorm();
  }
  return std::sqrt(s2 / static_cast<double>(view.corners.size()));
}

TEST_CASE("evaluate: each board's pose gives the least RMS of the poses near it, a stray corner or not",
          "[evaluate]") {
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const TargetSet targets =
      ReadTargets(test::RenderTargets("calibrate_evaluate", truth, 8, 7) + "/targets_unknown.yaml");
  CalibrateOptions detect;
  detect.num_threads = 2;
  const DetectionResult det = DetectBoards(targets, LoadTargetImages(targets), detect);
  REQUIRE(det.views.size() >= 5);
  BoardView view = det.views[2];
  view.corners[20] += Eigen::Vector2d(4.0, -3.0);  // a stray corner, 5 px off
  EvaluateOptions least_squares, robust;
  robust.least_squares_pose = false;
  const BoardPoseFit ls = FitBoardPose(view, targets.board, truth.sensor, least_squares);
  const BoardPoseFit rb = FitBoardPose(view, targets.board, truth.sensor, robust);
  REQUIRE(ls.ok);
  REQUIRE(rb.ok);
  WARN("a stray corner: RMS " << ls.rms_px << " px at the least-squares pose, " << rb.rms_px
                              << " px at the robust fit's");
  // The robust fit leaves the stray corner's error whole; least squares
  // spreads it (measured 0.695 against 0.703 px).
  CHECK(ls.rms_px < rb.rms_px - 0.004);
  CHECK(ls.rms_px == Approx(RmsAtPose(view, targets.board, truth.sensor, ls.rvec, ls.tvec)).epsilon(1e-9));
  // No nearby pose does better: each of the 6 parameters moved both ways.
  const double step = 1e-4;
  for (int k = 0; k < 6; ++k)
    for (double sign : {-1.0, 1.0}) {
      Eigen::Vector3d r = ls.rvec, t = ls.tvec;
      (k < 3 ? r[k] : t[k - 3]) += sign * step * (k < 3 ? 1.0 : 10.0);
      CHECK(RmsAtPose(view, targets.board, truth.sensor, r, t) >= ls.rms_px - 1e-12);
    }
}

}  // namespace
}  // namespace pano

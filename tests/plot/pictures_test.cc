// The pictures the tools write: each has the expected size and survives the
// edge cases (no ground truth, every frame lost, one frame, one landmark, no
// board), marks what it says where it says (the start marker at the start
// pose), and a lost frame's reason names the test that failed.
#include <catch2/catch.hpp>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/io/calibration.h"
#include "panotrack/pipeline/debug_draw.h"
#include "panotrack/pipeline/plot.h"
#include "panotrack/pipeline/calibration_report.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

Map TestMap(bool one_landmark = false) {
  Map m;
  m.units = "cm";
  if (!one_landmark) {
    m.room.present = true;
    m.room.min = {0, 0};
    m.room.max = {100, 80};
    m.room.height = 50;
  }
  MapRectangle r;
  r.id = "panel-a";
  r.from = {10, 79};
  r.to = {40, 79};
  r.z1 = 30;
  m.rectangles.push_back(r);
  if (!one_landmark) {
    r.id = "panel-b";
    r.from = {99, 20};
    r.to = {99, 50};
    m.rectangles.push_back(r);
    MapBox b;
    b.id = "cabinet";
    b.min = {60, 5, 0};
    b.max = {80, 15, 20};
    m.boxes.push_back(b);
  }
  return m;
}

// A straight run from (20, 20) to (75, 60), frame 5 lost, with std columns.
std::vector<PoseRow> Run(int frames, double offset) {
  std::vector<PoseRow> rows;
  for (int i = 0; i < frames; ++i) {
    PoseRow r;
    r.frame = i;
    r.time_s = 0.1 * i;
    const double t = frames > 1 ? static_cast<double>(i) / (frames - 1) : 0.0;
    r.pose = Pose2{20 + 55 * t + offset * std::sin(i), 20 + 40 * t, 0.6 + offset * 0.01 * std::cos(i)};
    r.n_landmarks = 6;
    r.extra = {0.2, 0.25, 0.002, 0.8};
    rows.push_back(r);
  }
  return rows;
}

std::vector<PoseRow> WithLost(std::vector<PoseRow> rows, int lost) {
  if (lost < static_cast<int>(rows.size())) {
    rows[lost].status = PoseStatus::kLost;
    rows[lost].extra.assign(4, std::nan(""));
  }
  return rows;
}

std::vector<PoseRow> AllLost(std::vector<PoseRow> rows) {
  for (PoseRow& r : rows) r.status = PoseStatus::kLost;
  return rows;
}

cv::Vec3b At(const cv::Mat& img, const cv::Point2d& p) {
  return img.at<cv::Vec3b>(static_cast<int>(std::lround(p.y)), static_cast<int>(std::lround(p.x)));
}

TEST_CASE("trajectory: size, markers at the transformed poses, edge cases", "[trajectory]") {
  const Map map = TestMap();
  const std::vector<PoseRow> truth = Run(20, 0.0);
  const std::vector<PoseRow> est = WithLost(Run(20, 0.3), 5);
  const TrajectoryFigure fig = DrawTrajectoryPlot(map, est, truth);
  // 1000 wide; the map (100 x 80 plus 4 % margins) sets the height.
  CHECK(fig.image.cols == 1000);
  CHECK(fig.image.rows == 36 + static_cast<int>(680.0 * 88 / 108) + 60);
  CHECK(fig.image.type() == CV_8UC3);
  // The start marker (green disc) at the first pose, the end marker (red
  // square) at the last.
  CHECK(At(fig.image, fig.transform.ToPixel(est.front().pose.x, est.front().pose.y)) == cv::Vec3b(44, 160, 44));
  CHECK(At(fig.image, fig.transform.ToPixel(est.back().pose.x, est.back().pose.y)) == cv::Vec3b(40, 39, 214));
  // The lost frame is marked (orange cross) at the truth's pose.
  CHECK(At(fig.image, fig.transform.ToPixel(truth[5].pose.x, truth[5].pose.y)) == cv::Vec3b(14, 127, 255));
  // Equal aspect, and the whole room inside the plot.
  CHECK(fig.transform.px_per_unit_x() == fig.transform.px_per_unit_y());
  CHECK(fig.transform.x_lo() <= 0);
  CHECK(fig.transform.x_hi() >= 100);
  CHECK(fig.transform.y_lo() <= 0);
  CHECK(fig.transform.y_hi() >= 80);

  SECTION("no ground truth: lost frames at the last pose known") {
    const TrajectoryFigure f = DrawTrajectoryPlot(map, est, {});
    CHECK(f.image.cols == 1000);
    CHECK(At(f.image, f.transform.ToPixel(est[4].pose.x, est[4].pose.y)) == cv::Vec3b(14, 127, 255));
  }
  SECTION("every frame lost, one frame, one landmark, nothing") {
    CHECK_NOTHROW(DrawTrajectoryPlot(map, AllLost(est), truth));
    CHECK_NOTHROW(DrawTrajectoryPlot(map, AllLost(est), {}));
    const TrajectoryFigure one = DrawTrajectoryPlot(map, Run(1, 0), Run(1, 0));
    CHECK(At(one.image, one.transform.ToPixel(20, 20)) == cv::Vec3b(44, 160, 44));
    const TrajectoryFigure lm = DrawTrajectoryPlot(TestMap(true), est, truth);
    CHECK(lm.image.cols == 1000);
    CHECK(lm.image.rows >= 36 + 360 + 60);
    CHECK_NOTHROW(DrawTrajectoryPlot(Map(), {}, {}));
  }
}

TEST_CASE("error plot: size, edge cases, written beside the plot", "[error_plot]") {
  const std::vector<PoseRow> truth = Run(30, 0.0);
  const std::vector<PoseRow> est = WithLost(Run(30, 0.3), 7);
  const cv::Mat img = DrawErrorPlot(est, truth, "cm");
  CHECK(img.cols == 960);
  CHECK(img.rows == 36 + 3 * 210 + 44);
  CHECK(DrawErrorPlot(AllLost(est), truth, "cm").size() == img.size());
  CHECK(DrawErrorPlot(Run(1, 0.1), Run(1, 0), "").size() == img.size());
  std::vector<PoseRow> no_std = est;
  for (PoseRow& r : no_std) r.extra.clear();
  CHECK(DrawErrorPlot(no_std, truth, "m").size() == img.size());

  CHECK(ErrorPlotPath("out/run/trajectory.png") == "out/run/trajectory_error.png");
  CHECK(ErrorPlotPath("plot.png") == "plot_error.png");
  const std::string dir = test::ScratchDir("plot_write");
  WritePlot(dir + "/t.png", TestMap(), est, truth);
  CHECK(cv::imread(dir + "/t.png").cols == 1000);
  CHECK(cv::imread(dir + "/t_error.png").cols == 960);
  WritePlot(dir + "/u.png", TestMap(), est, {});
  CHECK(fs::exists(dir + "/u.png"));
  CHECK_FALSE(fs::exists(dir + "/u_error.png"));
}

// One predicted landmark per map rectangle corner, half of them found.
struct DebugScene {
  Sensor sensor = ReadCalibration(test::SourcePath("calib/paper-synthetic.yaml")).sensor;
  std::vector<Landmark> landmarks;
  FrameResult fr;
  DebugScene() {
    landmarks.resize(6);
    for (int i = 0; i < 6; ++i) landmarks[i].id = "wall-" + std::to_string(i) + "/from-bottom";
    for (int i = 0; i < 6; ++i) {
      PredictedLandmark p;
      p.index = i;
      p.landmark = &landmarks[i];
      p.azimuth = i * 0.5;
      p.corner_radius = 120;
      p.v_radius = 160;
      p.corner_px = sensor.from_polar(120, p.azimuth);
      LandmarkMeasurement m;
      m.found = i % 2 == 0;
      m.azimuth = p.azimuth + 0.002;
      m.radius = 121;
      m.why = m.found ? "" : "vertical edge not found";
      fr.predicted.push_back(p);
      fr.measurements.push_back(m);
    }
    fr.row.frame = 12;
    fr.row.time_s = 1.2;
    fr.row.pose = Pose2{80, 60, 0.5};
    fr.row.n_landmarks = 3;
    fr.row.residual = 0.02;
    fr.row.extra = {0.01, 0.012, 0.0003, 0.9};
  }
};

TEST_CASE("debug frame: header band above the frame, labels, lost frames", "[debug_frame]") {
  DebugScene scene;
  const cv::Mat grey(scene.sensor.image_height, scene.sensor.image_width, CV_8UC1, cv::Scalar(128));
  cv::Mat out;
  DrawDebug(grey, scene.sensor, scene.fr, &out);
  CHECK(out.cols == grey.cols);
  CHECK(out.rows == grey.rows + kDebugHeaderHeight);
  CHECK(out.type() == CV_8UC3);
  // A found junction is a red cross at its image position (below the band).
  const Eigen::Vector2d j = scene.sensor.from_polar(121, scene.fr.measurements[0].azimuth);
  CHECK(At(out, {j.x(), j.y() + kDebugHeaderHeight}) == cv::Vec3b(0, 0, 255));
  // Lost, with nothing predicted, and on a frame of another content.
  scene.fr.row.status = PoseStatus::kLost;
  scene.fr.triangulation.failure = "too few landmarks (3 < 4)";
  CHECK_NOTHROW(DrawDebug(grey, scene.sensor, scene.fr, &out));
  CHECK(out.rows == grey.rows + kDebugHeaderHeight);
  FrameResult empty;
  empty.row.status = PoseStatus::kLost;
  CHECK_NOTHROW(DrawDebug(grey, scene.sensor, empty, &out));
  CHECK(out.size() == cv::Size(grey.cols, grey.rows + kDebugHeaderHeight));
}

TEST_CASE("lost reason: the first test the frame failed, with its numbers", "[lost_reason]") {
  DebugScene scene;
  FrameResult& fr = scene.fr;
  CHECK(LostReason(fr).empty());  // tracked
  fr.row.status = PoseStatus::kLost;
  fr.triangulation.ok = false;
  fr.triangulation.failure = "too few landmarks (3 < 4)";
  CHECK(LostReason(fr) == "too few landmarks (3 < 4); found 3 of 6; missed: vertical edge not found (3)");
  fr.triangulation.ok = true;
  fr.triangulation.rms_bearing = 0.6 * M_PI / 180;
  CHECK(LostReason(fr) == "bearing RMS 0.60 > 0.50 deg");
  fr.triangulation.rms_bearing = 0.001;
  fr.integrity.testable = true;
  fr.integrity.consistent = false;
  fr.integrity.chi2 = 35.14;
  fr.integrity.chi2_threshold = 18.5;
  CHECK(LostReason(fr) == "integrity: residuals inconsistent (chi2 35.1 > 18.5)");
  fr.integrity.consistent = true;
  fr.integrity.quality = 0.1;
  CHECK(LostReason(fr) == "integrity: quality 0.10 < 0.15");
  fr.integrity.quality = 0.5;
  fr.integrity.within_alert_limit = false;
  fr.integrity.protection_level = 2.1;
  fr.integrity.alert_limit = 0.9;
  CHECK(LostReason(fr) == "integrity: protection level 2.1 > alert limit 0.9");
  fr.integrity.within_alert_limit = true;
  fr.innovation = 35.2;
  CHECK(LostReason(fr) == "motion gate: innovation 35.2 > 21.1, too few inliers to override");
  fr.triangulation.inliers = {0, 1, 2, 3, 4};
  fr.withheld = true;
  CHECK(LostReason(fr) ==
        "no velocity to check it, and one bearing left out could move it beyond the alert limit (5 inliers; "
        "tracked on from it)");
  fr.withheld = false;
  fr.unconfirmed = true;
  CHECK(LostReason(fr) == "relocalised pose held for the next frame to confirm (5 inliers)");
  FrameResult none;
  none.row.status = PoseStatus::kLost;
  CHECK(LostReason(none) == "no landmark predicted (no pose to track from, or none in view)");
}

// A calibration result made by hand: the sensor of calib/paper-real.yaml,
// boards as rings of corners, one from the unwarped retry, one long name.
CalibrationResult HandResult(int views) {
  CalibrationResult r;
  r.calib = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const Sensor& s = r.calib.sensor;
  for (int v = 0; v < views; ++v) {
    BoardView b;
    b.file = v == 1 ? "a/rather/long/folder/name/for/the/calibration/images/cal_001.png"
                    : "cal_00" + std::to_string(v) + ".png";
    b.method = v == 2 ? "unwarped" : "raw";
    std::vector<Eigen::Vector2d> res;
    for (int k = 0; k < 20; ++k) {
      b.corners.push_back(s.from_polar(100 + 4 * k, 0.4 * v + 0.01 * k));
      res.emplace_back(0.05 * std::sin(k + v), 0.04 * std::cos(3 * k));
    }
    res[3] = Eigen::Vector2d(std::nan(""), std::nan(""));
    r.views.push_back(b);
    r.residuals.push_back(res);
    r.image_rms.push_back(0.04 + 0.01 * v);
  }
  r.rms_px = 0.05;
  r.parameters = {{"focal_px", 588.7, 1.9, false},
                  {"cx", 319.5, 0.007, false},
                  {"k1", 0.0, std::nan(""), false},
                  {"azimuth_offset", 0, 0, true}};
  r.not_found_files = {"cal_099.png"};
  r.warnings = {"the mirror's size is poorly determined"};
  return r;
}

TEST_CASE("report: corners of every image over the mirror, edge cases", "[report]") {
  const CalibrationResult r = HandResult(4);
  const Sensor& s = r.calib.sensor;
  const cv::Mat image(s.image_height, s.image_width, CV_8UC1, cv::Scalar(100));
  const cv::Mat report = DrawReport(r, image, 3);
  CHECK(report.type() == CV_8UC3);
  CHECK(report.cols >= 1400);
  CHECK(report.rows >= 46 + 30 + 400 + 24 + 30 + 250);
  // The first corner of image 1 (raw: a disc in its colour) in the coverage
  // panel: 560 px wide at (18, 70).
  const double sc = 560.0 / std::max(s.image_width, s.image_height);
  const Eigen::Vector2d c = r.views[0].corners[0];
  CHECK(At(report, {18 + c.x() * sc, 70 + c.y() * sc}) == cv::Vec3b(180, 119, 31));
  // No image, no view, one view, many views.
  CHECK_NOTHROW(DrawReport(r, cv::Mat(), 0));
  CHECK_NOTHROW(DrawReport(CalibrationResult(), cv::Mat(), 0));
  CHECK_NOTHROW(DrawReport(HandResult(1), image, 0));
  const cv::Mat many = DrawReport(HandResult(30), image, 5);
  CHECK(many.rows > report.rows);  // a bar per image
}

}  // namespace
}  // namespace pano

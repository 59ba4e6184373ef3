// Determinism, the presets' guarantees, the sequence writer and the
// calibration target renderer.
#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/io/targets.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/render/targets_render.h"
#include "panotrack/render/writers.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a != b) == 0;
}

TEST_CASE("rendering is deterministic for a seed, whatever the thread count", "[deterministic]") {
  SequenceCase c = MakePreset("paper-real");  // noise, blur, gradient
  const Scene scene = Scene::FromMap(c.map, true);
  c.options.num_threads = 1;
  const Renderer r1(c.calib.sensor, scene, c.map.sensor_height, c.options);
  c.options.num_threads = 3;
  const Renderer r(c.calib.sensor, scene, c.map.sensor_height, c.options);
  const cv::Mat a1 = r1.Render(c.poses[5], 5);
  const cv::Mat a2 = r.Render(c.poses[5], 5);
  const cv::Mat a3 = r.Render(c.poses[5], 5);
  CHECK(Same(a1, a2));
  CHECK(Same(a2, a3));
  // A thread count no run may have is refused, naming the field.
  RenderOptions bad = c.options;
  bad.num_threads = -1;
  CHECK_THROWS_WITH(bad.Check("options"), Catch::Contains("options: num_threads"));
  // Another frame index (noise) or another seed gives another image.
  CHECK_FALSE(Same(a1, r.Render(c.poses[5], 6)));
  RenderOptions o2 = c.options;
  o2.seed = c.options.seed + 1;
  const Renderer r2(c.calib.sensor, scene, c.map.sensor_height, o2);
  const cv::Mat b = r2.Render(c.poses[5], 5);
  CHECK_FALSE(Same(a1, b));
  // The noise is what differs: about sigma 3 grey levels on the mirror, nothing outside.
  cv::Mat diff;
  cv::absdiff(a1, b, diff);
  CHECK(cv::mean(diff)[0] < 6.0);
  CHECK(a1.at<uint8_t>(0, 0) == 0);
  CHECK(a1.at<uint8_t>(479, 639) == 0);
  // RenderStill agrees with the renderer.
  CHECK(Same(RenderStill(c.calib.sensor, c.map, c.poses[5], c.options), r.Render(c.poses[5], 0)));
}

TEST_CASE("presets: sizes, sensors, and at least 4 spread corners in view in every frame", "[presets]") {
  // The built-in sensors are the calib/ files.
  for (const auto& [name, built] : {std::make_pair(std::string("paper-real"), PaperRealCalibration()),
                                    std::make_pair(std::string("paper-synthetic"), PaperSyntheticCalibration())}) {
    const Calibration f = ReadCalibration(test::SourcePath("calib/" + name + ".yaml"));
    INFO(name);
    CHECK(f.sensor.image_width == built.sensor.image_width);
    CHECK(f.sensor.image_height == built.sensor.image_height);
    CHECK(f.sensor.params.focal_px == built.sensor.params.focal_px);
    CHECK(f.sensor.params.cx == built.sensor.params.cx);
    CHECK(f.sensor.params.cy == built.sensor.params.cy);
    CHECK(f.sensor.mirror_radius() == Approx(built.sensor.mirror_radius()));
    CHECK(f.sensor.mirror_distance() == Approx(built.sensor.mirror_distance()));
    CHECK(f.units == built.units);
  }
  const SequenceCase syn = MakePreset("paper-synthetic");
  CHECK(syn.poses.size() == 66);
  CHECK(syn.calib.sensor.image_width == 500);
  double horizon;
  REQUIRE(syn.calib.sensor.image_radius(1e7, 0.0, &horizon));
  CHECK(horizon == Approx(157.2).margin(0.3));
  const SequenceCase real = MakePreset("paper-real");
  CHECK(real.poses.size() == 57);
  CHECK(real.map.units == "cm");
  for (size_t i = 1; i < real.poses.size(); ++i) {
    const double step = std::hypot(real.poses[i].x - real.poses[i - 1].x, real.poses[i].y - real.poses[i - 1].y);
    CHECK(step == Approx(5.0).margin(0.05));  // the arc's chord is a hair shorter
  }
  CHECK(real.options.noise_sigma == Approx(3.0));
  CHECK(real.options.blur);
  const SequenceCase kid = MakePreset("kidnap");
  REQUIRE(kid.kidnap_frames.size() == 1);
  const Pose2 before = kid.poses[static_cast<size_t>(kid.kidnap_frames[0] - 1)];
  const Pose2 after = kid.poses[static_cast<size_t>(kid.kidnap_frames[0])];
  CHECK(std::hypot(after.x - before.x, after.y - before.y) > 20.0);
  CHECK(std::abs(WrapAngle(after.theta - before.theta)) > 1.0);
  const SequenceCase clu = MakePreset("cluttered");
  CHECK_FALSE(clu.map.distractors.empty());
  CHECK_FALSE(clu.map.boxes.empty());
  double mean_step = 0, mean_turn = 0;
  for (size_t i = 1; i < clu.poses.size(); ++i) {
    mean_step += std::hypot(clu.poses[i].x - clu.poses[i - 1].x, clu.poses[i].y - clu.poses[i - 1].y);
    mean_turn += std::abs(WrapAngle(clu.poses[i].theta - clu.poses[i - 1].theta));
  }
  mean_step /= clu.poses.size() - 1;
  mean_turn /= clu.poses.size() - 1;
  CHECK(mean_step > 3.0);
  CHECK(mean_turn * 180 / M_PI > 3.0);

  for (const std::string& name : PresetNames()) {
    const SequenceCase c = MakePreset(name);  // checks 25 units of clearance
    const Scene scene = Scene::FromMap(c.map, true);
    int min_seen = 1 << 30, occluded_frames = 0;
    double worst_gap = 0;
    const size_t all = MapCorners(c.map).size();
    for (size_t i = 0; i < c.poses.size(); ++i) {
      const std::vector<CornerView> v = VisibleCorners(c.calib.sensor, c.map, scene, c.poses[i]);
      INFO(name << " frame " << i);
      REQUIRE(v.size() >= 4);
      // Well spread: the largest gap between bearings is under 180 degrees.
      std::vector<double> b;
      for (const CornerView& view : v) b.push_back(view.bearing);
      std::sort(b.begin(), b.end());
      double gap = b.front() + 2 * M_PI - b.back();
      for (size_t k = 1; k < b.size(); ++k) gap = std::max(gap, b[k] - b[k - 1]);
      CHECK(gap < M_PI);
      worst_gap = std::max(worst_gap, gap);
      min_seen = std::min(min_seen, static_cast<int>(v.size()));
      // Corners hidden by map surfaces (not merely out of view).
      size_t hidden = 0;
      for (const MapCorner& mc : MapCorners(c.map)) {
        Eigen::Vector2d px;
        const Eigen::Vector3d ps = SensorFromWorld(c.poses[i], c.map.sensor_height, mc.world);
        Eigen::Vector3d o, d;
        if (!c.calib.sensor.project(ps, &px) || !c.calib.sensor.backproject(px, &o, &d)) continue;
        if (scene.Occluded(WorldFromSensor(c.poses[i], c.map.sensor_height, o), mc.world, 1e-6)) ++hidden;
      }
      if (hidden > 0) ++occluded_frames;
    }
    WARN(name << ": " << c.poses.size() << " frames, " << all << " map corners, at least " << min_seen
              << " in view per frame, widest bearing gap " << worst_gap * 180 / M_PI << " deg, frames with hidden corners "
              << occluded_frames);
    if (name == "cluttered") CHECK(occluded_frames > 0);
  }
}

TEST_CASE("sequence writer: gt.csv, map, calib, case, lossless frames", "[sequence]") {
  SequenceCase c = MakePreset("paper-synthetic");
  c.poses.resize(3);
  c.options.noise_sigma = 2.0;
  const std::string dir = test::ScratchDir("render_sequence") + "/out";
  SequenceWriteOptions wo;
  wo.frames = true;
  std::vector<std::pair<int, int>> progress;
  wo.on_progress = [&](int done, int total) { progress.emplace_back(done, total); };
  const SequenceWriteResult res = WriteSequence(c, dir, wo);
  CHECK(res.frames == 3);
  // Progress every tenth frame and at the last: here the last alone.
  CHECK(progress == std::vector<std::pair<int, int>>{{3, 3}});
  CHECK((res.codec == "h264" || res.codec == "mp4v"));
  for (const char* f : {"video.mp4", "gt.csv", "map.yaml", "calib.yaml", "case.yaml", "frames/frame_0002.png"})
    CHECK(fs::exists(dir + "/" + f));
  const std::vector<PoseRow> gt = ReadPoseCsv(dir + "/gt.csv");
  REQUIRE(gt.size() == 3);
  const Scene scene = Scene::FromMap(c.map, true);
  for (int i = 0; i < 3; ++i) {
    CHECK(gt[static_cast<size_t>(i)].frame == i);
    CHECK(gt[static_cast<size_t>(i)].status == PoseStatus::kOk);
    CHECK(gt[static_cast<size_t>(i)].pose.x == Approx(c.poses[static_cast<size_t>(i)].x).margin(1e-4));  // gt.csv: %.4f
    CHECK(gt[static_cast<size_t>(i)].n_landmarks ==
          static_cast<int>(VisibleCorners(c.calib.sensor, c.map, scene, c.poses[static_cast<size_t>(i)]).size()));
  }
  // Frames are exactly what the renderer makes.
  const Renderer r(c.calib.sensor, scene, c.map.sensor_height, c.options);
  CHECK(Same(cv::imread(dir + "/frames/frame_0002.png", cv::IMREAD_UNCHANGED), r.Render(c.poses[2], 2)));
  const Map m = ReadMap(dir + "/map.yaml");
  CHECK(m.rectangles.size() == c.map.rectangles.size());
  CHECK(ReadCalibration(dir + "/calib.yaml").sensor.params.focal_px == 590.0);
  // An existing, non-empty folder is refused; --force replaces it.
  CHECK_THROWS_WITH(WriteSequence(c, dir, wo), Catch::Contains("exists and is not empty"));
  wo.overwrite = true;
  wo.video = false;
  WriteSequence(c, dir, wo);
  CHECK_FALSE(fs::exists(dir + "/video.mp4"));
  CHECK(fs::exists(dir + "/frames/frame_0000.png"));
}

// The calibration board of the targets tests: 9 x 6 inner corners, 3 cm squares.
TargetBoard Board963() {
  TargetBoard board;
  board.cols = 9;
  board.rows = 6;
  board.square = 3.0;
  return board;
}

TEST_CASE("--auto board poses span the mirror from below its vertex to the limb", "[targets]") {
  // The design that lets unknown-pose calibration tell the focal length from
  // the mirror's size (docs/calibration.md): near boards, some above the
  // mirror, corners out to the limb, every azimuth.
  const Calibration calib = PaperRealCalibration();
  const TargetBoard board = Board963();
  const std::vector<BoardPose> poses = AutoBoardPoses(calib.sensor, board, 14, 1);
  REQUIRE(poses.size() == 14);
  const double limb = calib.sensor.limb_radius(), zv = calib.sensor.params.vertex_distance;
  int above = 0, below = 0;
  double r_max = 0.0;
  for (const BoardPose& p : poses) {
    const std::vector<Eigen::Vector3d> corners = BoardCornersSensor(board, p);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& X : corners) {
      centre += X / corners.size();
      Eigen::Vector2d px;
      REQUIRE(calib.sensor.project(X, &px));
      double r, az;
      calib.sensor.to_polar(px.x(), px.y(), &r, &az);
      r_max = std::max(r_max, r);
      CHECK(r < 0.98 * limb + 1e-9);
    }
    (centre.z() > zv ? above : below) += 1;
    // Near: within the mirror distance plus a board diagonal.
    CHECK(std::hypot(centre.x(), centre.y()) < calib.sensor.mirror_distance() + 40.0);
  }
  CHECK(above >= 4);
  CHECK(below >= 2);
  CHECK(r_max > 0.9 * limb);
}

TEST_CASE("chessboard targets: pattern convention, poses, files", "[targets]") {
  const Calibration calib = PaperRealCalibration();
  const TargetBoard board = Board963();
  const std::vector<BoardPose> poses = AutoBoardPoses(calib.sensor, board, 6, 7);
  REQUIRE(poses.size() == 6);
  RenderOptions o;
  const RayTable table(calib.sensor, 3);
  for (size_t i = 0; i < poses.size(); ++i) {
    CHECK(BoardFullyVisible(calib.sensor, board, poses[i]));
    const cv::Mat img = RenderBoard(table, board, poses[i], o, static_cast<int>(i));
    // Square centres: (-1, -1) black, (0, -1) white, (0, 0) black.
    auto grey_at = [&](double x, double y) {
      const Eigen::Matrix3d R = Eigen::AngleAxisd(Eigen::Vector3d(poses[i].rvec[0], poses[i].rvec[1], poses[i].rvec[2]).norm(),
                                                  Eigen::Vector3d(poses[i].rvec[0], poses[i].rvec[1], poses[i].rvec[2]).normalized())
                                    .toRotationMatrix();
      const Eigen::Vector3d p = R * Eigen::Vector3d(x * board.square, y * board.square, 0) +
                                Eigen::Vector3d(poses[i].tvec[0], poses[i].tvec[1], poses[i].tvec[2]);
      Eigen::Vector2d px;
      REQUIRE(calib.sensor.project(p, &px));
      return static_cast<int>(img.at<uint8_t>(static_cast<int>(std::lround(px.y())), static_cast<int>(std::lround(px.x()))));
    };
    INFO("image " << i);
    CHECK(grey_at(-0.5, -0.5) < 60);
    CHECK(grey_at(0.5, -0.5) > 180);
    CHECK(grey_at(0.5, 0.5) < 60);
    CHECK(grey_at(8.5, 5.5) > 180);  // square (8, 5): odd sum, white (10 x 7 squares)
    CHECK(grey_at(7.5, 5.5) < 60);
  }
  const std::string dir = test::ScratchDir("render_targets") + "/cal";
  o.noise_sigma = 2.0;
  WriteTargetImages(dir, calib, board, {poses[0], poses[1]}, o, TargetsWriteOptions{});
  const TargetSet known = ReadTargets(dir + "/targets.yaml");
  CHECK(known.AllPosesKnown());
  REQUIRE(known.images.size() == 2);
  CHECK(known.images[1].tvec[0] == Approx(poses[1].tvec[0]));
  CHECK(fs::exists(known.images[0].resolved));
  const TargetSet unknown = ReadTargets(dir + "/targets_unknown.yaml");
  CHECK_FALSE(unknown.images[0].has_pose);
  CHECK(ReadCalibration(dir + "/truth.yaml").sensor.params.focal_px == 590.0);
}

}  // namespace
}  // namespace pano

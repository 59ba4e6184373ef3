// The factors of real cameras and rooms (motion blur, auto-exposure, texture,
// people, covered and dropped frames) and the presets that combine them.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/render/sequence.h"
#include "panotrack/render/writers.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a != b) == 0;
}

double Deg(double rad) { return rad * 180.0 / M_PI; }

double Bilinear(const cv::Mat& img, const Eigen::Vector2d& px) {
  const int u = static_cast<int>(std::floor(px.x())), v = static_cast<int>(std::floor(px.y()));
  const double fu = px.x() - u, fv = px.y() - v;
  return (1 - fu) * (1 - fv) * img.at<float>(v, u) + fu * (1 - fv) * img.at<float>(v, u + 1) +
         (1 - fu) * fv * img.at<float>(v + 1, u) + fu * fv * img.at<float>(v + 1, u + 1);
}

// A few frames of the synthetic room with one ray per pixel (fast).
SequenceCase SmallCase(const std::vector<Pose2>& poses) {
  SequenceCase c = MakePreset("paper-synthetic");
  c.poses = poses;
  c.options.supersample = 1;
  return c;
}

TEST_CASE("motion blur of a still robot is the sharp render", "[motion_blur]") {
  const Pose2 p{80.0, 75.0, 0.4};
  SequenceCase c = SmallCase({p, p, p});
  c.options.supersample = 2;
  c.options.noise_sigma = 2.0;
  c.options.blur = true;
  c.options.exposure = 0.5;
  const SequenceRenderer sr(c);
  CHECK(sr.BlurSamples(1) == 1);
  for (int i = 0; i < 3; ++i) CHECK(Same(sr.RenderFrame(i), sr.renderer().Render(p, i)));
}

TEST_CASE("a blurred frame is the mean of the sharp renders at the sub-frame poses", "[motion_blur]") {
  // Uniform motion: 2 units and 5 degrees per frame.
  std::vector<Pose2> poses;
  for (int i = 0; i < 4; ++i) poses.push_back({70.0 + 2.0 * i, 70.0 + 0.5 * i, 0.2 + i * 5.0 * M_PI / 180.0});
  SequenceCase c = SmallCase(poses);
  c.options.exposure = 0.5;
  const SequenceRenderer sr(c);
  const int k = sr.BlurSamples(1);
  // Enough sub-frames for about 1 px at the rim: 2.5 degrees and 1 unit over the exposure.
  const double rim_px = 0.5 * (5.0 * M_PI / 180.0 + std::hypot(2.0, 0.5) / c.map.sensor_height) *
                        c.calib.sensor.limb_radius();
  CHECK(k == static_cast<int>(std::ceil(rim_px)));
  CHECK(k >= 4);
  const std::vector<Pose2> subs = sr.SubPoses(1);
  REQUIRE(static_cast<int>(subs.size()) == k);
  // Centred on the frame's time: the mid-exposure pose is the frame's pose.
  Pose2 mean{0, 0, 0};
  for (const Pose2& s : subs) {
    mean.x += s.x / k;
    mean.y += s.y / k;
    mean.theta += s.theta / k;
  }
  CHECK(mean.x == Approx(poses[1].x).margin(1e-9));
  CHECK(mean.y == Approx(poses[1].y).margin(1e-9));
  CHECK(mean.theta == Approx(poses[1].theta).margin(1e-9));
  CHECK(std::abs(WrapAngle(subs.back().theta - subs.front().theta)) ==
        Approx(0.5 * 5.0 * M_PI / 180.0 * (k - 1) / k).margin(1e-9));
  cv::Mat sum(c.calib.sensor.image_height, c.calib.sensor.image_width, CV_64FC1, cv::Scalar(0));
  for (size_t s = 0; s < subs.size(); ++s) {
    cv::Mat sharp;
    sr.renderer().Render(subs[s], 1).convertTo(sharp, CV_64FC1);
    sum += sharp / static_cast<double>(k);
  }
  cv::Mat blurred, diff;
  sr.RenderFrame(1).convertTo(blurred, CV_64FC1);
  cv::absdiff(blurred, sum, diff);
  double worst;
  cv::minMaxLoc(diff, nullptr, &worst);
  CHECK(worst <= 1.0);  // each sharp render and the mean are rounded once
  // And the blur is real: the frame differs from the sharp one.
  cv::Mat sharp1;
  sr.renderer().Render(poses[1], 1).convertTo(sharp1, CV_64FC1);
  cv::absdiff(blurred, sharp1, diff);
  cv::minMaxLoc(diff, nullptr, &worst);
  CHECK(worst > 20.0);
}

TEST_CASE("sub-frame poses: shortest arc, ends and kidnaps extrapolated from one neighbour", "[motion_blur]") {
  const std::vector<Pose2> poses = {{10, 10, 3.1}, {12, 10, -3.1}, {50, 50, 0.0}, {51, 50, 0.1}};
  const std::vector<int> kidnaps = {2};
  // Across +-pi along the shortest arc (0.083 rad per frame).
  const Pose2 a = PoseAtOffset(poses, 1, -0.5, kidnaps);
  CHECK(a.x == Approx(11.0));
  CHECK(WrapAngle(a.theta - (-3.1)) == Approx(-0.5 * WrapAngle(-3.1 - 3.1)));
  // Frame 1 has no next neighbour (the kidnap): its motion comes from frame 0.
  const Pose2 b = PoseAtOffset(poses, 1, 0.5, kidnaps);
  CHECK(b.x == Approx(13.0));
  // Frame 2 has no previous neighbour: extrapolated backwards from frame 3.
  const Pose2 c = PoseAtOffset(poses, 2, -0.5, kidnaps);
  CHECK(c.x == Approx(49.5));
  CHECK(c.theta == Approx(-0.05));
  // The first and last frames.
  CHECK(PoseAtOffset(poses, 0, -0.25, kidnaps).x == Approx(9.5));
  CHECK(PoseAtOffset(poses, 3, 0.25, kidnaps).x == Approx(51.25));
  CHECK(PoseAtOffset(poses, 3, 0.0, kidnaps).x == 51.0);
}

TEST_CASE("auto-exposure gain: deterministic, within bounds, drifting and stepping", "[factors]") {
  RenderOptions o;
  for (int i = 0; i < 50; ++i) CHECK(AutoExposureGain(o, i) == 1.0);
  o.auto_exposure = 0.2;
  o.seed = 7;
  std::vector<double> g;
  for (int i = 0; i < 300; ++i) g.push_back(AutoExposureGain(o, i));
  int steps = 0;
  for (int i = 0; i < 300; ++i) {
    CHECK(g[static_cast<size_t>(i)] == AutoExposureGain(o, i));
    CHECK(g[static_cast<size_t>(i)] >= 0.8);
    CHECK(g[static_cast<size_t>(i)] <= 1.2);
    // The drift changes the gain by at most 0.2 * 0.5 * 2 pi / 150 per frame; larger changes are steps.
    if (i > 0 && std::abs(g[static_cast<size_t>(i)] - g[static_cast<size_t>(i - 1)]) > 0.0045) ++steps;
  }
  CHECK(steps >= 3);  // every 40..80 frames
  CHECK(steps <= 8);
  CHECK(*std::max_element(g.begin(), g.end()) - *std::min_element(g.begin(), g.end()) > 0.1);
  RenderOptions other = o;
  other.seed = 8;
  CHECK(AutoExposureGain(other, 100) != g[100]);
}

TEST_CASE("texture is fixed to the world: a floor point keeps its shade from two poses", "[factors]") {
  SequenceCase c = MakePreset("paper-synthetic");
  c.options.supersample = 1;
  c.options.texture = 0.3;
  RenderOptions plain = c.options;
  plain.texture = 0.0;
  const Scene scene = Scene::FromMap(c.map, true);
  const Renderer textured(c.calib.sensor, scene, c.map.sensor_height, c.options);
  const Renderer untextured(c.calib.sensor, scene, c.map.sensor_height, plain);
  const Eigen::Vector3d extent = scene.max() - scene.min();
  const double wavelength = 0.06 * std::max(extent.x(), extent.y());
  const Pose2 poses[2] = {{70, 70, 0.0}, {90, 78, 1.2}};
  cv::Mat ratio[2];
  for (int k = 0; k < 2; ++k) {
    cv::Mat a(500, 500, CV_32FC1, cv::Scalar(0)), b(500, 500, CV_32FC1, cv::Scalar(0));
    textured.Accumulate(poses[k], 1.0, {}, true, &a);
    untextured.Accumulate(poses[k], 1.0, {}, true, &b);
    cv::divide(a, cv::Mat(cv::max(b, 1e-3)), ratio[k]);
  }
  int checked = 0, strong = 0;
  double worst = 0.0;
  for (double x = 60; x <= 100; x += 2.5) {
    for (double y = 60; y <= 90; y += 2.5) {
      const Eigen::Vector3d w(x, y, 0.0);  // on the floor
      const double expected = 1.0 + 0.3 * SurfaceTexture(w, wavelength);
      double seen[2];
      bool ok = true;
      for (int k = 0; k < 2 && ok; ++k) {
        Eigen::Vector2d px;
        ok = c.calib.sensor.project(SensorFromWorld(poses[k], c.map.sensor_height, w), &px) &&
             c.calib.sensor.inside_image(px, 2.0);
        // The ratio is smooth: interpolated between pixel centres (integer coordinates).
        if (ok) seen[k] = Bilinear(ratio[k], px);
      }
      if (!ok) continue;
      INFO("floor point " << x << ", " << y);
      // Within half a pixel's footprint of the smooth pattern.
      CHECK(seen[0] == Approx(expected).margin(0.01));
      CHECK(seen[1] == Approx(seen[0]).margin(0.01));
      worst = std::max({worst, std::abs(seen[0] - expected), std::abs(seen[1] - seen[0])});
      ++checked;
      if (std::abs(expected - 1.0) > 0.15) ++strong;
    }
  }
  WARN("texture: " << checked << " floor points, " << strong << " with |t| > 0.5, worst difference " << worst);
  CHECK(checked > 100);
  CHECK(strong > 20);
}

TEST_CASE("people walk clear of the sensor, occlude landmarks and are not in the map", "[factors]") {
  SequenceCase c = MakePreset("fast-turns");
  c.poses.resize(60);
  c.options.people = 2;
  c.options.supersample = 1;
  const SequenceRenderer sr(c);
  REQUIRE(sr.people().size() == 2);
  const int n_scene = static_cast<int>(sr.scene().surfaces().size());
  const double size = 220.0;
  CHECK(sr.people()[0].radius == Approx(0.02 * size));
  CHECK(sr.people()[0].speed == Approx(0.01 * size));
  int frames_occluded = 0;
  for (int i = 0; i < 60; i += 6) {
    const Pose2& p = c.poses[static_cast<size_t>(i)];
    for (const Person& person : sr.people()) {
      const Eigen::Vector2d q = PersonPosition(person, i, {p.x, p.y}, sr.people_clearance());
      CHECK((q - Eigen::Vector2d(p.x, p.y)).norm() >= sr.people_clearance() - 1e-9);
      CHECK(q.x() > 0.0);
      CHECK(q.x() < 220.0);
    }
    const std::vector<Surface> extra = PeopleSurfaces(sr.people(), i, {p.x, p.y}, sr.people_clearance());
    CHECK(extra.size() == 10);
    const cv::Mat with = sr.renderer().SurfaceIds(p, extra), without = sr.renderer().SurfaceIds(p);
    const int person_pixels = cv::countNonZero(with >= n_scene);
    CHECK(cv::countNonZero(with != without) == person_pixels);
    // Pixels where a person hides a landmark rectangle.
    int hidden = 0;
    for (int v = 0; v < with.rows; ++v)
      for (int u = 0; u < with.cols; ++u) {
        const int s = without.at<int>(v, u);
        if (with.at<int>(v, u) >= n_scene && s >= 0 && sr.scene().surfaces()[static_cast<size_t>(s)].kind == SurfaceKind::kRectangle)
          ++hidden;
      }
    if (hidden > 0) ++frames_occluded;
  }
  CHECK(frames_occluded >= 2);
  // The written map has no people.
  c.poses.resize(3);
  const std::string dir = test::ScratchDir("render_people") + "/out";
  SequenceWriteOptions wo;
  wo.video = false;
  wo.frames = true;
  WriteSequence(c, dir, wo);
  const Map m = ReadMap(dir + "/map.yaml");
  CHECK(m.rectangles.size() == c.map.rectangles.size());
  CHECK(m.boxes.size() == c.map.boxes.size());
  CHECK(m.distractors.empty());
}

TEST_CASE("dropped frames: gt.csv rows match the video's frames; covered frames are dark", "[factors]") {
  std::vector<Pose2> poses;
  for (int i = 0; i < 16; ++i) poses.push_back({60.0 + 3.0 * i, 70.0, 0.1 * i});
  SequenceCase c = SmallCase(poses);
  c.options.dropped_frames = 3;
  c.options.covered_frames = 2;
  c.options.noise_sigma = 1.0;
  const SequenceRenderer sr(c);
  const std::vector<int> dropped = sr.dropped(), covered = sr.covered();
  REQUIRE(dropped.size() == 3);
  REQUIRE(covered.size() == 2);
  for (int f : dropped) CHECK(f >= 5);
  for (int f : covered) {
    CHECK(f >= 5);
    CHECK_FALSE(sr.Dropped(f));
  }
  const std::string dir = test::ScratchDir("render_dropped") + "/out";
  SequenceWriteOptions wo;
  wo.frames = true;
  const SequenceWriteResult res = WriteSequence(c, dir, wo);
  CHECK(res.frames == 13);
  const std::vector<PoseRow> gt = ReadPoseCsv(dir + "/gt.csv");
  REQUIRE(gt.size() == 13);
  cv::VideoCapture video(dir + "/video.mp4");
  REQUIRE(video.isOpened());
  int video_frames = 0;
  cv::Mat img;
  while (video.read(img)) ++video_frames;
  CHECK(video_frames == 13);
  const cv::Mat mask = sr.renderer().MirrorMask();
  int row = 0;
  for (int i = 0; i < 16; ++i) {
    if (sr.Dropped(i)) continue;
    const PoseRow& r = gt[static_cast<size_t>(row)];
    INFO("frame " << i << ", video frame " << row);
    CHECK(r.frame == row);
    CHECK(r.time_s == Approx(i / c.fps));
    CHECK(r.pose.x == Approx(poses[static_cast<size_t>(i)].x).margin(1e-4));
    char name[64];
    std::snprintf(name, sizeof(name), "/frames/frame_%04d.png", row);
    const cv::Mat frame = cv::imread(dir + name, cv::IMREAD_UNCHANGED);
    CHECK(Same(frame, sr.RenderFrame(i)));
    const double mean = cv::mean(frame, mask)[0];
    if (sr.Covered(i)) CHECK(mean < 0.5 * cv::mean(sr.renderer().Render(poses[static_cast<size_t>(i)], i), mask)[0]);
    else CHECK(Same(frame, sr.renderer().Render(poses[static_cast<size_t>(i)], i)));
    ++row;
  }
  // Too many to fit is an error naming the option.
  c.options.dropped_frames = 6;
  CHECK_THROWS_WITH(CheckCase(c, "case"), Catch::Contains("dropped-frames"));
}

TEST_CASE("the presets of real conditions: frames, speeds, turns and kidnaps", "[presets]") {
  const SequenceCase ft = MakePreset("fast-turns");  // passes CheckCase with 25 cm clearance
  REQUIRE(ft.poses.size() == 300);
  CHECK(ft.map.units == "cm");
  CHECK(ft.options.noise_sigma == 4.0);
  CHECK(ft.options.blur);
  CHECK(ft.options.exposure == 0.0);
  double max_turn = 0, min_step = 1e9, max_step = 0;
  for (size_t i = 1; i < ft.poses.size(); ++i) {
    max_turn = std::max(max_turn, std::abs(WrapAngle(ft.poses[i].theta - ft.poses[i - 1].theta)));
    const double step = std::hypot(ft.poses[i].x - ft.poses[i - 1].x, ft.poses[i].y - ft.poses[i - 1].y);
    min_step = std::min(min_step, step);
    max_step = std::max(max_step, step);
  }
  CHECK(Deg(max_turn) == Approx(8.0).margin(0.01));
  CHECK(min_step == Approx(1.2).margin(0.01));
  CHECK(max_step == Approx(2.5).margin(0.01));
  const SequenceCase mb = MakePreset("motion-blur");
  CHECK(mb.poses.size() == 300);
  CHECK(mb.poses[123].theta == ft.poses[123].theta);
  CHECK(mb.options.exposure == 0.5);
  {
    const SequenceRenderer sr(mb);
    int k_min = 1 << 30, k_max = 0;
    double k_mean = 0.0;
    for (int i = 0; i < sr.frames(); ++i) {
      const int k = sr.BlurSamples(i);
      k_min = std::min(k_min, k);
      k_max = std::max(k_max, k);
      k_mean += static_cast<double>(k) / sr.frames();
    }
    WARN("motion-blur: " << k_min << ".." << k_max << " sub-frames per frame, mean " << k_mean
                         << "; rim radius " << mb.calib.sensor.limb_radius() << " px");
    CHECK(k_min == 4);  // 1.2 cm and little turning: about 4 px at the rim over the exposure
    CHECK(k_max == 19);  // 8 degrees and 2.5 cm per frame
  }
  const SequenceCase rc = MakePreset("real-conditions");
  CHECK(rc.poses.size() == 300);
  CHECK(rc.options.exposure == 0.5);
  CHECK(rc.options.auto_exposure == 0.2);
  CHECK(rc.options.texture == 0.1);
  CHECK(rc.options.people == 2);
  CHECK(DroppedFrames(rc.options, 300).size() == 3);
  CHECK(CoveredFrames(rc.options, 300).size() == 3);

  for (const std::string name : {"long-run", "long-run-blur"}) {
    const SequenceCase lr = MakePreset(name);
    INFO(name);
    REQUIRE(lr.poses.size() == 3000);
    REQUIRE(lr.kidnap_frames == std::vector<int>({1000, 2000}));
    CHECK(lr.options.exposure == (name == "long-run" ? 0.0 : 0.5));
    double turn = 0, step = 0;
    for (size_t i = 1; i < lr.poses.size(); ++i) {
      const double dt = std::abs(WrapAngle(lr.poses[i].theta - lr.poses[i - 1].theta));
      const double ds = std::hypot(lr.poses[i].x - lr.poses[i - 1].x, lr.poses[i].y - lr.poses[i - 1].y);
      if (i == 1000 || i == 2000) {
        CHECK(ds > 40.0);
        CHECK(Deg(dt) > 80.0);
        CHECK(Deg(dt) < 120.0);
        continue;
      }
      turn = std::max(turn, dt);
      step = std::max(step, ds);
    }
    CHECK(Deg(turn) == Approx(10.0).margin(1e-6));
    CHECK(step <= 2.0 + 1e-9);
  }
}

}  // namespace
}  // namespace pano

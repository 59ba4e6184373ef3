// The localiser's parts: landmarks and their prediction, the step detector,
// the visual compass, relocalisation, and the accuracy summary.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <set>
#include <string>

#include "panotrack/core/error.h"
#include "test_rng.h"
#include "panotrack/track/compass.h"
#include "panotrack/track/edge_profile.h"
#include "panotrack/track/junction_tracker.h"
#include "panotrack/track/relocalize.h"
#include "track_fixture.h"

namespace pano {
namespace {

Map OneRoom() {
  Map m;
  m.sensor_height = 30;
  m.room.present = true;
  m.room.min = {0, 0};
  m.room.max = {200, 200};
  m.room.height = 120;
  m.rectangles.push_back({"door", {0.5, 50}, {0.5, 90}, 0, 100, 0.1});
  m.boxes.push_back({"crate", {120, 40, 0}, {150, 70, 45}, 0.9});
  return m;
}

// Decoded video frames share the decoder's buffer, whose rows are padded:
// a frame with padded rows reads as its continuous copy does.
cv::Mat WithPaddedRows(const cv::Mat& frame, int padding) {
  cv::Mat wide(frame.rows, frame.cols + padding, CV_8UC1, cv::Scalar(255));
  frame.copyTo(wide(cv::Rect(0, 0, frame.cols, frame.rows)));
  return wide(cv::Rect(0, 0, frame.cols, frame.rows));
}

TEST_CASE("landmarks: ids, prediction geometry, polarity, box silhouettes, occlusion", "[landmarks]") {
  const Map m = OneRoom();
  const std::vector<Landmark> lms = LandmarksFromMap(m);
  CHECK(lms.size() == 4 + 8 * 2);
  CHECK(lms[0].id == "door/from-bottom");
  CHECK(lms[3].id == "door/to-top");
  const Sensor s = MakeSphereSensor(500, 500, 590, 249.5, 249.5, 1.0, 4.9, 15.1);
  const Scene scene = Scene::FromMap(m, false);
  const RadiusTable table = RadiusTable::Build(s, RangesForMap(m, s));
  const Pose2 pose{60, 110, 0.3};
  const std::vector<PredictedLandmark> pred = PredictLandmarks(lms, m, scene, s, table, pose, PredictionOptions());
  int doors = 0;
  for (const PredictedLandmark& p : pred) {
    const Landmark& l = *p.landmark;
    // The corner's predicted pixel is its exact projection (table: measured 4.6e-5 px).
    Eigen::Vector2d px;
    REQUIRE(s.project(SensorFromWorld(pose, m.sensor_height, l.corner), &px));
    CHECK((px - p.corner_px).norm() < 1.5e-4);
    if (l.id.rfind("door/", 0) == 0) {
      ++doors;
      CHECK(p.v_polarity == -1);  // a dark door on a lighter wall
      // Top corners: the face lies below, at smaller radius.
      CHECK(p.inside_radius_sign == (l.id.find("top") != std::string::npos ? -1 : 1));
    }
    if (l.box) {
      // Box corners: silhouette vertical edges only, on faces seen by the camera.
      const Eigen::Vector2d to_cam = Eigen::Vector2d(pose.x, pose.y) - l.corner.head<2>();
      CHECK(to_cam.dot(l.face_normal) > 0);
      CHECK(to_cam.dot(l.other_face_normal) <= 0);
    }
  }
  CHECK(doors == 4);
  // From behind the crate, the door... is still visible; the crate's far
  // corners are hidden by its own faces.
  const Pose2 behind{180, 55, M_PI};
  for (const PredictedLandmark& p : PredictLandmarks(lms, m, scene, s, table, behind, PredictionOptions()))
    CHECK(p.landmark->id.find("x0") == std::string::npos);  // the x = 120 side faces away
  // SelectSpread puts N spread over the circle first (one per third of the
  // circle where the thirds hold landmarks), and keeps the rest after them.
  const std::vector<PredictedLandmark> ordered = SelectSpread(pred, 3);
  REQUIRE(ordered.size() == pred.size());
  std::set<int> thirds_with_landmarks, thirds_chosen;
  for (const PredictedLandmark& p : pred)
    thirds_with_landmarks.insert(std::min(2, static_cast<int>((p.azimuth + M_PI) / (2 * M_PI) * 3)));
  for (size_t i = 0; i < std::min<size_t>(3, ordered.size()); ++i)
    thirds_chosen.insert(std::min(2, static_cast<int>((ordered[i].azimuth + M_PI) / (2 * M_PI) * 3)));
  CHECK(thirds_chosen.size() == std::min<size_t>(3, thirds_with_landmarks.size()));
}

TEST_CASE("landmarks: a door measured a little behind its wall is seen within the survey's tolerance",
          "[landmarks]") {
  Map m = OneRoom();
  m.rectangles[0].from.x() = m.rectangles[0].to.x() = -1.0;  // 1 unit behind the wall x = 0
  const std::vector<Landmark> lms = LandmarksFromMap(m);
  const Sensor s = MakeSphereSensor(500, 500, 590, 249.5, 249.5, 1.0, 4.9, 15.1);
  const Scene scene = Scene::FromMap(m, false);
  const RadiusTable table = RadiusTable::Build(s, RangesForMap(m, s));
  const Pose2 pose{60, 110, 0.3};
  auto doors = [&](const PredictionOptions& o) {
    int n = 0;
    for (const PredictedLandmark& p : PredictLandmarks(lms, m, scene, s, table, pose, o))
      n += p.landmark->id.rfind("door/", 0) == 0;
    return n;
  };
  PredictionOptions measured;
  CHECK(doors(measured) == 0);  // an exact map's prediction: hidden by the wall
  measured.surface_tolerance = 1.5;
  CHECK(doors(measured) == 4);
  measured.surface_tolerance = 0.9;  // further behind than the tolerance
  CHECK(doors(measured) == 0);
  measured.surface_tolerance = -1.0;
  CHECK_THROWS_AS(measured.Check(), Error);
}

TEST_CASE("landmarks: a wall passed closer than two mirror distances keeps its corners", "[landmarks]") {
  // The door's wall 24.5 and 27.5 units away, the sensor's mirror distance
  // 15.1: the door's horizontal edges, whose lines pass that near, come
  // from the E(D,Z) table, which reaches one mirror distance; the room-wide
  // search's options (lines from two) leave them out.
  const Map m = OneRoom();
  const std::vector<Landmark> lms = LandmarksFromMap(m);
  const Sensor s = MakeSphereSensor(500, 500, 590, 249.5, 249.5, 1.0, 4.9, 15.1);
  const Scene scene = Scene::FromMap(m, false);
  const RadiusTable table = RadiusTable::Build(s, RangesForMap(m, s));
  CHECK(table.ranges().d_min <= s.mirror_distance());
  PredictionOptions search;
  search.min_line_distance_mirrors = 2.0;
  for (const double x : {25.0, 28.0}) {
    const Pose2 pose{x, 70, 0.4};
    auto doors = [&](const PredictionOptions& o) {
      std::set<std::string> ids;
      for (const PredictedLandmark& p : PredictLandmarks(lms, m, scene, s, table, pose, o)) {
        if (p.landmark->id.rfind("door/", 0) != 0) continue;
        ids.insert(p.landmark->id);
        Eigen::Vector2d px;
        REQUIRE(s.project(SensorFromWorld(pose, m.sensor_height, p.landmark->corner), &px));
        CHECK((px - p.corner_px).norm() < 1e-3);
      }
      return ids;
    };
    INFO("robot at x = " << x);
    CHECK(doors(PredictionOptions()) == std::set<std::string>{"door/from-bottom", "door/to-bottom"});
    CHECK(doors(search).empty());
  }
  // A corner nearer than PredictionOptions::min_distance_mirrors (30.2
  // units: a panel's corner level with the sensor, in view) is left out.
  Map panel = m;
  panel.rectangles[0].z0 = 20;
  panel.rectangles[0].z1 = 45;
  const std::vector<Landmark> panel_lms = LandmarksFromMap(panel);
  const Scene panel_scene = Scene::FromMap(panel, false);
  const Pose2 beside{25, 60, 0.4};
  auto panel_corners = [&](const PredictionOptions& o) {
    std::set<std::string> ids;
    for (const PredictedLandmark& p : PredictLandmarks(panel_lms, panel, panel_scene, s, table, beside, o))
      if (p.landmark->id.rfind("door/", 0) == 0) ids.insert(p.landmark->id);
    return ids;
  };
  PredictionOptions all;
  all.min_distance_mirrors = 0.0;
  CHECK(panel_corners(all).count("door/from-bottom") == 1);
  CHECK(panel_corners(PredictionOptions()).count("door/from-bottom") == 0);
  CHECK(panel_corners(PredictionOptions()).count("door/to-bottom") == 1);
  for (double PredictionOptions::*field : {&PredictionOptions::min_distance_mirrors,
                                            &PredictionOptions::min_line_distance_mirrors,
                                            &PredictionOptions::spread_line_distance_mirrors}) {
    PredictionOptions bad;
    bad.*field = -1.0;
    CHECK_THROWS_AS(bad.Check(), Error);
  }
}

// OneRoom with what predicting its landmarks needs.
struct SpreadRoom {
  Map m = OneRoom();
  std::vector<Landmark> lms = LandmarksFromMap(m);
  Sensor s = MakeSphereSensor(500, 500, 590, 249.5, 249.5, 1.0, 4.9, 15.1);
  Scene scene = Scene::FromMap(m, false);
  RadiusTable table = RadiusTable::Build(s, RangesForMap(m, s));
  PredictionOptions options;
  // A random pose in the room, nullopt where it is not free.
  std::optional<Pose2> RandomPose(std::mt19937_64& rng) const {
    std::uniform_real_distribution<double> xy(5.0, 195.0), heading(-M_PI, M_PI);
    const Pose2 pose{xy(rng), xy(rng), heading(rng)};
    if (!m.IsFree(pose.x, pose.y)) return std::nullopt;
    return pose;
  }
  std::vector<PredictedLandmark> All(const Pose2& pose) const {
    return PredictLandmarks(lms, m, scene, s, table, pose, options);
  }
  SpreadPrediction Spread(const Pose2& pose, int max_count, int partners = 0) const {
    return SpreadPrediction(lms, m, scene, s, table, pose, options, max_count, partners);
  }
  // The horizontal distance from `pose` to the line of l's horizontal edge.
  static double LineDistance(const Landmark& l, const Pose2& pose) {
    const Eigen::Vector2d c = l.corner.head<2>() - Eigen::Vector2d(pose.x, pose.y);
    const Eigen::Vector2d dir = (l.h_end - l.corner).head<2>().normalized();
    return (c - c.dot(dir) * dir).norm();
  }
};

TEST_CASE("landmarks: SpreadPrediction is SelectSpread(PredictLandmarks) in two parts", "[landmarks]") {
  PANO_SEEDED_RNG(11);
  SpreadRoom room;
  room.options.spread_line_distance_mirrors = 0.0;  // every landmark takes part in the spread
  auto same = [](const PredictedLandmark& a, const PredictedLandmark& b) {
    return a.index == b.index && a.corner_px == b.corner_px && a.azimuth == b.azimuth && a.v_radius == b.v_radius &&
           a.r_main == b.r_main && a.theta_main == b.theta_main && a.v_polarity == b.v_polarity &&
           a.h_polarity == b.h_polarity && a.map_v_polarity == b.map_v_polarity;
  };
  int with_rest = 0, short_lists = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const std::optional<Pose2> at = room.RandomPose(rng);
    if (!at) continue;
    const Pose2& pose = *at;
    const std::vector<PredictedLandmark> all = room.All(pose);
    for (int max_count : {0, 3, 5, 12, 100}) {
      INFO("pose " << pose.x << " " << pose.y << " " << pose.theta << ", max_count " << max_count);
      const std::vector<PredictedLandmark> expected = SelectSpread(all, max_count);
      SpreadPrediction prediction = room.Spread(pose, max_count);
      std::vector<PredictedLandmark> got = prediction.First();
      CHECK(got.size() == (max_count > 0 ? std::min<size_t>(max_count, all.size()) : all.size()));
      CHECK(prediction.HasMore() == (got.size() < expected.size()));
      with_rest += prediction.HasMore();
      short_lists += max_count > 0 && all.size() <= static_cast<size_t>(max_count);
      const std::vector<PredictedLandmark> rest = prediction.Rest();
      got.insert(got.end(), rest.begin(), rest.end());
      REQUIRE(got.size() == expected.size());
      for (size_t i = 0; i < got.size(); ++i) CHECK(same(got[i], expected[i]));
    }
  }
  // Both of SelectSpread's cases were met: a list longer than max_count
  // (spread), and one no longer (landmark order).
  CHECK(with_rest > 20);
  CHECK(short_lists > 20);
}

TEST_CASE("landmarks: landmarks whose horizontal edges pass near are tracked besides the spread, not in it",
          "[landmarks]") {
  PANO_SEEDED_RNG(13);
  const SpreadRoom room;
  const double near = room.options.spread_line_distance_mirrors * room.s.mirror_distance();
  REQUIRE(near > 0.0);
  int with_near = 0;
  for (int trial = 0; trial < 120; ++trial) {
    const std::optional<Pose2> at = room.RandomPose(rng);
    if (!at) continue;
    const Pose2& pose = *at;
    const std::vector<PredictedLandmark> all = room.All(pose);
    std::vector<PredictedLandmark> far, near_lines;
    for (const PredictedLandmark& p : all)
      (SpreadRoom::LineDistance(*p.landmark, pose) < near ? near_lines : far).push_back(p);
    std::stable_sort(near_lines.begin(), near_lines.end(),
                     [](const PredictedLandmark& a, const PredictedLandmark& b) { return a.distance < b.distance; });
    for (int max_count : {3, 5}) {
      INFO("pose " << pose.x << " " << pose.y << " " << pose.theta << ", max_count " << max_count);
      SpreadPrediction prediction = room.Spread(pose, max_count);
      std::vector<PredictedLandmark> got = prediction.First();
      const std::vector<PredictedLandmark> got_near = prediction.NearLines();
      if (!prediction.HasMore()) {
        // No more than max_count of the others: First() holds every one.
        CHECK(got_near.empty());
        CHECK(got.size() == all.size());
        continue;
      }
      const std::vector<PredictedLandmark> expected = SelectSpread(far, max_count);
      const std::vector<PredictedLandmark> rest = prediction.Rest();
      got.insert(got.end(), rest.begin(), rest.end());
      REQUIRE(got.size() == expected.size());
      for (size_t i = 0; i < got.size(); ++i) CHECK(got[i].index == expected[i].index);
      REQUIRE(got_near.size() == near_lines.size());
      for (size_t i = 0; i < got_near.size(); ++i) CHECK(got_near[i].index == near_lines[i].index);
      with_near += !got_near.empty();
    }
  }
  CHECK(with_near > 5);
}

TEST_CASE("landmarks: SpreadPrediction's partners are the other corners of the nearest chosen edges",
          "[landmarks]") {
  PANO_SEEDED_RNG(12);
  const SpreadRoom room;
  // b is the corner at the other end of a's vertical edge.
  auto other_end = [](const PredictedLandmark& a, const PredictedLandmark& b) {
    return (a.landmark->v_end - b.landmark->corner).squaredNorm() < 1e-12;
  };
  auto in = [](const std::vector<PredictedLandmark>& list, int index) {
    return std::any_of(list.begin(), list.end(), [&](const PredictedLandmark& p) { return p.index == index; });
  };
  constexpr int kMaxCount = 5, kPartners = 2;
  int with_partners = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const std::optional<Pose2> at = room.RandomPose(rng);
    if (!at) continue;
    const Pose2& pose = *at;
    const std::vector<PredictedLandmark> all = room.All(pose);
    SpreadPrediction plain = room.Spread(pose, kMaxCount);
    SpreadPrediction paired = room.Spread(pose, kMaxCount, kPartners);
    const std::vector<PredictedLandmark> chosen = plain.First();
    INFO("pose " << pose.x << " " << pose.y << " " << pose.theta);
    // The first part and the rest as without partners.
    const std::vector<PredictedLandmark> first = paired.First(), rest = paired.Rest(), plain_rest = plain.Rest();
    REQUIRE(first.size() == chosen.size());
    for (size_t i = 0; i < first.size(); ++i) CHECK(first[i].index == chosen[i].index);
    REQUIRE(rest.size() == plain_rest.size());
    for (size_t i = 0; i < rest.size(); ++i) CHECK(rest[i].index == plain_rest[i].index);
    CHECK(plain.Partners().empty());
    const std::vector<PredictedLandmark> partners = paired.Partners();
    if (!plain.HasMore()) {
      CHECK(partners.empty());
      continue;
    }
    // The partners expected: of the chosen, nearest first, each that has
    // the other end of its vertical edge visible and not chosen, that
    // corner; up to kPartners.
    std::vector<PredictedLandmark> by_distance = chosen;
    std::stable_sort(by_distance.begin(), by_distance.end(),
                     [](const PredictedLandmark& a, const PredictedLandmark& b) { return a.distance < b.distance; });
    std::vector<int> expected;
    for (const PredictedLandmark& c : by_distance) {
      if (static_cast<int>(expected.size()) == kPartners) break;
      const auto end = std::find_if(all.begin(), all.end(), [&](const PredictedLandmark& p) {
        return other_end(c, p) && !in(chosen, p.index) &&
               std::find(expected.begin(), expected.end(), p.index) == expected.end();
      });
      if (end != all.end()) expected.push_back(end->index);
    }
    REQUIRE(partners.size() == expected.size());
    for (size_t i = 0; i < partners.size(); ++i) CHECK(partners[i].index == expected[i]);
    with_partners += !partners.empty();
  }
  CHECK(with_partners > 10);
}

TEST_CASE("linear samples: the vector path gives the scalar blend's bits", "[edge_step]") {
  PANO_SEEDED_RNG(5);
  cv::Mat image(60, 90, CV_8UC1);
  cv::randu(image, 0, 256);
  const cv::Mat padded = WithPaddedRows(image, 7);
  std::uniform_real_distribution<double> x(0.0, 88.99), y(0.0, 58.99);
  std::uniform_int_distribution<int> count(1, 70);
  for (int trial = 0; trial < 400; ++trial) {
    // Lines anywhere, the last rows included (read without gathers).
    const double ay = y(rng), ax = x(rng), by = y(rng), bx = x(rng);  // (drawn in a set order: a call's argument order is the compiler's)
    const Eigen::Vector2d a(ax, ay), b(bx, by);
    const int n = count(rng);
    const Eigen::Vector2d step = n > 1 ? Eigen::Vector2d((b - a) / (n - 1)) : Eigen::Vector2d(0.3, 0.1);
    float got[80], got_padded[80];
    REQUIRE(SampleLine(image, a, step, n, got));
    REQUIRE(SampleLine(padded, a, step, n, got_padded));
    for (int k = 0; k < n; ++k) {
      // The blend in float, as SampleLine documents it.
      const float px = static_cast<float>(a.x()) + static_cast<float>(k) * static_cast<float>(step.x());
      const float py = static_cast<float>(a.y()) + static_cast<float>(k) * static_cast<float>(step.y());
      const int ix = std::clamp(static_cast<int>(px), 0, image.cols - 2);
      const int iy = std::clamp(static_cast<int>(py), 0, image.rows - 2);
      const float fx = px - static_cast<float>(ix), fy = py - static_cast<float>(iy);
      const float p00 = image.at<uchar>(iy, ix), p01 = image.at<uchar>(iy, ix + 1);
      const float p10 = image.at<uchar>(iy + 1, ix), p11 = image.at<uchar>(iy + 1, ix + 1);
      const float expected = (1 - fy) * ((1 - fx) * p00 + fx * p01) + fy * ((1 - fx) * p10 + fx * p11);
      INFO("trial " << trial << " sample " << k << " of " << n);
      CHECK(got[k] == expected);
      CHECK(got_padded[k] == expected);
    }
  }
  float none[2];
  CHECK_FALSE(SampleLine(image, {10, 58.5}, {0, 1}, 2, none));  // the second sample falls outside
}

TEST_CASE("step detector: of equal steps, the first", "[edge_step]") {
  // Two identical steps (and falls between them): whichever part of the
  // profile each lies in, the first one is found.
  for (int n : {29, 40, 47, 61}) {
    for (int first = 6; first < n / 2 - 4; ++first) {
      const int second = first + (n - first) / 2;
      std::vector<float> p(static_cast<size_t>(n));
      for (int i = 0; i < n; ++i) p[static_cast<size_t>(i)] = (i >= first && i < second - 3) || i >= second ? 150.0f : 50.0f;
      StepEdge e;
      INFO("n " << n << ", steps at " << first << " and " << second);
      if (!FindStep(p.data(), n, +1, 4, 12.0, &e)) continue;  // too near an end for the plateaus
      CHECK(std::abs(e.location - (first - 0.5)) < 0.01);
    }
  }
}

TEST_CASE("step detector: sub-sample location of blurred steps, polarity, threshold", "[edge_step]") {
  PANO_SEEDED_RNG(3);
  std::uniform_real_distribution<double> pos(10.0, 20.0);
  for (int trial = 0; trial < 200; ++trial) {
    const double edge = pos(rng);  // in samples
    float p[33];
    for (int i = 0; i < 33; ++i) p[i] = static_cast<float>(60 + 100 / (1 + std::exp(-(i - edge) / 1.2)));
    StepEdge e;
    REQUIRE(FindStep(p, 33, +1, 4, 12.0, &e));
    // 0.1 sample = 0.05 px at panoloc's 0.5 px sampling: linear interpolation
    // of the midpoint crossing on a sigmoid is off by up to ~0.06 sample.
    CHECK(std::abs(e.location - edge) < 0.1);
    CHECK(e.strength > 80);
    CHECK_FALSE(FindStep(p, 33, -1, 4, 12.0, &e));  // wrong polarity
    CHECK_FALSE(FindStep(p, 33, +1, 4, 150.0, &e)); // below the threshold
  }
}

TEST_CASE("step detector: a motion-blurred ramp at its centre", "[edge_step]") {
  // A box-blurred step: linear from 60 to 160 over `width` samples.
  for (double centre : {27.3, 30.0, 33.8}) {
    const double width = 16.0;
    float p[61];
    for (int i = 0; i < 61; ++i)
      p[i] = static_cast<float>(60 + 100 * std::clamp((i - centre) / width + 0.5, 0.0, 1.0));
    StepEdge e;
    INFO("centre " << centre);
    // Expected ramp as wide as it is: the centre, to a hundredth of a sample.
    REQUIRE(FindStep(p, 61, +1, 4, 12.0, &e, width));
    CHECK(std::abs(e.location - centre) < 0.01);
    CHECK(e.strength == Approx(100.0).margin(0.5));
    CHECK(e.width == Approx(0.7 * width).margin(1.0));  // between the 15 % and 85 % levels
  }
}

// Paints the image at polar coordinates (radius, azimuth) from `source`'s
// pixel at the polar offsets given (px along the radius, px across it).
void CopyPolar(const Sensor& s, const cv::Mat& source, double r_from, double r_to, double half_width,
               double azimuth, double dr, double dt, cv::Mat* image) {
  for (double r = std::min(r_from, r_to); r <= std::max(r_from, r_to); r += 0.25)
    for (double t = -half_width; t <= half_width; t += 0.25) {
      const Eigen::Vector2d to = s.from_polar(r, azimuth + t / r);
      const Eigen::Vector2d from = s.from_polar(r + dr, azimuth + (t + dt) / r);
      image->at<uchar>(static_cast<int>(std::lround(to.y())), static_cast<int>(std::lround(to.x()))) =
          source.at<uchar>(static_cast<int>(std::lround(from.y())), static_cast<int>(std::lround(from.x())));
    }
}

TEST_CASE("junction tracker: a landmark only where its edges meet at the junction", "[junction]") {
  const test::RenderedCase r = test::RenderPreset("paper-synthetic", 1);
  const Sensor& s = r.c.calib.sensor;
  const std::vector<Landmark> lms = LandmarksFromMap(r.c.map);
  const Scene scene = Scene::FromMap(r.c.map, true);
  const Pose2 pose = r.truth[0].pose;
  std::vector<PredictedLandmark> pred = PredictLandmarks(lms, r.c.map, scene, s, *r.table, pose, PredictionOptions());
  SetImageMotion(r.c.map, s, *r.table, pose, 0.0, &pred);
  JunctionTracker tracker(s, MakeTrackingPhTables(r.table, 1), JunctionOptions());
  const cv::Mat& frame = r.frames[0];
  // A vertical edge of 40 px or more, found where predicted.
  const PredictedLandmark* chosen = nullptr;
  tracker.BeginFrame(frame);
  for (const PredictedLandmark& p : pred) {
    const LandmarkMeasurement m = tracker.Measure(p, 8.0);
    if (m.found && std::abs(p.v_radius - p.corner_radius) > 40 &&
        std::abs(WrapAngle(m.azimuth - p.azimuth)) * p.corner_radius < 0.3) {
      chosen = &p;
      break;
    }
  }
  REQUIRE(chosen != nullptr);
  const PredictedLandmark& p = *chosen;
  const int direction = p.v_radius > p.corner_radius ? 1 : -1;  // the edge runs this way from the corner
  // The vertical edge cut back: 9 px nearest the junction painted with what
  // lies 12 px further along it (the face and the background either side).
  cv::Mat cut = frame.clone();
  CopyPolar(s, frame, p.corner_radius + direction * 1.5, p.corner_radius + direction * 9.0, 3.0, p.azimuth,
            direction * 12.0, 6.0 * p.inside_azimuth_sign, &cut);
  tracker.BeginFrame(cut);
  LandmarkMeasurement m = tracker.Measure(p, 8.0);
  CHECK_FALSE(m.found);
  CHECK(std::string(m.why) == "edges do not meet");
  // Cut back by 2 px only: within the tolerance (3 px), still a junction.
  cut = frame.clone();
  CopyPolar(s, frame, p.corner_radius + direction * 0.5, p.corner_radius + direction * 2.0, 3.0, p.azimuth,
            direction * 12.0, 6.0 * p.inside_azimuth_sign, &cut);
  tracker.BeginFrame(cut);
  m = tracker.Measure(p, 8.0);
  CHECK(m.found);
  // The horizontal edge cut back instead: from the vertical edge to cut_px
  // along it, painted with what lies 12 px beyond the corner (the
  // background) as far into the face as a 3 px search reaches. Ending 9 px
  // from the junction it lies beyond the tolerance; 2 px, within it.
  const double along = p.inside_azimuth_sign / p.corner_radius;  // rad per px along the horizontal edge
  for (const auto& [cut_px, meets] : {std::pair{9.0, false}, std::pair{2.0, true}}) {
    cut = frame.clone();
    CopyPolar(s, frame, p.corner_radius - direction * 4.0, p.corner_radius + direction * 8.0, 0.5 * cut_px,
              p.azimuth + along * 0.5 * cut_px, -direction * 12.0, 0.0, &cut);
    tracker.BeginFrame(cut);
    m = tracker.Measure(p, 3.0);
    INFO("horizontal edge cut back to " << cut_px << " px: " << m.why);
    CHECK(m.found == meets);
    if (!meets) CHECK(std::string(m.why) == "edges do not meet");
  }
  // The vertical edge drawn on past the junction (what lies 12 px along it,
  // copied 2 to 9 px beyond the corner): not this landmark's corner.
  cv::Mat past = frame.clone();
  CopyPolar(s, frame, p.corner_radius - direction * 2.0, p.corner_radius - direction * 9.0, 4.0, p.azimuth,
            direction * 16.0, 0.0, &past);
  tracker.BeginFrame(past);
  m = tracker.Measure(p, 8.0);
  CHECK_FALSE(m.found);
  CHECK(std::string(m.why) == "vertical edge runs past the junction");
}

TEST_CASE("visual compass: the rotation between two frames at one position", "[compass]") {
  const SequenceCase c = MakePreset("paper-synthetic");
  const Scene scene = Scene::FromMap(c.map, true);
  const Renderer renderer(c.calib.sensor, scene, c.map.sensor_height, c.options);
  const AzimuthCompass compass(c.calib.sensor);
  Pose2 a = c.poses[10];
  for (double turn_deg : {-25.0, -7.0, 3.3, 14.0}) {
    Pose2 b = a;
    b.theta += turn_deg * M_PI / 180;
    double score;
    const double turn = compass.Rotation(compass.Signature(renderer.Render(a)),
                                         compass.Signature(renderer.Render(b)), M_PI / 3, &score);
    INFO("turn " << turn_deg << " deg, estimated " << turn * 180 / M_PI);
    CHECK(std::abs(turn * 180 / M_PI - turn_deg) < 0.2);
    CHECK(score > 0.96);
  }
}


TEST_CASE("visual compass and relocalisation read frames with padded rows", "[compass]") {
  const SequenceCase c = MakePreset("paper-synthetic");
  const Scene scene = Scene::FromMap(c.map, true);
  const Renderer renderer(c.calib.sensor, scene, c.map.sensor_height, c.options);
  const cv::Mat frame = renderer.Render(c.poses[10]);
  REQUIRE(frame.isContinuous());
  const cv::Mat padded = WithPaddedRows(frame, 44);
  REQUIRE_FALSE(padded.isContinuous());
  const AzimuthCompass compass(c.calib.sensor);
  CHECK(compass.Signature(padded) == compass.Signature(frame));
  const RadiusTable table = RadiusTable::Build(c.calib.sensor, RangesForMap(c.map, c.calib.sensor));
  const RelocalizationIndex index(c.calib.sensor, table, c.map, scene, LandmarksFromMap(c.map),
                                  PredictionOptions(), RelocalizeOptions());
  const std::vector<float> hist = index.RadialEdgeHistogram(frame);
  CHECK(*std::max_element(hist.begin(), hist.end()) == Approx(1.0).margin(1e-6));  // edges were found
  CHECK(index.RadialEdgeHistogram(padded) == hist);
}

TEST_CASE("relocalisation: asked for more hypotheses, the search returns the usual ones first", "[relocalize]") {
  // The localiser verifies more of them before a first pose: the ranking
  // does not change, the list only goes on.
  const SequenceCase c = MakePreset("paper-synthetic");
  const Scene scene = Scene::FromMap(c.map, true);
  const Renderer renderer(c.calib.sensor, scene, c.map.sensor_height, c.options);
  const cv::Mat frame = renderer.Render(c.poses[10]);
  const RadiusTable table = RadiusTable::Build(c.calib.sensor, RangesForMap(c.map, c.calib.sensor));
  const RelocalizeOptions options;
  const RelocalizationIndex index(c.calib.sensor, table, c.map, scene, LandmarksFromMap(c.map),
                                  PredictionOptions(), options);
  const std::vector<PoseHypothesis> usual = index.Hypotheses(frame);
  const std::vector<PoseHypothesis> more = index.Hypotheses(frame, 0, 30);
  REQUIRE(usual.size() == static_cast<size_t>(options.hypotheses));
  REQUIRE(more.size() == 30);
  for (size_t i = 0; i < usual.size(); ++i) {
    CHECK(more[i].pose.x == usual[i].pose.x);
    CHECK(more[i].pose.y == usual[i].pose.y);
    CHECK(more[i].pose.theta == usual[i].pose.theta);
    CHECK(more[i].score == usual[i].score);
  }
  for (size_t i = 1; i < more.size(); ++i) CHECK(more[i].score <= more[i - 1].score);
  CHECK(index.Hypotheses(frame, 0, 5).size() == 5);
}

TEST_CASE("relocalisation: a robot started at a wrong pose finds itself", "[relocalize]") {
  const test::RenderedCase r = test::RenderPreset("paper-synthetic", 6, 30);
  Pose2 wrong = r.c.poses[30];
  wrong.x = r.c.map.room.max.x() - wrong.x;
  wrong.y = r.c.map.room.max.y() - wrong.y;
  wrong.theta += 2.0;
  const std::vector<PoseRow> rows = test::Localize(r, LocalizerOptions(), wrong);
  // Lost at first, then relocalised after relocalize_after lost frames.
  int first_ok = -1;
  for (size_t i = 0; i < rows.size(); ++i)
    if (rows[i].status == PoseStatus::kOk) {
      first_ok = static_cast<int>(i);
      break;
    }
  REQUIRE(first_ok >= 0);
  CHECK(first_ok <= 2);
  for (size_t i = first_ok; i < rows.size(); ++i) {
    REQUIRE(rows[i].status == PoseStatus::kOk);
    CHECK(std::hypot(rows[i].pose.x - r.truth[i].pose.x, rows[i].pose.y - r.truth[i].pose.y) < 0.1);
  }
}

TEST_CASE("relocalisation: the heading search finds the best heading, the lowest among equals",
          "[relocalize_heading]") {
  PANO_SEEDED_RNG(21);
  std::uniform_real_distribution<float> level(0.0f, 1.0f);
  for (int bins : {720, 725, 36}) {
    for (int trial = 0; trial < 200; ++trial) {
      // A histogram of a few peaks over a low floor, quantised so that equal
      // scores occur (the lowest bin must win).
      std::vector<float> hist(static_cast<size_t>(bins));
      for (float& h : hist) h = std::floor(4 * level(rng) * level(rng) * level(rng)) / 4;
      std::vector<int> edges;
      std::uniform_int_distribution<int> bin(0, bins - 1);
      const int n = 3 + trial % 10;
      for (int k = 0; k < n; ++k) edges.push_back(bin(rng));
      // One heading at a time, as the definition reads.
      double expected_score = 0.0;
      int expected = -1;
      for (int t = 0; t < bins; ++t) {
        double sum = 0.0;
        for (int b : edges) sum += hist[static_cast<size_t>(((b - t) % bins + bins) % bins)];
        if (sum - 0.15 * edges.size() > expected_score) {
          expected_score = sum - 0.15 * edges.size();
          expected = t;
        }
      }
      double score;
      const int found = HeadingSearch(hist).Best(edges, &score);
      INFO("bins " << bins << ", trial " << trial);
      REQUIRE(found == expected);
      REQUIRE(score == expected_score);
    }
  }
  // Nothing above zero: no heading.
  double score;
  CHECK(HeadingSearch(std::vector<float>(720, 0.0f)).Best({1, 2, 3}, &score) == -1);
  CHECK(score == 0.0);
  CHECK_THROWS_WITH(HeadingSearch(std::vector<float>()), Catch::Contains("histogram"));
}

// Every field of two trajectories, compared exactly.
void CheckSameRows(const std::vector<PoseRow>& a, const std::vector<PoseRow>& b) {
  REQUIRE(a.size() == b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    INFO("frame " << i);
    CHECK(a[i].status == b[i].status);
    CHECK(a[i].pose.x == b[i].pose.x);
    CHECK(a[i].pose.y == b[i].pose.y);
    CHECK(a[i].pose.theta == b[i].pose.theta);
    CHECK(a[i].n_landmarks == b[i].n_landmarks);
    CHECK((a[i].residual == b[i].residual || (std::isnan(a[i].residual) && std::isnan(b[i].residual))));
    REQUIRE(a[i].extra.size() == b[i].extra.size());
    for (size_t k = 0; k < a[i].extra.size(); ++k)
      CHECK((a[i].extra[k] == b[i].extra[k] || (std::isnan(a[i].extra[k]) && std::isnan(b[i].extra[k]))));
  }
}

TEST_CASE("localiser threads: identical trajectories for 1, 2 and 4 threads (and a search on 3), through a kidnapping",
          "[threads]") {
  // Frames 27..36 of the kidnap preset: tracking, the jump at frame 30
  // (relocalised at once), tracking again: every parallel loop of the localiser.
  const test::RenderedCase r = test::RenderPreset("kidnap", 10, 27);
  for (TrackingMethod method : {TrackingMethod::kJunction, TrackingMethod::kVertex}) {
    INFO("method " << TrackingMethodName(method));
    LocalizerOptions opt;
    opt.method = method;
    opt.num_threads = 1;
    const std::vector<PoseRow> one = test::Localize(r, opt, r.c.poses[27]);
    // The run is worth comparing: tracked before the jump, found again at it
    // by the room-wide search (nothing predicted was there).
    CHECK(one[0].status == PoseStatus::kOk);
    CHECK(one[3].status == PoseStatus::kOk);
    CHECK(std::hypot(one[3].pose.x - r.truth[3].pose.x, one[3].pose.y - r.truth[3].pose.y) < 0.1);
    CHECK(std::hypot(one[3].pose.x - one[2].pose.x, one[3].pose.y - one[2].pose.y) > 20.0);
    CHECK(one.back().status == PoseStatus::kOk);
    for (int threads : {2, 4}) {
      INFO(threads << " threads");
      opt.num_threads = threads;
      CheckSameRows(one, test::Localize(r, opt, r.c.poses[27]));
    }
    // Frames tracked on one thread, the room-wide search on three.
    opt.num_threads = 1;
    opt.search_threads = 3;
    CheckSameRows(one, test::Localize(r, opt, r.c.poses[27]));
  }
  LocalizerOptions bad;
  bad.num_threads = -1;
  CHECK_THROWS_AS(Localizer(r.c.calib, r.c.map, r.table, bad), Error);
  bad.num_threads = 1;
  bad.search_threads = -1;
  CHECK_THROWS_AS(Localizer(r.c.calib, r.c.map, r.table, bad), Error);
}

TEST_CASE("accuracy summary: RMS, std, max, outliers, tracked frames", "[accuracy]") {
  std::vector<PoseRow> truth, est;
  for (int i = 0; i < 10; ++i) {
    PoseRow t;
    t.frame = i;
    t.pose = {10.0 * i, 5.0, 0.0};
    truth.push_back(t);
    PoseRow e = t;
    e.pose.x += (i % 2 ? 0.1 : -0.1);  // errors of +-0.1, zero mean
    if (i == 7) e.pose.y += 3.0;       // one outlier
    if (i == 9) e.status = PoseStatus::kLost;
    e.pose.theta = 0.01;
    est.push_back(e);
  }
  const AccuracySummary a = CompareToGroundTruth(est, truth);
  CHECK(a.frames == 10);
  CHECK(a.tracked == 9);
  CHECK(a.compared == 9);
  CHECK(a.outliers == 1);
  CHECK(a.max == Approx(std::hypot(0.1, 3.0)));
  CHECK(a.rms == Approx(std::sqrt((8 * 0.01 + 0.01 + 9.0) / 9)));
  CHECK(a.std_inliers == Approx(std::sqrt(0.009375)));
  CHECK(a.heading_rms_deg == Approx(0.01 * 180 / M_PI));
}

}  // namespace
}  // namespace pano

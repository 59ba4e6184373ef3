// Survey error of panosim's maps: per-coordinate errors, whole-rectangle
// offsets and gross faults, each seeded and independent of the others.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <opencv2/imgcodecs.hpp>

#include "expect_error.h"
#include "panotrack/io/map.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/render/sequence.h"
#include "panotrack/render/writers.h"
#include "panotrack/scene/scene.h"
#include "test_paths.h"

namespace pano {
namespace {

const MapRectangle* Find(const Map& m, const std::string& id) {
  for (const MapRectangle& r : m.rectangles)
    if (r.id == id) return &r;
  return nullptr;
}

bool SameRectangle(const MapRectangle& a, const MapRectangle& b) {
  return a.id == b.id && a.from == b.from && a.to == b.to && a.z0 == b.z0 && a.z1 == b.z1;
}

// A map of many small rectangles (statistics of the errors) and 20 boxes.
Map ManyRectangles() {
  Map m = MakePreset("paper-real").map;
  m.rectangles.clear();
  m.boxes.clear();
  for (int k = 0; k < 400; ++k) {
    MapRectangle r;
    r.id = "r" + std::to_string(k);
    r.from = {10.0 + 0.5 * k, 20.0};
    r.to = {10.0 + 0.5 * k, 40.0};
    r.z0 = k % 2 ? 0.0 : 10.0;
    r.z1 = 50.0;
    m.rectangles.push_back(r);
  }
  for (int k = 0; k < 20; ++k) {
    MapBox b;
    b.id = "b" + std::to_string(k);
    b.min = {20.0 + 5.0 * k, 100.0, 0.0};
    b.max = {23.0 + 5.0 * k, 104.0, 30.0};
    m.boxes.push_back(b);
  }
  return m;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

double Std(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

TEST_CASE("per-coordinate survey error: stated in the map, boxes after the rectangles", "[survey]") {
  const Map truth = MakePreset("cluttered").map;
  REQUIRE_FALSE(truth.boxes.empty());
  SurveyError e;
  e.sigma = 0.5;
  e.seed = 3;
  const SurveyedMap s = SurveyMap(truth, e);
  CHECK(s.map.survey_sigma == 0.5);
  CHECK(s.faults.empty());
  REQUIRE(s.room.rectangles.size() == truth.rectangles.size());
  for (size_t k = 0; k < truth.rectangles.size(); ++k) CHECK(SameRectangle(s.room.rectangles[k], truth.rectangles[k]));
  // The rectangles' errors are those of a map without boxes (older renders keep their maps).
  Map no_boxes = truth;
  no_boxes.boxes.clear();
  const Map p = PerturbedMap(no_boxes, 0.5, 3);
  for (size_t k = 0; k < truth.rectangles.size(); ++k) CHECK(SameRectangle(s.map.rectangles[k], p.rectangles[k]));
  // Boxes are surveyed too; on the floor they stay there.
  for (size_t k = 0; k < truth.boxes.size(); ++k) {
    CHECK((s.map.boxes[k].min - truth.boxes[k].min).norm() + (s.map.boxes[k].max - truth.boxes[k].max).norm() > 0.0);
    if (truth.boxes[k].min.z() == 0.0) CHECK(s.map.boxes[k].min.z() == 0.0);
  }
  // An exact map states that it is exact (the rendered room is the map).
  CHECK(SurveyMap(truth, SurveyError{}).map.survey_sigma == 0.0);
}

TEST_CASE("box coordinates get errors of sigma, their floor contact none", "[survey]") {
  const Map truth = ManyRectangles();
  const Map p = PerturbedMap(truth, 2.0, 5);
  std::vector<double> d;
  for (size_t k = 0; k < truth.boxes.size(); ++k) {
    for (int i = 0; i < 2; ++i) d.push_back(p.boxes[k].min[i] - truth.boxes[k].min[i]);
    d.push_back(p.boxes[k].max.z() - truth.boxes[k].max.z());
    CHECK(p.boxes[k].min.z() == 0.0);
    CHECK(p.boxes[k].max.z() > p.boxes[k].min.z());
  }
  CHECK(Std(d) == Approx(2.0).epsilon(0.25));
}

TEST_CASE("offsets move each rectangle and box as a whole by N(0, sigma) in x and y", "[survey]") {
  const Map truth = ManyRectangles();
  SurveyError e;
  e.offset_sigma = 1.5;
  e.seed = 9;
  const SurveyedMap s = SurveyMap(truth, e);
  CHECK(s.map.survey_sigma == 1.5);
  std::vector<double> dx, dy;
  for (size_t k = 0; k < truth.rectangles.size(); ++k) {
    const MapRectangle &a = truth.rectangles[k], &b = s.map.rectangles[k];
    const Eigen::Vector2d d = b.from - a.from;
    // A whole move: both ends by the same vector, heights kept.
    CHECK((b.to - a.to - d).norm() < 1e-12);
    CHECK(b.z0 == a.z0);
    CHECK(b.z1 == a.z1);
    dx.push_back(d.x());
    dy.push_back(d.y());
  }
  CHECK(Std(dx) == Approx(1.5).epsilon(0.1));
  CHECK(Std(dy) == Approx(1.5).epsilon(0.1));
  for (size_t k = 0; k < truth.boxes.size(); ++k) {
    const Eigen::Vector3d d = s.map.boxes[k].min - truth.boxes[k].min;
    CHECK((s.map.boxes[k].max - truth.boxes[k].max - d).norm() < 1e-12);
    CHECK(d.z() == 0.0);
    CHECK(d.head<2>().norm() > 0.0);
  }
  // Both kinds together: the per-coordinate errors are those alone, the
  // offsets added on top, and the stated sigma is their combined spread.
  e.sigma = 2.0;
  const SurveyedMap both = SurveyMap(truth, e);
  CHECK(both.map.survey_sigma == Approx(2.5));
  const Map coords = PerturbedMap(truth, 2.0, 9);
  for (size_t k = 0; k < truth.rectangles.size(); ++k) {
    const Eigen::Vector2d offset = s.map.rectangles[k].from - truth.rectangles[k].from;
    CHECK((both.map.rectangles[k].from - coords.rectangles[k].from - offset).norm() < 1e-9);
  }
}

TEST_CASE("gross faults: one of each kind for three, seeded, 8 cm by default", "[survey]") {
  const Map truth = MakePreset("paper-real").map;
  REQUIRE(truth.units == "cm");
  SurveyError e;
  e.gross = 3;
  e.seed = 4;
  const SurveyedMap s = SurveyMap(truth, e);
  REQUIRE(s.faults.size() == 3);
  CHECK(s.map.survey_sigma == 0.0);  // blunders are not a survey sigma: the rest is exact
  CHECK(s.faults[0].kind == MapFaultKind::kMoved);
  CHECK(s.faults[1].kind == MapFaultKind::kNotInRoom);
  CHECK(s.faults[2].kind == MapFaultKind::kNotInMap);
  CHECK(s.faults[0].id != s.faults[1].id);
  CHECK(s.faults[1].id != s.faults[2].id);
  CHECK(s.faults[0].id != s.faults[2].id);
  CHECK(s.faults[0].offset.norm() == Approx(8.0));
  // Slid along its bottom edge: a wall rectangle stays on its wall.
  const Eigen::Vector2d along = Find(truth, s.faults[0].id)->to - Find(truth, s.faults[0].id)->from;
  CHECK(std::abs(along.x() * s.faults[0].offset.y() - along.y() * s.faults[0].offset.x()) < 1e-9 * along.norm());
  // Moved: in both, 8 cm apart; not in the room: in the map only; not in the map: in the room only.
  const MapRectangle *moved_map = Find(s.map, s.faults[0].id), *moved_room = Find(s.room, s.faults[0].id);
  REQUIRE(moved_map);
  REQUIRE(moved_room);
  CHECK((moved_map->from - moved_room->from - s.faults[0].offset).norm() < 1e-12);
  CHECK((moved_map->to - moved_room->to - s.faults[0].offset).norm() < 1e-12);
  CHECK(Find(s.map, s.faults[1].id));
  CHECK_FALSE(Find(s.room, s.faults[1].id));
  CHECK_FALSE(Find(s.map, s.faults[2].id));
  CHECK(Find(s.room, s.faults[2].id));
  CHECK(s.map.rectangles.size() == truth.rectangles.size() - 1);
  CHECK(s.room.rectangles.size() == truth.rectangles.size() - 1);
  // Every other rectangle is exact in both.
  for (const MapRectangle& r : truth.rectangles) {
    if (std::any_of(s.faults.begin(), s.faults.end(), [&](const MapFault& f) { return f.id == r.id; })) continue;
    REQUIRE(Find(s.map, r.id));
    CHECK(SameRectangle(*Find(s.map, r.id), r));
    CHECK(SameRectangle(*Find(s.room, r.id), r));
  }
  // The same seed picks the same; the picks do not depend on the other errors.
  e.sigma = 1.0;
  e.offset_sigma = 0.5;
  const SurveyedMap again = SurveyMap(truth, e);
  for (size_t k = 0; k < 3; ++k) {
    CHECK(again.faults[k].id == s.faults[k].id);
    CHECK(again.faults[k].offset == s.faults[k].offset);
  }
  // Another seed, other picks (for this seed pair), and a given distance.
  e.seed = 5;
  e.gross_offset = 3.0;
  const SurveyedMap other = SurveyMap(truth, e);
  CHECK(other.faults[0].offset.norm() == Approx(3.0));
  bool differs = false;
  for (size_t k = 0; k < 3; ++k) differs |= other.faults[k].id != s.faults[k].id;
  CHECK(differs);
}

TEST_CASE("gross faults that do not fit the map are refused, naming the option", "[survey][bad_input]") {
  const Map truth = MakePreset("paper-synthetic").map;
  SurveyError e;
  e.gross = static_cast<int>(truth.rectangles.size()) + 1;
  test::ExpectError([&] { SurveyMap(truth, e); }, "map-gross", {"rectangles"});
  e.gross = -1;
  test::ExpectError([&] { SurveyMap(truth, e); }, "map-gross", {});
  e.gross = 0;
  e.offset_sigma = -1.0;
  test::ExpectError([&] { SurveyMap(truth, e); }, "map-offset-sigma", {});
}

TEST_CASE("sequence writer: surveyed map, true map, faults, and the room rendered", "[survey][sequence]") {
  SequenceCase c = MakePreset("paper-real");
  c.poses.resize(2);
  c.options.supersample = 1;
  c.survey.sigma = 0.5;
  c.survey.gross = 3;
  c.survey.seed = 2;
  const std::string dir = test::ScratchDir("render_survey") + "/out";
  SequenceWriteOptions wo;
  wo.frames = true;
  wo.video = false;
  WriteSequence(c, dir, wo);
  const SurveyedMap s = SurveyMap(c.map, c.survey);
  const Map written = ReadMap(dir + "/map.yaml"), true_map = ReadMap(dir + "/map_true.yaml");
  CHECK(written.survey_sigma == 0.5);
  CHECK(written.rectangles.size() == s.map.rectangles.size());
  CHECK(Find(written, s.faults[1].id));
  CHECK_FALSE(Find(written, s.faults[2].id));
  CHECK_FALSE(Find(true_map, s.faults[1].id));
  CHECK(Find(true_map, s.faults[2].id));
  CHECK(true_map.survey_sigma == 0.0);
  const std::string faults = ReadText(dir + "/map_faults.yaml");
  CHECK(faults == MapFaultsYaml(s.faults, "cm"));
  CHECK(faults.find("kind: not-in-room") != std::string::npos);
  const std::string case_yaml = ReadText(dir + "/case.yaml");
  for (const char* line : {"map_sigma: 0.5", "map_gross: 3", "map_faults: map_faults.yaml", "map_seed: 2"})
    CHECK(case_yaml.find(line) != std::string::npos);
  CHECK(case_yaml.find("map_offset_sigma") == std::string::npos);
  // The frames show the room: without the rectangle that is not in it.
  const Scene room = Scene::FromMap(s.room, true), full = Scene::FromMap(c.map, true);
  const cv::Mat frame = cv::imread(dir + "/frames/frame_0001.png", cv::IMREAD_UNCHANGED);
  const Renderer in_room(c.calib.sensor, room, c.map.sensor_height, c.options);
  const Renderer everything(c.calib.sensor, full, c.map.sensor_height, c.options);
  CHECK(cv::countNonZero(frame != in_room.Render(c.poses[1], 1)) == 0);
  CHECK(cv::countNonZero(frame != everything.Render(c.poses[1], 1)) > 0);
}

}  // namespace
}  // namespace pano

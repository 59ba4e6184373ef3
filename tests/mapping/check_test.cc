// panomap check's library on a rendered sequence of the paper-real room:
// a map with three deliberate faults (one rectangle moved 5 cm, one shade
// inverted, one rectangle that is not in the room) must be flagged on those
// three and no other, from the ground-truth poses and self-localised.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <string>

#include "expect_error.h"
#include "panotrack/io/map.h"
#include "panotrack/pipeline/panomap.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/sequence.h"
#include "panotrack/render/writers.h"
#include "test_paths.h"

namespace pano {
namespace {

constexpr int kFrames = 30;

struct FaultCase {
  std::string dir, frames, video, calib, gt, true_map, faulty_map;
};

MapRectangle* Find(Map* m, const std::string& id) {
  for (MapRectangle& r : m->rectangles)
    if (r.id == id) return &r;
  return nullptr;
}

// paper-real (cm) cut to its first 30 frames, and its map with the faults:
// e2 moved 5 cm along its wall, n2's shade inverted (light drawn dark), and
// "ghost", a dark rectangle on the east wall where the camera looks.
const FaultCase& GetFaultCase() {
  static const FaultCase c = [] {
    FaultCase f;
    f.dir = test::ScratchDir("mapping_check") + "/seq";
    SequenceCase sc = MakePreset("paper-real");
    sc.poses.resize(kFrames);
    SequenceWriteOptions w;
    w.frames = true;
    WriteSequence(sc, f.dir, w);
    f.frames = f.dir + "/frames";
    f.video = f.dir + "/video.mp4";
    f.calib = f.dir + "/calib.yaml";
    f.gt = f.dir + "/gt.csv";
    f.true_map = f.dir + "/map.yaml";
    Map m = ReadMap(f.true_map);
    MapRectangle* e2 = Find(&m, "e2");
    REQUIRE(e2 != nullptr);
    e2->from.y() += 5.0;
    e2->to.y() += 5.0;
    MapRectangle* n2 = Find(&m, "n2");
    REQUIRE(n2 != nullptr);
    REQUIRE(n2->shade > 0.8);
    n2->shade = 0.12;
    MapRectangle ghost;
    ghost.id = "ghost";
    ghost.from = {219.5, 62.0};
    ghost.to = {219.5, 80.0};
    ghost.z0 = 15.0;
    ghost.z1 = 65.0;
    ghost.shade = 0.12;
    m.rectangles.push_back(ghost);
    f.faulty_map = f.dir + "/faulty.yaml";
    WriteMap(f.faulty_map, m);
    return f;
  }();
  return c;
}

// `f` throws pano::Error with a one-line message containing `part`.
template <typename F>
void Refused(F f, const std::string& part) {
  const std::string msg = test::ErrorOf(f);
  INFO("message: " << msg);
  CHECK(msg.find(part) != std::string::npos);
  CHECK(msg.find('\n') == std::string::npos);
}

std::set<std::string> Flagged(const MapCheckReport& r) {
  std::set<std::string> out;
  for (const ObjectFinding& f : r.findings) out.insert(f.object);
  return out;
}

const ObjectFinding* FindingOf(const MapCheckReport& r, const std::string& object) {
  for (const ObjectFinding& f : r.findings)
    if (f.object == object) return &f;
  return nullptr;
}

const EdgeCheck& Edge(const MapCheckReport& r, const std::string& id) {
  for (const EdgeCheck& e : r.edges)
    if (e.id == id) return e;
  FAIL("no edge " << id);
  return r.edges.front();
}

// `shade_margin`: how far the shades seen may be from the truth (the H.264
// video's limited luma range narrows the contrast: 0.17 for 0.12).
void RequireTheThreeFaults(const MapCheckReport& r, double shade_margin = 0.03) {
  INFO(FormatMapCheckTable(r));
  CHECK(Flagged(r) == std::set<std::string>{"e2", "ghost", "n2"});
  REQUIRE(r.findings.size() == 3);
  CHECK(FindingOf(r, "ghost")->kind == MapFinding::kNeverFound);
  CHECK(FindingOf(r, "n2")->kind == MapFinding::kWrongPolarity);
  CHECK(FindingOf(r, "e2")->kind == MapFinding::kBiased);
  CHECK(FindingOf(r, "n2")->message.find("set shade to about") != std::string::npos);
  CHECK(FindingOf(r, "e2")->message.find("run panomap refine") != std::string::npos);
  // The moved rectangle: both edges off by about 2.1 and 1.4 degrees (5 cm
  // along the wall is 4.5 and 3.6 cm across the line of sight at 124 and
  // 146 cm); every edge that is right within 0.02 degrees (measured: at most
  // 0.01) and found on at least 90 % of the frames that show it (measured:
  // 93 % for n2/to, 96 % or more for the others).
  CHECK(Edge(r, "e2/from").mean_residual_deg == Approx(-2.07).margin(0.1));
  CHECK(Edge(r, "e2/to").mean_residual_deg == Approx(-1.42).margin(0.06));
  for (const EdgeCheck& e : r.edges) {
    if (e.object == "e2" || e.object == "ghost" || e.residual_frames == 0) continue;
    INFO(e.id);
    CHECK(std::abs(e.mean_residual_deg) < 0.02);
    CHECK(e.std_residual_deg < 0.04);
    if (e.visible >= 3) CHECK(e.found_fraction >= 0.9);
    // The shade seen (brightness against the wall's 0.55) is the map's,
    // within 0.03 on the lossless frames (measured: 0.02).
    if (e.object != "n2") CHECK(e.seen_shade == Approx(e.shade).margin(shade_margin));
  }
  // The inverted rectangle's shade as seen: its true 0.88, suggested.
  CHECK(Edge(r, "n2/from").seen_shade == Approx(0.88).margin(shade_margin));
  CHECK(FindingOf(r, "n2")->message.find("set shade to about 0.8") != std::string::npos);
  CHECK(Edge(r, "n2/from").polarity_fraction == 0.0);
  CHECK(Edge(r, "n2/to").polarity_fraction == 0.0);
  CHECK(Edge(r, "ghost/from").found == 0);
  CHECK(Edge(r, "ghost/to").found == 0);
}

TEST_CASE("map check: the three faults and no others, from the ground truth and self-localised",
          "[check_flags]") {
  const FaultCase& c = GetFaultCase();
  MapCheckJob job;
  job.map_path = c.faulty_map;
  job.calib_path = c.calib;
  job.input = c.frames;
  SECTION("ground-truth poses") {
    job.poses_path = c.gt;
    const MapCheckReport r = RunMapCheck(job);
    CHECK(r.frames == kFrames);
    CHECK(r.frames_with_pose == kFrames);
    RequireTheThreeFaults(r);
  }
  SECTION("self-localised, each object held out of its own residuals' pose") {
    const MapCheckReport r = RunMapCheck(job);
    CHECK(r.frames_with_pose >= kFrames - 1);
    RequireTheThreeFaults(r);
  }
  SECTION("the video, with the overlay and the report CSV") {
    job.input = c.video;
    job.poses_path = c.gt;
    job.overlay = c.dir + "/../overlay.png";
    job.report_csv = c.dir + "/../report.csv";
    const MapCheckReport r = RunMapCheck(job);
    RequireTheThreeFaults(r, 0.07);
    CHECK(std::filesystem::file_size(job.overlay) > 10000);
    std::ifstream csv(job.report_csv);
    int lines = 0;
    for (std::string line; std::getline(csv, line);) ++lines;
    CHECK(lines == 1 + static_cast<int>(r.edges.size()));
  }
}

TEST_CASE("map check: the true map has no findings", "[check_flags]") {
  const FaultCase& c = GetFaultCase();
  MapCheckJob job;
  job.map_path = c.true_map;
  job.calib_path = c.calib;
  job.input = c.frames;
  job.poses_path = c.gt;
  const MapCheckReport r = RunMapCheck(job);
  INFO(FormatMapCheckTable(r));
  CHECK(r.findings.empty());
}

// A rectangle that panomap build found, from `from` to `to`.
BuiltRectangle Built(Eigen::Vector2d from, Eigen::Vector2d to) {
  BuiltRectangle b;
  b.rectangle.from = from;
  b.rectangle.to = to;
  b.rectangle.z0 = 0.0;
  b.rectangle.z1 = 60.0;
  b.edge_from = 0;
  b.edge_to = 1;
  return b;
}

TEST_CASE("map check: rectangles found in the images are mapped ones, moved ones or not in the map",
          "[check_unmapped]") {
  Map map = MakePreset("paper-real").map;  // 220 cm: the tolerance is 2.2 cm
  map.distractors.clear();
  MapBuildResult built;
  built.edges.resize(2);
  built.edges[0].views = 40;
  built.edges[1].views = 50;
  MapCheckReport report;
  ObjectFinding biased;
  biased.object = "e2";
  biased.kind = MapFinding::kBiased;
  biased.message = "e2: corner mis-measured";
  report.findings.push_back(biased);
  const MapRectangle* e2 = Find(&map, "e2");
  const MapRectangle* s1 = Find(&map, "s1");
  REQUIRE(e2);
  REQUIRE(s1);
  const Eigen::Vector2d shift(0.0, 6.0);
  // s1 seen from where the map does not predict it, reversed: s1 itself.
  built.rectangles.push_back(Built(s1->to + Eigen::Vector2d(1.0, 0.5), s1->from));
  // e2 where it stands, 6 cm from the map's: e2's finding says so.
  built.rectangles.push_back(Built(e2->from + shift, e2->to + shift));
  // s1 shifted as well, but s1 has no finding: a rectangle not in the map.
  built.rectangles.push_back(Built(s1->from + shift, s1->to + shift));
  // Nothing mapped near it (the middle of the room).
  built.rectangles.push_back(Built({140.0, 100.0}, {160.0, 100.0}));
  AddUnmappedFindings(map, built, &report);
  INFO(FormatMapCheckTable(report));
  REQUIRE(report.findings.size() == 3);
  CHECK(report.findings[0].message.find("stands 6.0 cm from it") != std::string::npos);
  CHECK(report.findings[1].object == "unmapped-1");
  CHECK(report.findings[1].kind == MapFinding::kNotInMap);
  CHECK(report.findings[2].object == "unmapped-2");
  CHECK(report.findings[2].message.find("(140.0, 100.0) to (160.0, 100.0), z 0 to 60 cm, seen in 50 frames") !=
        std::string::npos);
  // A map measured to 2.5 cm: 3 sigmas of tolerance take the shifted
  // rectangles for the mapped ones.
  map.survey_sigma = 2.5;
  MapCheckReport measured;
  AddUnmappedFindings(map, built, &measured);
  REQUIRE(measured.findings.size() == 1);
  CHECK(measured.findings[0].message.find("(140.0, 100.0)") != std::string::npos);
}

TEST_CASE("map check: only frames whose pose fits the map look for what it lacks", "[check_unmapped]") {
  const double deg = M_PI / 180;
  FrameCheck fc;
  auto add = [&](bool found, bool has_residual, double residual_deg) {
    EdgeFrameMeasurement m;
    m.found = found;
    m.has_residual = has_residual;
    m.bearing_residual = residual_deg * deg;
    fc.edges.push_back(m);
  };
  add(true, true, 0.05);
  add(true, true, -0.1);
  CHECK_FALSE(PoseFitsTheMap(fc, 0.3 * deg));  // two edges: too few to judge
  add(true, true, 2.0);                         // one edge off (a moved rectangle) ...
  add(false, false, 0.0);
  CHECK(PoseFitsTheMap(fc, 0.3 * deg));         // ... the median fits
  add(true, true, -0.5);
  add(true, true, 0.6);
  CHECK_FALSE(PoseFitsTheMap(fc, 0.3 * deg));   // most edges off: the pose is
  CHECK(PoseFitsTheMap(fc, 0.6 * deg));
}

TEST_CASE("map check: panosim's gross survey errors are each flagged", "[check_gross]") {
  // paper-real's first 30 frames; seed 3 slides n3 8 cm along its wall,
  // leaves e1 out of the room and e2 out of the map.
  SequenceCase sc = MakePreset("paper-real");
  sc.poses.resize(kFrames);
  sc.survey.gross = 3;
  sc.survey.seed = 3;
  const SurveyedMap survey = SurveyMap(sc.map, sc.survey);
  REQUIRE(survey.faults.size() == 3);
  CHECK(survey.faults[0].id == "n3");
  CHECK(survey.faults[1].id == "e1");
  CHECK(survey.faults[2].id == "e2");
  const std::string dir = test::ScratchDir("mapping_gross") + "/seq";
  SequenceWriteOptions w;
  w.frames = true;
  w.video = false;
  WriteSequence(sc, dir, w);
  MapCheckJob job;
  job.map_path = dir + "/map.yaml";
  job.calib_path = dir + "/calib.yaml";
  job.input = dir + "/frames";
  const auto three_flagged = [](const MapCheckReport& r) {
    INFO(FormatMapCheckTable(r));
    REQUIRE(r.findings.size() == 3);
    CHECK(Flagged(r) == std::set<std::string>{"n3", "e1", "unmapped-1"});
    // Off by about 8 cm across its line of sight (its true place is seen
    // over too little parallax on 30 frames to be placed; on all 300 frames
    // of paper-real-map-error the finding adds where it stands).
    CHECK(FindingOf(r, "n3")->kind == MapFinding::kBiased);
    CHECK(FindingOf(r, "e1")->kind == MapFinding::kNeverFound);
    const ObjectFinding* unmapped = FindingOf(r, "unmapped-1");
    CHECK(unmapped->kind == MapFinding::kNotInMap);
    // Placed where it stands, (219.5, 90) to (219.5, 125), within a
    // centimetre (the builds' rounding moves the last digit).
    std::smatch m;
    const std::regex placed(R"(\(([-0-9.]+), ([-0-9.]+)\) to \(([-0-9.]+), ([-0-9.]+)\))");
    REQUIRE(std::regex_search(unmapped->message, m, placed));
    CHECK(std::stod(m[1]) == Approx(219.5).margin(1.0));
    CHECK(std::stod(m[2]) == Approx(90.0).margin(1.0));
    CHECK(std::stod(m[3]) == Approx(219.5).margin(1.0));
    CHECK(std::stod(m[4]) == Approx(125.0).margin(1.0));
  };
  SECTION("ground-truth poses") {
    job.poses_path = dir + "/gt.csv";
    three_flagged(RunMapCheck(job));
  }
  SECTION("self-localised") { three_flagged(RunMapCheck(job)); }
  SECTION("the same faults in a map measured to 0.5 cm, whose corners are all a little off") {
    // The frames do not depend on the survey sigma: the same room.
    SurveyError measured = sc.survey;
    measured.sigma = 0.5;
    job.map_path = dir + "/measured.yaml";
    WriteMap(job.map_path, SurveyMap(sc.map, measured).map);
    job.poses_path = dir + "/gt.csv";
    three_flagged(RunMapCheck(job));
  }
  SECTION("without the search for rectangles the map lacks, the missing one goes unseen") {
    job.poses_path = dir + "/gt.csv";
    job.options.find_unmapped = false;
    CHECK(Flagged(RunMapCheck(job)) == std::set<std::string>{"n3", "e1"});
  }
}

TEST_CASE("map check: one vertical edge per rectangle end and box corner", "[check_edges]") {
  Map m;
  MapRectangle r;
  r.id = "door-w";
  r.from = {0, 0};
  r.to = {10, 0};
  r.z1 = 20;
  m.rectangles.push_back(r);
  MapBox b;
  b.id = "crate";
  b.max = {5, 5, 5};
  b.min = {1, 1, 0};
  m.boxes.push_back(b);
  const std::vector<Landmark> landmarks = LandmarksFromMap(m);
  std::vector<int> edge_of;
  const std::vector<EdgeCheck> edges = MapEdges(landmarks, &edge_of);
  REQUIRE(edges.size() == 2 + 4);
  CHECK(edges[0].id == "door-w/from");
  CHECK(edges[0].object == "door-w");
  CHECK(edges[1].id == "door-w/to");
  CHECK(edges[2].id == "crate/x0y0");
  CHECK(edges[2].box);
  CHECK(edges[5].id == "crate/x1y1");
  CHECK(edges[5].position == Eigen::Vector2d(5, 5));
  REQUIRE(edge_of.size() == landmarks.size());
  for (size_t i = 0; i < landmarks.size(); ++i)
    CHECK(landmarks[i].id.rfind(edges[edge_of[i]].id + "-", 0) == 0);
}

TEST_CASE("map check: inputs that cannot be checked are refused with the file named", "[check_bad_input]") {
  const FaultCase& c = GetFaultCase();
  const std::string dir = test::ScratchDir("mapping_bad");
  MapCheckJob job;
  job.map_path = c.faulty_map;
  job.calib_path = c.calib;
  job.input = c.frames;
  SECTION("a poses CSV with fewer rows than frames") {
    std::ifstream in(c.gt);
    std::ofstream out(dir + "/short.csv");
    std::string line;
    for (int i = 0; i < kFrames && std::getline(in, line); ++i) out << line << "\n";  // header + 29 rows
    out.close();
    job.poses_path = dir + "/short.csv";
    Refused([&] { RunMapCheck(job); }, dir + "/short.csv: 29 rows, but " + c.frames + " has more frames");
  }
  SECTION("a poses CSV whose frames skip one") {
    std::ifstream in(c.gt);
    std::ofstream out(dir + "/skip.csv");
    std::string line;
    for (int i = 0; std::getline(in, line); ++i)
      if (i != 5) out << line << "\n";
    out.close();
    job.poses_path = dir + "/skip.csv";
    Refused([&] { RunMapCheck(job); }, "row 5 is frame 5, expected frame 4");
  }
  SECTION("no landmark in view in any frame") {
    job.pose = Pose2{110, 110, 0};
    Map m = ReadMap(c.true_map);
    m.rectangles = {m.rectangles.front()};
    m.rectangles.front().z0 = 190;  // above the mirror's view
    m.rectangles.front().z1 = 199;
    job.map_path = dir + "/high.yaml";
    WriteMap(job.map_path, m);
    Refused([&] { RunMapCheck(job); }, dir + "/high.yaml: no landmark is in view in any of the 30 frames");
  }
  SECTION("missing files") {
    job.map_path = dir + "/none.yaml";
    Refused([&] { RunMapCheck(job); }, dir + "/none.yaml");
    job.map_path = c.faulty_map;
    job.input = dir + "/none.mp4";
    Refused([&] { RunMapCheck(job); }, dir + "/none.mp4");
  }
  SECTION("--pose and --poses together") {
    job.pose = Pose2{110, 110, 0};
    job.poses_path = c.gt;
    Refused([&] { RunMapCheck(job); }, "--pose and --poses");
  }
}

}  // namespace
}  // namespace pano

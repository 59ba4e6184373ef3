// panomap check's library on a rendered sequence of the paper-real room:
// a map with three deliberate faults (one rectangle moved 5 cm, one shade
// inverted, one rectangle that is not in the room) must be flagged on those
// three and no other, from the ground-truth poses and self-localised.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "expect_error.h"
#include "panotrack/io/map.h"
#include "panotrack/mapping/check.h"
#include "panotrack/render/presets.h"
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
    w.quiet = true;
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

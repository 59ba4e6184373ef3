// Growing a map from video: a rendered run with only four seed rectangles
// recovers the removed ones; bad inputs fail with one line, non-zero exit
// and nothing written.
#include "panotrack/pipeline/panomap.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "expect_error.h"
#include "panotrack/io/map.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

// Every `stride`-th of the first `count` frames of paper-real as PNG frames,
// with its true map and gt.csv, and the seed: the true map with only
// s2, e2, n2 and w2 (one rectangle per wall).
std::string RenderPaperReal(const std::string& name, int stride, int count) {
  SequenceCase c = MakePreset("paper-real");
  std::vector<Pose2> poses;
  for (int i = 0; i < count; ++i) poses.push_back(c.poses[static_cast<size_t>(i * stride)]);
  c.poses = poses;
  const std::string dir = test::ScratchDir(name) + "/seq";
  SequenceWriteOptions wo;
  wo.frames = true;
  wo.video = false;
  WriteSequence(c, dir, wo);
  Map seed = ReadMap(dir + "/map.yaml");
  const std::set<std::string> keep = {"s2", "e2", "n2", "w2"};
  seed.rectangles.erase(std::remove_if(seed.rectangles.begin(), seed.rectangles.end(),
                                       [&](const MapRectangle& r) { return !keep.count(r.id); }),
                        seed.rectangles.end());
  WriteMap(dir + "/seed.yaml", seed);
  return dir;
}

// Largest distance between the four corners of two rectangles, with the
// end points matched either way round.
double WorstCornerError(const MapRectangle& a, const MapRectangle& b) {
  double best = 1e300;
  for (bool flip : {false, true}) {
    const Eigen::Vector2d b_from = flip ? b.to : b.from, b_to = flip ? b.from : b.to;
    double worst = 0;
    for (const auto& ends : {std::make_pair(a.from, b_from), std::make_pair(a.to, b_to)})
      for (const auto& z : {std::make_pair(a.z0, b.z0), std::make_pair(a.z1, b.z1)})
        worst = std::max(worst, std::hypot((ends.first - ends.second).norm(), z.first - z.second));
    best = std::min(best, worst);
  }
  return best;
}

MapBuildJob JobFor(const std::string& dir, const std::string& seed, const std::string& poses) {
  MapBuildJob job;
  job.map_path = seed;
  job.calib_path = dir + "/calib.yaml";
  job.input = dir + "/frames/frame_%04d.png";
  job.poses_path = poses;
  job.output = dir + "/grown.yaml";
  job.report_csv = dir + "/report.csv";
  return job;
}

TEST_CASE("a rendered run recovers the rectangles removed from the map", "[build_rendered]") {
  const std::string dir = RenderPaperReal("build_rendered", 2, 29);
  const Map truth = ReadMap(dir + "/map.yaml");
  // Three frames lost (as a localiser reports them): skipped.
  {
    std::ifstream in(dir + "/gt.csv");
    std::ofstream out(dir + "/lost.csv");
    std::string line;
    for (int i = -1; std::getline(in, line); ++i) {
      if (i == 3 || i == 10 || i == 17) {  // frame,time_s,,,,lost,0,
        const size_t time_end = line.find(',', line.find(',') + 1);
        line = line.substr(0, time_end) + ",,,,lost,0,";
      }
      out << line << "\n";
    }
  }
  const MapBuildResult r = RunMapBuild(JobFor(dir, dir + "/seed.yaml", dir + "/lost.csv"));
  INFO(FormatMapBuildReport(r));
  CHECK(r.frames == 29);
  CHECK(r.frames_with_pose == 26);
  const Map grown = ReadMap(dir + "/grown.yaml");
  // The seed is kept as it was, new rectangles follow it.
  REQUIRE(grown.rectangles.size() == 4 + r.rectangles.size());
  for (size_t i = 0; i < 4; ++i)
    CHECK(WorstCornerError(grown.rectangles[i], ReadMap(dir + "/seed.yaml").rectangles[i]) == 0.0);
  // Each removed rectangle (9) matched to the nearest new one.
  int recovered = 0;
  double worst = 0;
  std::set<std::string> matched;
  for (const MapRectangle& t : truth.rectangles) {
    if (t.id == "s2" || t.id == "e2" || t.id == "n2" || t.id == "w2") continue;
    const MapRectangle* best = nullptr;
    double err = 1e300;
    for (const BuiltRectangle& b : r.rectangles) {
      const double e = WorstCornerError(t, b.rectangle);
      if (e < err && !matched.count(b.rectangle.id)) {
        err = e;
        best = &b.rectangle;
      }
    }
    if (best == nullptr || err > 5.0) continue;
    matched.insert(best->id);
    ++recovered;
    worst = std::max(worst, err);
    CHECK(std::isnan(best->shade));  // learnt by the localiser
  }
  INFO("recovered " << recovered << ", worst corner error " << worst << " cm");
  // Measured: all 9 removed rectangles, none spurious; worst corner error
  // 0.316 cm over 36 corners (0.43 cm from all 57 frames).
  CHECK(recovered == 9);
  CHECK(r.rectangles.size() == 9);
  CHECK(worst == Approx(0.316).margin(0.04));
  CHECK(std::filesystem::exists(dir + "/report.csv"));
}

TEST_CASE("bad inputs: one line, non-zero exit, nothing written", "[build_bad_input]") {
  const std::string dir = RenderPaperReal("build_bad_input", 5, 8);
  // A pose CSV with a row missing.
  {
    std::ifstream in(dir + "/gt.csv");
    std::ofstream out(dir + "/short.csv");
    std::string line;
    for (int i = 0; i < 8 && std::getline(in, line); ++i) out << line << "\n";
  }
  test::ExpectError([&] { RunMapBuild(JobFor(dir, dir + "/seed.yaml", dir + "/short.csv")); }, dir + "/short.csv",
                    {"7 rows, but", "has more frames"});
  CHECK(!std::filesystem::exists(dir + "/grown.yaml"));
  // A seed whose landmarks are all above the mirror's view: none in view.
  Map high = ReadMap(dir + "/seed.yaml");
  for (MapRectangle& rect : high.rectangles) {
    rect.z0 = 185;
    rect.z1 = 195;
  }
  WriteMap(dir + "/high.yaml", high);
  test::ExpectError([&] { RunMapBuild(JobFor(dir, dir + "/high.yaml", dir + "/gt.csv")); }, dir + "/high.yaml",
                    {"no seed landmark is in view in any of the 8 frames"});
  CHECK(!std::filesystem::exists(dir + "/grown.yaml"));
  CHECK(!std::filesystem::exists(dir + "/report.csv"));
  // The program: exit 1, one line, nothing written.
  const std::string common =
      " --calib " + dir + "/calib.yaml " + dir + "/frames/frame_%04d.png -o " + dir + "/out.yaml";
  test::CommandRun run =
      test::RunProgram("panomap build --map " + dir + "/seed.yaml --poses " + dir + "/short.csv" + common);
  CHECK(run.code == 1);
  CHECK(test::CountLines(run.out) == 1);
  CHECK(run.out.find("panomap: " + dir + "/short.csv: 7 rows") == 0);
  run = test::RunProgram("panomap build --map " + dir + "/high.yaml --poses " + dir + "/gt.csv" + common);
  CHECK(run.code == 1);
  CHECK(test::CountLines(run.out) == 1);
  CHECK(run.out.find("no seed landmark is in view") != std::string::npos);
  run = test::RunProgram("panomap build --map " + dir + "/seed.yaml --poses " + dir + "/gt.csv --start 1,2,0" + common);
  CHECK(run.code == 1);
  CHECK(run.out.find("--start and --poses") != std::string::npos);
  CHECK(!std::filesystem::exists(dir + "/out.yaml"));
  // A good run prints the counts and writes the map.
  run = test::RunProgram("panomap build -q --map " + dir + "/seed.yaml --poses " + dir + "/gt.csv" + common);
  INFO(run.out);
  CHECK(run.code == 0);
  CHECK(run.out.find("candidate edges: ") != std::string::npos);
  CHECK(std::filesystem::exists(dir + "/out.yaml"));
}

}  // namespace
}  // namespace pano

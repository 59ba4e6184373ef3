// panomap check as users run it: the table and findings on stdout with exit
// status 0 (findings are results), and exit 1 with one line naming the file
// for inputs it cannot check.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <string>

#include "panotrack/io/map.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

bool Contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST_CASE("panomap check: exit 0 with the findings, exit 1 and one line for bad inputs", "[check_cli]") {
  const std::string dir = test::ScratchDir("panomap_cli");
  SequenceCase sc = MakePreset("paper-real");
  sc.poses.resize(10);
  SequenceWriteOptions w;
  w.frames = true;
  WriteSequence(sc, dir + "/seq", w);
  const std::string seq = dir + "/seq";
  Map m = ReadMap(seq + "/map.yaml");
  for (MapRectangle& r : m.rectangles)
    if (r.id == "s1") r.shade = 0.9;  // inverted
  WriteMap(dir + "/inverted.yaml", m);
  const std::string common = " --calib " + seq + "/calib.yaml " + seq + "/video.mp4";

  test::CommandRun r = test::RunProgram("panomap check --map " + dir + "/inverted.yaml" + common + " --poses " + seq +
                                        "/gt.csv -o " + dir + "/o.png --report " + dir + "/r.csv");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK(Contains(r.out, "s1: shade looks inverted"));
  CHECK(Contains(r.out, "1 finding\n"));
  CHECK(std::filesystem::exists(dir + "/o.png"));
  // The outputs exist: nothing is done without --force.
  r = test::RunProgram("panomap check --map " + dir + "/inverted.yaml" + common + " --poses " + seq + "/gt.csv -o " +
                       dir + "/o.png");
  CHECK(r.code == 1);
  CHECK(r.out == "panomap: " + dir + "/o.png exists (use --force to replace it)\n");
  // One image at one pose; -q: the findings only.
  r = test::RunProgram("panomap check -q --map " + dir + "/inverted.yaml --calib " + seq + "/calib.yaml " + seq +
                       "/frames/frame_0000.png --pose 40,35,0");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(Contains(r.out, "s1: shade looks inverted"));

  // A poses CSV of another length.
  {
    std::ifstream in(seq + "/gt.csv");
    std::ofstream out(dir + "/short.csv");
    std::string line;
    for (int i = 0; i < 6 && std::getline(in, line); ++i) out << line << "\n";
  }
  r = test::RunProgram("panomap check --map " + seq + "/map.yaml" + common + " --poses " + dir + "/short.csv");
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(Contains(r.out, "panomap: " + dir + "/short.csv: 5 rows, but " + seq + "/video.mp4 has more frames"));
  // No landmark in view: a pose outside the room's walls is refused; a map
  // whose landmarks are all above the mirror's view has none in view.
  m = ReadMap(seq + "/map.yaml");
  for (MapRectangle& rect : m.rectangles) {
    rect.z0 = 185;
    rect.z1 = 195;
  }
  WriteMap(dir + "/high.yaml", m);
  r = test::RunProgram("panomap check --map " + dir + "/high.yaml" + common + " --pose 110,110,0");
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(Contains(r.out, "panomap: " + dir + "/high.yaml: no landmark is in view in any of the 10 frames"));
  // Missing files.
  r = test::RunProgram("panomap check --map " + dir + "/none.yaml" + common);
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(Contains(r.out, dir + "/none.yaml"));
  r = test::RunProgram("panomap check --map " + seq + "/map.yaml --calib " + seq + "/calib.yaml " + dir + "/none.mp4");
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(Contains(r.out, dir + "/none.mp4"));
  r = test::RunProgram("panomap check --map " + seq + "/map.yaml" + common + " --pose 1,2");
  CHECK(r.code == 1);
  CHECK(Contains(r.out, "--pose"));
}

}  // namespace
}  // namespace pano

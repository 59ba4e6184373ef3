// No program replaces a file it reads, --force or not: every output flag
// against every kind of input (a folder's or a pattern's frames, a target
// file's board images, panosim's inputs under its output folder). A refused
// run exits 1 with one line naming the output and the input, and leaves the
// input as it was.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "panotrack/io/map.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

std::string Bytes(const std::string& path) {
  std::ostringstream text;
  text << std::ifstream(path, std::ios::binary).rdbuf();
  return text.str();
}

// Runs `args`, which must be refused for writing over `input`: exit 1, one
// line that names `output_flag output` and `input`, and `input` unchanged.
void ExpectRefused(const std::string& args, const std::string& output_flag, const std::string& output,
                   const std::string& input) {
  const std::string before = Bytes(input);
  REQUIRE_FALSE(before.empty());
  const test::CommandRun r = test::RunProgram(args);
  INFO(args);
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(r.out.find(output_flag + " " + output + ": ") != std::string::npos);
  CHECK(r.out.find("the input " + input) != std::string::npos);
  CHECK(Bytes(input) == before);
}

// A short rendered sequence with its frames: DIR/seq/{map,calib}.yaml,
// DIR/seq/frames/frame_%04d.png.
std::string FramesCase(const std::string& dir) {
  SequenceCase sc = MakePreset("paper-real");
  sc.poses.resize(4);
  SequenceWriteOptions w;
  w.frames = true;
  w.video = false;
  WriteSequence(sc, dir + "/seq", w);
  return dir + "/seq";
}

TEST_CASE("panoloc and panomap check: no output over a frame of a folder or pattern input", "[output_guard]") {
  const std::string dir = test::ScratchDir("apps_guard_frames");
  const std::string seq = FramesCase(dir), frames = seq + "/frames";
  const std::string files = " --calib " + seq + "/calib.yaml --map " + seq + "/map.yaml";
  const std::string f1 = frames + "/frame_0001.png", f2 = frames + "/frame_0002.png";
  ExpectRefused("panoloc " + frames + files + " -o " + f1 + " --force", "-o", f1, f1);
  ExpectRefused("panoloc " + frames + files + " -o " + dir + "/est.csv --plot " + f2 + " --force", "--plot", f2, f2);
  ExpectRefused("panoloc '" + frames + "/frame_%04d.png'" + files + " -o " + f2 + " --force", "-o", f2, f2);
  ExpectRefused("panoloc " + frames + files + " -o " + dir + "/est.csv --tum " + f1 + " --force", "--tum", f1, f1);
  // Another name for a frame is the same file.
  fs::create_hard_link(f1, dir + "/hard.png");
  fs::create_symlink(f2, dir + "/soft.png");
  ExpectRefused("panoloc " + frames + files + " -o " + dir + "/hard.png --force", "-o", dir + "/hard.png", f1);
  ExpectRefused("panoloc " + frames + files + " -o " + dir + "/soft.png --force", "-o", dir + "/soft.png", f2);
  ExpectRefused("panomap check --map " + seq + "/map.yaml --calib " + seq + "/calib.yaml " + frames +
                    " --pose 40,35,0 -o " + f2 + " --force",
                "-o", f2, f2);
  ExpectRefused("panomap check --map " + seq + "/map.yaml --calib " + seq + "/calib.yaml " + frames +
                    " --pose 40,35,0 --report " + f1 + " --force",
                "--report", f1, f1);
  CHECK_FALSE(fs::exists(dir + "/est.csv"));
}

TEST_CASE("panoloc: no output over the case.yaml whose initial pose it reads", "[output_guard]") {
  const std::string dir = test::ScratchDir("apps_guard_case");
  const std::string seq = FramesCase(dir), frames = seq + "/frames";
  REQUIRE(fs::exists(seq + "/case.yaml"));
  const std::string files = " --calib " + seq + "/calib.yaml --map " + seq + "/map.yaml -o " + dir + "/est.csv";
  ExpectRefused("panoloc " + frames + files + " --summary-json " + seq + "/case.yaml --force", "--summary-json",
                seq + "/case.yaml", seq + "/case.yaml");
  ExpectRefused("panoloc " + frames + files + " --plot " + seq + "/case.yaml --force", "--plot", seq + "/case.yaml",
                seq + "/case.yaml");
  CHECK_FALSE(fs::exists(dir + "/est.csv"));
  // With --init the case.yaml is not read, and may be written over.
  const test::CommandRun r =
      test::RunProgram("panoloc " + frames + files + " --init 40,35,0 -q --summary-json " + seq + "/case.yaml --force");
  INFO(r.out);
  CHECK(r.code == 0);
}

TEST_CASE("panocalib calibrate and evaluate: no output over a board image", "[output_guard]") {
  const std::string dir = test::ScratchDir("apps_guard_boards");
  const std::string calib = test::SourcePath("calib/paper-real.yaml");
  const test::CommandRun made =
      test::RunProgram("panosim targets --calib " + calib + " --board 9,6,3 --auto 4 -q -o " + dir + "/t");
  INFO(made.out);
  REQUIRE(made.code == 0);
  const std::string t = dir + "/t", targets = t + "/targets.yaml";
  const std::string c1 = t + "/cal_001.png", c2 = t + "/cal_002.png", c3 = t + "/cal_003.png";
  ExpectRefused("panocalib calibrate " + targets + " -o " + c1 + " --force", "-o", c1, c1);
  ExpectRefused("panocalib calibrate " + targets + " -o " + dir + "/c.yaml --report " + c2 + " --force", "--report",
                c2, c2);
  ExpectRefused("panocalib calibrate " + targets + " -o " + dir + "/c.yaml --lut " + c3 + " --force", "--lut", c3,
                c3);
  ExpectRefused("panocalib calibrate " + targets + " -o " + dir + "/c.yaml --summary-json " + c1 + " --force",
                "--summary-json", c1, c1);
  ExpectRefused("panocalib calibrate " + t + " --board 9x6 --square 3 -o " + c2 + " --force", "-o", c2, c2);
  ExpectRefused("panocalib evaluate --calib " + t + "/truth.yaml " + targets + " --summary-json " + c3 + " --force",
                "--summary-json", c3, c3);
  CHECK_FALSE(fs::exists(dir + "/c.yaml"));
}

TEST_CASE("panosim: an output folder that holds an input is refused, --force or not", "[output_guard]") {
  const std::string dir = test::ScratchDir("apps_guard_panosim");
  const std::string d = dir + "/d";
  fs::create_directories(d);
  fs::copy_file(test::SourcePath("calib/paper-real.yaml"), d + "/calib.yaml");
  WriteMap(d + "/map.yaml", MakePreset("paper-real").map);
  std::ofstream(d + "/traj.csv") << "x,y,theta\n40,35,0\n41,35,0.1\n";
  const std::string calib_before = Bytes(d + "/calib.yaml");
  for (const char* force : {"", " --force"}) {
    const test::CommandRun r = test::RunProgram("panosim sequence --map " + d + "/map.yaml --calib " + d +
                                                "/calib.yaml --trajectory " + d + "/traj.csv -o " + d + force);
    INFO(r.out);
    CHECK(r.code == 1);
    CHECK(test::CountLines(r.out) == 1);
    CHECK(r.out.find("-o " + d + ": replacing this folder would delete the input " + d + "/map.yaml (--map)") !=
          std::string::npos);
  }
  // One input in the folder, reached through a link from outside it; the
  // folder spelt otherwise.
  fs::copy_file(d + "/calib.yaml", dir + "/calib.yaml");
  fs::copy_file(d + "/map.yaml", dir + "/map.yaml");
  fs::create_symlink(d + "/traj.csv", dir + "/traj.csv");
  const test::CommandRun linked = test::RunProgram("panosim sequence --map " + dir + "/map.yaml --calib " + dir +
                                                   "/calib.yaml --trajectory " + dir + "/traj.csv -o " + dir +
                                                   "/./d/ --force");
  INFO(linked.out);
  CHECK(linked.code == 1);
  CHECK(linked.out.find("would delete the input " + dir + "/traj.csv (--trajectory)") != std::string::npos);
  const test::CommandRun targets = test::RunProgram("panosim targets --calib " + d +
                                                    "/calib.yaml --board 9,6,3 --auto 2 -q -o " + d + " --force");
  INFO(targets.out);
  CHECK(targets.code == 1);
  CHECK(targets.out.find("would delete the input " + d + "/calib.yaml (--calib)") != std::string::npos);
  CHECK(Bytes(d + "/calib.yaml") == calib_before);
  CHECK(fs::exists(d + "/traj.csv"));
  CHECK(fs::exists(d + "/map.yaml"));
}

}  // namespace
}  // namespace pano

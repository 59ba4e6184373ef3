// Bad input to panosim: a one-line error naming the file or option, a
// non-zero exit, and nothing half-written.
#include <catch2/catch.hpp>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "panotrack/core/error.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

struct Run {
  int code;
  std::string output;
};

Run Panosim(const std::string& args) {
  const char* bin = std::getenv("PANO_BIN_DIR");
  REQUIRE(bin != nullptr);
  const std::string cmd = std::string(bin) + "/panosim " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p != nullptr);
  std::string out;
  char buf[512];
  while (std::fgets(buf, sizeof(buf), p)) out += buf;
  const int st = pclose(p);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

void Write(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

void ExpectOneLineError(const Run& r, const std::string& needle1, const std::string& needle2) {
  INFO(r.output);
  CHECK(r.code == 1);
  CHECK(r.output.rfind("panosim: ", 0) == 0);
  CHECK(std::count(r.output.begin(), r.output.end(), '\n') == 1);
  CHECK(r.output.find(needle1) != std::string::npos);
  CHECK(r.output.find(needle2) != std::string::npos);
}

TEST_CASE("bad input: clear one-line errors, non-zero exit, nothing written", "[bad_input]") {
  const std::string dir = test::ScratchDir("render_bad_input");
  const std::string calib = test::SourcePath("calib/paper-synthetic.yaml");
  const std::string good_map = dir + "/room.yaml";
  Write(good_map,
        "units: units\nsensor_height: 30\nroom:\n  min: [0, 0]\n  max: [200, 200]\n  height: 120\n"
        "rectangles:\n  - id: door\n    from: [0.5, 50]\n    to: [0.5, 90]\n    z: [0, 100]\n    shade: 0.1\n");

  // Unknown preset.
  Run r = Panosim("sequence --preset paper-fake -o " + dir + "/seq");
  ExpectOneLineError(r, "--preset", "paper-fake");
  CHECK_FALSE(fs::exists(dir + "/seq"));

  // Malformed map: YAML syntax, then a bad key.
  Write(dir + "/broken.yaml", "units: cm\nsensor_height: [30\nroom: {\n");
  r = Panosim("still --map " + dir + "/broken.yaml --calib " + calib + " --pose 100,100,0 -o " + dir + "/a.png");
  ExpectOneLineError(r, "broken.yaml", "");
  CHECK_FALSE(fs::exists(dir + "/a.png"));
  Write(dir + "/badrect.yaml",
        "units: cm\nsensor_height: 30\nrectangles:\n  - id: r\n    from: [0, 0]\n    to: [10, 0]\n    z: [50, 10]\n");
  r = Panosim("still --map " + dir + "/badrect.yaml --calib " + calib + " --pose 100,100,0 -o " + dir + "/a.png");
  ExpectOneLineError(r, "badrect.yaml", "rectangles[0].z");

  // Pose outside the room, malformed pose.
  r = Panosim("still --map " + good_map + " --calib " + calib + " --pose 250,100,0 -o " + dir + "/a.png");
  ExpectOneLineError(r, "--pose", "outside the room");
  CHECK_FALSE(fs::exists(dir + "/a.png"));
  r = Panosim("still --map " + good_map + " --calib " + calib + " --pose 100,abc -o " + dir + "/a.png");
  ExpectOneLineError(r, "--pose", "abc");

  // A trajectory that leaves the room: error names the file and pose, no folder left.
  Write(dir + "/traj.csv", "x,y,theta\n100,100,0\n150,120,0.1\n210,120,0.2\n");
  r = Panosim("sequence --map " + good_map + " --calib " + calib + " --trajectory " + dir + "/traj.csv -q -o " + dir + "/seq");
  ExpectOneLineError(r, "traj.csv", "pose 3");
  CHECK_FALSE(fs::exists(dir + "/seq"));
  Write(dir + "/traj2.csv", "x,y\n100,100\n");
  r = Panosim("sequence --map " + good_map + " --calib " + calib + " --trajectory " + dir + "/traj2.csv -q -o " + dir + "/seq");
  ExpectOneLineError(r, "traj2.csv", "line 1");

  // Bad options and a missing calibration.
  r = Panosim("still --preset paper-synthetic --supersample 0 -o " + dir + "/a.png");
  ExpectOneLineError(r, "supersample", "1..8");
  r = Panosim("still --map " + good_map + " --calib " + dir + "/nope.yaml --pose 100,100,0 -o " + dir + "/a.png");
  ExpectOneLineError(r, "nope.yaml", "");
  r = Panosim("sequence --preset paper-synthetic --exposure 1.5 -q -o " + dir + "/seq");
  ExpectOneLineError(r, "exposure", "0..1");
  r = Panosim("sequence --preset paper-synthetic --people 51 -q -o " + dir + "/seq");
  ExpectOneLineError(r, "people", "0..50");
  r = Panosim("sequence --preset paper-synthetic --dropped-frames 20 --covered-frames 20 -q -o " + dir + "/seq");
  ExpectOneLineError(r, "preset 'paper-synthetic'", "do not fit");
  r = Panosim("still --preset paper-synthetic --texture -0.1 -o " + dir + "/a.png");
  ExpectOneLineError(r, "texture", "0..1");
  CHECK_FALSE(fs::exists(dir + "/seq"));
  r = Panosim("targets --calib " + calib + " --board 9,6 --auto 2 -o " + dir + "/cal");
  ExpectOneLineError(r, "--board", "cols,rows,square");
  CHECK_FALSE(fs::exists(dir + "/cal"));
  r = Panosim("targets --calib " + calib + " --board 9,6,3 --auto 0 -q -o " + dir + "/cal");
  ExpectOneLineError(r, "--auto", "positive");
  Write(dir + "/poses.csv", "rx,ry,rz,tx,ty,tz\n0,0,0,1,2\n");
  r = Panosim("targets --calib " + calib + " --board 9,6,3 --poses " + dir + "/poses.csv -q -o " + dir + "/cal");
  ExpectOneLineError(r, "poses.csv", "line 2");
  CHECK_FALSE(fs::exists(dir + "/cal"));

  // No temporary leftovers in the scratch folder.
  for (const auto& e : fs::directory_iterator(dir))
    CHECK(e.path().filename().string().find("tmp") == std::string::npos);

  // The good inputs work: a still from files, then a short sequence with frames.
  r = Panosim("still --map " + good_map + " --calib " + calib + " --pose 100,100,0.3 -o " + dir + "/ok.png");
  CHECK(r.code == 0);
  CHECK(fs::exists(dir + "/ok.png"));
  Write(dir + "/traj3.csv", "x,y,theta\n100,100,0\n102,100,0.05\n");
  r = Panosim("sequence --map " + good_map + " --calib " + calib + " --trajectory " + dir +
              "/traj3.csv --frames --supersample 1 -q -o " + dir + "/seq");
  INFO(r.output);
  CHECK(r.code == 0);
  CHECK(fs::exists(dir + "/seq/frames/frame_0001.png"));
  CHECK(fs::exists(dir + "/seq/case.yaml"));
}

TEST_CASE("library errors name the option or file", "[bad_input]") {
  CHECK_THROWS_WITH(MakePreset("nope"), Catch::Contains("unknown preset 'nope'") && Catch::Contains("paper-synthetic"));
  const SequenceCase c = MakePreset("paper-synthetic");
  CHECK_THROWS_WITH(CheckPose(c.map, {-5, 50, 0}, "--pose"), Catch::StartsWith("--pose: ") && Catch::Contains("outside the room"));
  CHECK_THROWS_WITH(CheckPose(c.map, {100, 80, 0}, "x", 500.0), Catch::Contains("closer than"));
  RenderOptions o;
  o.gradient = 2.0;
  CHECK_THROWS_WITH(o.Check("opts"), Catch::StartsWith("opts: gradient"));
  o.gradient = 0.0;
  for (auto [set, key] : std::vector<std::pair<void (*)(RenderOptions*), std::string>>{
           {[](RenderOptions* x) { x->exposure = -0.1; }, "exposure"},
           {[](RenderOptions* x) { x->blur_samples = 65; }, "blur-samples"},
           {[](RenderOptions* x) { x->auto_exposure = 1.0; }, "auto-exposure"},
           {[](RenderOptions* x) { x->texture = 1.5; }, "texture"},
           {[](RenderOptions* x) { x->people = -1; }, "people"},
           {[](RenderOptions* x) { x->covered_frames = -1; }, "covered-frames"},
           {[](RenderOptions* x) { x->dropped_frames = -1; }, "dropped-frames"}}) {
    RenderOptions bad;
    set(&bad);
    CHECK_THROWS_WITH(bad.Check("opts"), Catch::StartsWith("opts: " + key));
  }
  SequenceCase no_room = c;
  no_room.map.room.present = false;
  no_room.options.people = 1;
  CHECK_THROWS_WITH(CheckCase(no_room, "case"), Catch::Contains("people"));
  SequenceCase bad_kidnap = c;
  bad_kidnap.kidnap_frames = {10, 5};
  CHECK_THROWS_WITH(CheckCase(bad_kidnap, "case"), Catch::Contains("kidnap frames"));
}

}  // namespace
}  // namespace pano

// Inputs a careful user would not give, answered as the programs answer bad
// input: one line naming the flag, file or field and the problem, exit 1,
// no output left behind; or, where the run can go on, a clear note.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

// A short rendered sequence (8 frames of paper-real), made once.
const std::string& Sequence() {
  static const std::string seq = [] {
    const std::string dir = test::ScratchDir("apps_absurd") + "/seq";
    SequenceCase sc = MakePreset("paper-real");
    sc.poses.resize(8);
    SequenceWriteOptions w;
    w.overwrite = true;
    WriteSequence(sc, dir, w);
    return dir;
  }();
  return seq;
}

std::string Read(const std::string& path) {
  std::ostringstream text;
  text << std::ifstream(path).rdbuf();
  return text.str();
}

// panoloc on the sequence with `args` added; `--calib`/`--map` as given or the sequence's.
test::CommandRun Panoloc(const std::string& args, const std::string& calib = "", const std::string& map = "") {
  const std::string& seq = Sequence();
  return test::RunProgram("panoloc " + seq + "/video.mp4 --calib " + (calib.empty() ? seq + "/calib.yaml" : calib) +
                          " --map " + (map.empty() ? seq + "/map.yaml" : map) + " -q " + args);
}

void ExpectOneLineError(const test::CommandRun& r, const std::string& part) {
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(r.out.find(part) != std::string::npos);
}

TEST_CASE("--out-dir naming a file: one line naming the option", "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_outdir");
  std::ofstream(dir + "/od") << "not a folder\n";
  test::CommandRun r = Panoloc("--out-dir " + dir + "/od");
  ExpectOneLineError(r, "panoloc: --out-dir: " + dir + "/od is a file, not a folder");
  r = Panoloc("--out-dir " + dir + "/od/sub");
  ExpectOneLineError(r, "panoloc: --out-dir: " + dir + "/od is a file, not a folder");
  CHECK(Read(dir + "/od") == "not a folder\n");
}

// `path`'s text with the first line starting with `key` replaced by `line`, written to `out`.
void WriteWithLine(const std::string& path, const std::string& key, const std::string& line,
                   const std::string& out) {
  std::istringstream in(Read(path));
  std::ofstream o(out);
  bool done = false;
  for (std::string l; std::getline(in, l);) {
    const bool match = !done && l.find(key) != std::string::npos;
    o << (match ? line : l) << "\n";
    done = done || match;
  }
  REQUIRE(done);
}

TEST_CASE("absurd values in files: the field named, by what it means", "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_files");
  const std::string& seq = Sequence();
  WriteWithLine(seq + "/calib.yaml", "cx:", "cx: 1e308", dir + "/calib.yaml");
  ExpectOneLineError(Panoloc("-o " + dir + "/a.csv", dir + "/calib.yaml"),
                     "panoloc: " + dir + "/calib.yaml: cx: expected the principal point inside the image");
  CHECK_FALSE(fs::exists(dir + "/a.csv"));
  WriteWithLine(seq + "/calib.yaml", "cy:", "cy: -3", dir + "/calib_cy.yaml");
  ExpectOneLineError(test::RunProgram("panocalib project --calib " + dir + "/calib_cy.yaml --point 100,0,-10"),
                     "cy: expected the principal point inside the image");
  // A corner 1e300 away: the rectangle named, not a distance range of the table.
  WriteWithLine(seq + "/map.yaml", "from:", "    from: [1e300, 60.0]", dir + "/map.yaml");
  ExpectOneLineError(Panoloc("-o " + dir + "/b.csv", "", dir + "/map.yaml"),
                     "panoloc: " + dir + "/map.yaml: rectangles[0].from ('");
  ExpectOneLineError(Panoloc("-o " + dir + "/b.csv", "", dir + "/map.yaml"),
                     "expected coordinates within +-1e6 map units, got 1e+300");
  CHECK_FALSE(fs::exists(dir + "/b.csv"));
}

TEST_CASE("absurd values of flags: the flag named, with the value given", "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_flags");
  const std::string out = " -o " + dir + "/a.csv";
  ExpectOneLineError(Panoloc(out + " --fps 1e-300"), "panoloc: --fps (fps): expected 0 (the input's timestamps) or "
                                                    "a frame rate from 0.0001 to 100000 frames/s, got 1e-300");
  ExpectOneLineError(Panoloc(out + " --fps 1e300"), "got 1e+300");
  ExpectOneLineError(Panoloc(out + " --search-px -1"),
                     "panoloc: --search-px: expected a half-width above 0 and at most 20 px, got -1");
  ExpectOneLineError(Panoloc(out + " --min-step 0"), "panoloc: --min-step: expected an intensity step above 0");
  CHECK_FALSE(fs::exists(dir + "/a.csv"));
}

TEST_CASE("huge flag values: refused under the flag's name, nothing written", "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_huge");
  const std::string& seq = Sequence();
  ExpectOneLineError(Panoloc("-o " + dir + "/a.csv --tum " + dir + "/a.tum --tum-scale 1e300"),
                     "panoloc: --tum-scale (tum_scale): expected a positive number of metres per map unit up to "
                     "1e+06, or 0 for the map's units, got 1e+300");
  CHECK_FALSE(fs::exists(dir + "/a.csv"));
  ExpectOneLineError(test::RunProgram("panomap check " + seq + "/video.mp4 --map " + seq + "/map.yaml --calib " +
                                      seq + "/calib.yaml --pose 40,35,0 --search 1e300"),
                     "panomap: --search: expected a value from 0.5 to 2000, got 1e300");
  const std::string still = "panosim still --preset paper-real --supersample 1 -o " + dir + "/s.png ";
  ExpectOneLineError(test::RunProgram(still + "--noise 1e300"),
                     "panosim: options: noise: expected a noise sigma of 0..255 grey levels");
  ExpectOneLineError(test::RunProgram(still + "--distortion 1e300,0"),
                     "panosim: --distortion: expected coefficients within +-10, got 1e+300,0");
  ExpectOneLineError(test::RunProgram(still + "--camera-tilt 1000,0"),
                     "panosim: --camera-tilt: expected angles within +-28.6 degrees (0.5 rad), got 1000,0");
  CHECK_FALSE(fs::exists(dir + "/s.png"));
  const std::string targets = "panosim targets --preset paper-real --supersample 1 -o " + dir + "/t ";
  ExpectOneLineError(test::RunProgram(targets + "--board 6,4,2 --auto 100000000"),
                     "panosim: --auto: expected at most 1000 images, got 100000000");
  ExpectOneLineError(test::RunProgram(targets + "--board 6,4,2 --auto 3 --charuco 1 --dictionary DICT_BOGUS"),
                     "panosim: --dictionary: unknown ArUco dictionary 'DICT_BOGUS'");
  ExpectOneLineError(test::RunProgram(targets + "--board 100000,100000,2 --auto 3"),
                     "panosim: --board: expected 2..1000 inner corners along each side, got 100000 x 100000");
  CHECK_FALSE(fs::exists(dir + "/t"));
}

TEST_CASE("flags whose options a library checks: the flag named, not the field", "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_fields");
  const std::string& seq = Sequence();
  const std::string files = " --calib " + seq + "/calib.yaml --map " + seq + "/map.yaml ";
  const std::string tilt = "panocalib tilt " + seq + "/video.mp4" + files + "-o " + dir + "/t.yaml ";
  ExpectOneLineError(test::RunProgram(tilt + "--frames 0"), "panocalib: --frames: expected 5 or more, got 0");
  ExpectOneLineError(test::RunProgram(tilt + "--step -1"), "panocalib: --step: expected a positive angle");
  ExpectOneLineError(test::RunProgram(tilt + "--tolerance 2 --step 1"),
                     "panocalib: --tolerance: expected a positive angle below --step (1 degrees), got 2");
  ExpectOneLineError(test::RunProgram(tilt + "--max-trials -4"), "panocalib: --max-trials: expected 3 or more");
  const std::string unwarp =
      "panocalib unwarp " + seq + "/video.mp4 --calib " + seq + "/calib.yaml -o " + dir + "/u.png ";
  ExpectOneLineError(test::RunProgram(unwarp + "--perspective --fov 180"),
                     "panocalib: --fov: expected 0 < fov <= 170 degrees, got 180");
  ExpectOneLineError(test::RunProgram(unwarp + "--elevation 50,-50"),
                     "panocalib: --elevation: expected MIN,MAX with MIN below MAX (degrees), got 50,-50");
  ExpectOneLineError(test::RunProgram(unwarp + "--size 100000x100"),
                     "panocalib: --size: expected WxH of 2..65536 pixels each, got 100000x100");
  ExpectOneLineError(test::RunProgram(unwarp + "--distance -5"), "panocalib: --distance: expected a distance >= 0");
  ExpectOneLineError(
      test::RunProgram("panocalib export --opencv --calib " + seq + "/calib.yaml -o " + dir + "/cv.yml --distance -1"),
      "panocalib: --distance: expected a value from 0 to 1e+06, got -1");
  ExpectOneLineError(test::RunProgram("panomap build " + seq + "/video.mp4" + files + "--poses " + seq +
                                      "/gt.csv -o " + dir + "/b.yaml --max-std -1"),
                     "panomap: --max-std: expected a positive number, got -1");
  ExpectOneLineError(Panoloc("-o " + dir + "/a.csv --scale 1e-300"),
                     "panoloc: --scale 1e-300: no pixel left of the 640x480 frames of " + seq + "/calib.yaml");
  ExpectOneLineError(test::RunProgram("panosim sequence --preset paper-real -o " + dir + "/sq --fps 1e300"),
                     "panosim: --fps: expected a frame rate from 0.01 to 1000 frames/s, got 1e+300");
  for (const char* out : {"t.yaml", "u.png", "cv.yml", "b.yaml", "a.csv", "sq"}) CHECK_FALSE(fs::exists(dir + "/" + out));
}

TEST_CASE("a PNG cut short among the frames: the tool's own line, not libpng's", "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_torn");
  SequenceCase sc = MakePreset("paper-real");
  sc.poses.resize(4);
  SequenceWriteOptions w;
  w.frames = true;
  w.video = false;
  WriteSequence(sc, dir + "/seq", w);
  const std::string seq = dir + "/seq", frames = seq + "/frames", torn = frames + "/frame_0002.png";
  const std::string bytes = Read(torn);
  const std::string half = bytes.substr(0, bytes.size() / 2);
  std::ofstream(torn, std::ios::binary | std::ios::trunc) << half;
  const std::string files = " --calib " + seq + "/calib.yaml --map " + seq + "/map.yaml";
  test::CommandRun r = test::RunProgram("panoloc " + frames + files + " -q -o " + dir + "/a.csv");
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK(r.out == "panoloc: " + frames + ": incomplete: decode error at frame 2: " + torn +
                     ": a PNG cut short (its last chunk, IEND, is missing; " + std::to_string(half.size()) +
                     " bytes)\n");
  ExpectOneLineError(test::RunProgram("panomap check " + torn + files + " --pose 40,35,0"),
                     "panomap: " + torn + ": a PNG cut short");
  // A board image cut short: panocalib's calibrate and evaluate too.
  const test::CommandRun t = test::RunProgram("panosim targets --calib " + seq + "/calib.yaml --board 9,6,3 --auto 4 -q -o " + dir + "/t");
  REQUIRE(t.code == 0);
  const std::string board = dir + "/t/cal_001.png", board_bytes = Read(board);
  std::ofstream(board, std::ios::binary | std::ios::trunc) << board_bytes.substr(0, board_bytes.size() / 2);
  ExpectOneLineError(test::RunProgram("panocalib calibrate " + dir + "/t/targets.yaml -q -o " + dir + "/c.yaml"),
                     "panocalib: " + board + ": a PNG cut short");
  ExpectOneLineError(test::RunProgram("panocalib evaluate " + dir + "/t/targets.yaml --calib " + seq + "/calib.yaml"),
                     "panocalib: " + board + ": a PNG cut short");
  CHECK_FALSE(fs::exists(dir + "/c.yaml"));
}

TEST_CASE("--gt of another length than the video is refused; --gt auto without gt.csv says so",
          "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_gt");
  const std::string& seq = Sequence();
  // The header and the first 4 of the 8 rows.
  std::istringstream gt(Read(seq + "/gt.csv"));
  std::ofstream short_gt(dir + "/gt4.csv");
  std::string line;
  for (int i = 0; i < 5 && std::getline(gt, line); ++i) short_gt << line << "\n";
  short_gt.close();
  ExpectOneLineError(Panoloc("-o " + dir + "/a.csv --gt " + dir + "/gt4.csv"),
                     "panoloc: --gt " + dir + "/gt4.csv: 4 rows for the 8 frames of " + seq +
                         "/video.mp4 (one row per frame expected)");
  CHECK_FALSE(fs::exists(dir + "/a.csv"));
  // The right length: the accuracy line.
  test::CommandRun r = test::RunProgram("panoloc " + seq + "/video.mp4 --calib " + seq + "/calib.yaml --map " + seq +
                                        "/map.yaml -o " + dir + "/b.csv --gt auto");
  INFO(r.out);
  CHECK(r.out.find("frames tracked 8/8") != std::string::npos);
  // A video with no gt.csv beside it.
  fs::create_directories(dir + "/alone");
  fs::copy_file(seq + "/video.mp4", dir + "/alone/video.mp4", fs::copy_options::overwrite_existing);
  r = test::RunProgram("panoloc " + dir + "/alone/video.mp4 --calib " + seq + "/calib.yaml --map " + seq +
                       "/map.yaml -o " + dir + "/c.csv --gt auto");
  INFO(r.out);
  CHECK(r.out.find("panoloc: note: " + dir + "/alone/video.mp4: --gt auto: no gt.csv beside it, no accuracy\n") !=
        std::string::npos);
}

// The first three frames of paper-real as an image folder (no video)
// under `dir`, with `sc`'s map.
void WriteShortFolder(const SequenceCase& sc, const std::string& dir) {
  SequenceCase shortened = sc;
  shortened.poses.resize(3);
  SequenceWriteOptions w;
  w.overwrite = w.frames = true;
  w.video = false;
  WriteSequence(shortened, dir, w);
}

TEST_CASE("an image folder without --fps: a note says the frame rate taken; with --fps none", "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_rate");
  WriteShortFolder(MakePreset("paper-real"), dir + "/seq");
  const std::string run = "panoloc " + dir + "/seq/frames --calib " + dir + "/seq/calib.yaml --map " + dir +
                          "/seq/map.yaml --force -o " + dir + "/a.csv";
  const std::string note = "panoloc: note: " + dir +
                           "/seq/frames: the frames carry no times: taken as 10 frames/s (the motion model's speed "
                           "limits depend on it; --fps RATE gives the camera's)\n";
  test::CommandRun r = test::RunProgram(run);
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK(r.out.find(note) != std::string::npos);
  r = test::RunProgram(run + " --fps 5");
  CHECK(r.code == 0);
  CHECK(r.out.find("carry no times") == std::string::npos);
  // -q silences it, as every note.
  r = test::RunProgram(run + " -q");
  CHECK(r.out.empty());
}

TEST_CASE("no start pose on a measured map: a note asks for one; with --init, or on an exact map, none",
          "[absurd_inputs]") {
  const std::string dir = test::ScratchDir("apps_absurd_start");
  SequenceCase sc = MakePreset("paper-real");
  WriteShortFolder(sc, dir + "/exact");
  sc.map.survey_sigma = std::nan("");  // a map measured by hand, stating nothing
  WriteShortFolder(sc, dir + "/measured");
  for (const char* seq : {"/measured", "/exact"}) fs::remove(dir + seq + "/case.yaml");  // no start beside
  auto run = [&](const std::string& seq, const std::string& extra) {
    return test::RunProgram("panoloc " + dir + seq + "/frames --calib " + dir + seq + "/calib.yaml --map " + dir +
                            seq + "/map.yaml --fps 5 --force -o " + dir + "/a.csv" + extra);
  };
  const std::string note = "panoloc: note: " + dir + "/measured/frames: no start pose was given";
  test::CommandRun r = run("/measured", "");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK(r.out.find(note) != std::string::npos);
  r = run("/measured", " --init 40,35,0");
  CHECK(r.code == 0);
  CHECK(r.out.find("no start pose") == std::string::npos);
  r = run("/exact", "");
  CHECK(r.code == 0);
  CHECK(r.out.find("no start pose") == std::string::npos);
}

TEST_CASE("panocalib backproject --pixels - fed binary data: one line, exit 1", "[absurd_inputs]") {
  const std::string& seq = Sequence();
  const std::string bin = test::ScratchDir("apps_absurd_binary") + "/a.out";
  std::ofstream(bin, std::ios::binary) << std::string("\x7f" "ELF\x02\x01\x01\0\0\0\xff\xfe", 12);
  const test::CommandRun r =
      test::RunProgram("panocalib backproject --calib " + seq + "/calib.yaml --pixels - < " + bin);
  ExpectOneLineError(r, "panocalib: <stdin>:1: not a text file of numbers (byte 0x7F at column 1)");
}

}  // namespace
}  // namespace pano

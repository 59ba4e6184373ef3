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
    w.quiet = true;
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

}  // namespace
}  // namespace pano

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

}  // namespace
}  // namespace pano

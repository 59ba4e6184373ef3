// Thread counts on the command line: every program bounds them (0..1024),
// refusing an absurd one with one line naming the flag before any work,
// where it would otherwise start threads until memory ran out.
#include <catch2/catch.hpp>

#include <filesystem>
#include <string>

#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

void ExpectThreadsRefused(const std::string& args, const std::string& flag) {
  const test::CommandRun r = test::RunProgram(args);
  INFO(args);
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(r.out.find(flag + ": expected 0 (every core) or 1..1024, got 100000") != std::string::npos);
}

TEST_CASE("absurd thread counts are refused by every program, naming the flag", "[thread_bounds]") {
  const std::string dir = test::ScratchDir("apps_threads");
  SequenceCase sc = MakePreset("paper-real");
  sc.poses.resize(4);
  SequenceWriteOptions w;
  WriteSequence(sc, dir + "/seq", w);
  const std::string seq = dir + "/seq", files = " --calib " + seq + "/calib.yaml --map " + seq + "/map.yaml";
  ExpectThreadsRefused("panoloc " + seq + "/video.mp4" + files + " -o " + dir + "/est.csv --threads 100000",
                       "--threads (num_threads)");
  CHECK_FALSE(std::filesystem::exists(dir + "/est.csv"));
  ExpectThreadsRefused("panomap refine" + files + " " + seq + "/video.mp4 --poses " + seq + "/gt.csv -o " +
                           dir + "/refined.yaml -j 100000",
                       "--threads");
  ExpectThreadsRefused("panosim still --preset paper-real -o " + dir + "/still.png -j 100000", "-j/--jobs");
  ExpectThreadsRefused("panocalib evaluate --calib " + seq + "/calib.yaml " + seq + "/video.mp4 --board 9x6 --square 3 -j 100000",
                       "--threads");
  ExpectThreadsRefused("panocalib calibrate " + seq + "/video.mp4 --board 9x6 --square 3 -o " + dir +
                           "/c.yaml -j 100000",
                       "--threads");
}

}  // namespace
}  // namespace pano

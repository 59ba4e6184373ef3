// The output guard: outputs compared with inputs by identity (links and
// other spellings of one file), by path where a file does not exist yet; an
// output folder replaced as a whole must hold no input.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "expect_error.h"
#include "panotrack/core/output_check.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;
using test::ErrorOf;

TEST_CASE("an output that is an input under another name is refused", "[output_check]") {
  const std::string dir = test::ScratchDir("core_output_check");
  fs::create_directories(dir + "/frames");
  std::ofstream(dir + "/frames/f_0001.png") << "png";
  fs::create_hard_link(dir + "/frames/f_0001.png", dir + "/hard.png");
  fs::create_symlink(dir + "/frames/f_0001.png", dir + "/soft.png");
  const NamedPaths reads = {{"--calib", dir + "/calib.yaml"}, {"a frame of frames", dir + "/frames/f_0001.png"}};
  for (const std::string& out : {dir + "/hard.png", dir + "/soft.png", dir + "/frames/../frames/./f_0001.png"}) {
    INFO(out);
    CHECK(ErrorOf([&] { CheckOutputsDistinct(reads, {{"-o", dir + "/est.csv"}, {"--plot", out}}); }) ==
          "--plot " + out + ": the same file as the input " + dir +
              "/frames/f_0001.png (a frame of frames); refusing to overwrite it");
  }
  // Files that do not exist yet compare by path.
  CHECK(ErrorOf([&] { CheckOutputsDistinct(reads, {{"-o", dir + "/./calib.yaml"}}); }).find("(--calib)") !=
        std::string::npos);
  CHECK(ErrorOf([&] { CheckOutputsDistinct({}, {{"-o", dir + "/a.csv"}, {"--tum", dir + "/x/../a.csv"}}); }) ==
        "--tum " + dir + "/x/../a.csv: the same file as -o " + dir + "/a.csv");
  CHECK_NOTHROW(CheckOutputsDistinct(reads, {{"-o", dir + "/frames/f_0002.png"}, {"--plot", "-"}}));
  // No option lifts it.
  CHECK_THROWS_AS(CheckPlannedOutputs(reads, {{"-o", dir + "/hard.png"}}, true), Error);
}

TEST_CASE("an output folder replaced as a whole may hold no input", "[output_check]") {
  const std::string dir = test::ScratchDir("core_output_folder");
  fs::create_directories(dir + "/d/sub");
  std::ofstream(dir + "/d/sub/traj.csv") << "x,y,theta\n";
  std::ofstream(dir + "/map.yaml") << "units: cm\n";
  fs::create_symlink(dir + "/d/sub/traj.csv", dir + "/traj.csv");
  fs::create_symlink(dir + "/d", dir + "/d_link");
  const NamedPaths reads = {{"--map", dir + "/map.yaml"}, {"--trajectory", dir + "/traj.csv"}};
  CHECK(ErrorOf([&] { CheckFolderOutputHoldsNoInput(reads, "-o", dir + "/d"); }) ==
        "-o " + dir + "/d: replacing this folder would delete the input " + dir +
            "/traj.csv (--trajectory); refusing");
  CHECK_THROWS_AS(CheckFolderOutputHoldsNoInput(reads, "-o", dir + "/d_link/"), Error);
  CHECK_THROWS_AS(CheckFolderOutputHoldsNoInput({{"", dir + "/d/sub"}}, "-o", dir + "/d/sub"), Error);
  CHECK_NOTHROW(CheckFolderOutputHoldsNoInput(reads, "-o", dir + "/other"));
  CHECK_NOTHROW(CheckFolderOutputHoldsNoInput(reads, "-o", dir + "/d/sub/deeper"));
  CHECK_NOTHROW(CheckFolderOutputHoldsNoInput({{"--map", dir + "/map.yaml"}}, "-o", dir + "/d"));
}

TEST_CASE("an output folder where a file stands is refused, naming the option", "[output_check]") {
  const std::string dir = test::ScratchDir("core_output_folder");
  std::ofstream(dir + "/od") << "a file";
  CHECK(ErrorOf([&] { CreateOutputFolder(dir + "/od", "--out-dir"); }) ==
        "--out-dir: " + dir + "/od is a file, not a folder");
  CHECK(ErrorOf([&] { CreateOutputFolder(dir + "/od/sub", "--out-dir"); }) ==
        "--out-dir: " + dir + "/od is a file, not a folder (in the path " + dir + "/od/sub)");
  CreateOutputFolder(dir + "/new/sub", "--out-dir");
  CHECK(fs::is_directory(dir + "/new/sub"));
  CHECK_NOTHROW(CreateOutputFolder(dir + "/new/sub", "--out-dir"));  // already there
}

}  // namespace
}  // namespace pano

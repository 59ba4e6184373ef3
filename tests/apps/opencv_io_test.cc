// OpenCV's image and video I/O is a module that panoloc loads only when an
// input or output needs it (video/opencv_io.h): videos decode without it.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <string>

#include "run_command.h"
#include "test_paths.h"
#include "test_skip.h"

namespace pano {
namespace {

using test::RunProgram;

std::string ShellOutput(const std::string& cmd) {
  std::string out;
  FILE* p = popen((cmd + " 2>/dev/null").c_str(), "r");
  if (!p) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  pclose(p);
  return out;
}

TEST_CASE("panoloc loads OpenCV's image and video I/O only when needed", "[opencv_io]") {
  const std::string needed = ShellOutput(std::string("readelf -d ") + std::getenv("PANO_BIN_DIR") + "/panoloc");
  if (needed.find("libopencv_core") == std::string::npos) {
    test::Skip("readelf cannot list panoloc's libraries");
    return;
  }
  CHECK(needed.find("libopencv_imgcodecs") == std::string::npos);
  CHECK(needed.find("libopencv_videoio") == std::string::npos);

  const std::string dir = test::ScratchDir("apps_opencv_io");
  REQUIRE(RunProgram("panosim sequence --preset paper-synthetic --supersample 1 --frames -q -o " + dir + "/seq").code ==
          0);
  const std::string maps = " --calib " + dir + "/seq/calib.yaml --map " + dir + "/seq/map.yaml -q --no-table-cache";
  // Through the module: an image folder, a plot.
  test::CommandRun r = RunProgram("panoloc " + dir + "/seq/frames" + maps + " -o " + dir + "/folder.csv --plot " +
                                  dir + "/plot.png");
  INFO(r.out);
  CHECK(r.code == 0);

  // Without it, a video still runs; a folder fails with one line that says why.
  REQUIRE(setenv("PANOTRACK_OPENCV_IO", (dir + "/missing.so").c_str(), 1) == 0);
  r = RunProgram("panoloc " + dir + "/seq/video.mp4" + maps + " -o " + dir + "/video.csv");
  CHECK(r.code == 0);
  r = RunProgram("panoloc " + dir + "/seq/frames" + maps + " -o " + dir + "/none.csv");
  unsetenv("PANOTRACK_OPENCV_IO");
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK(test::CountLines(r.out) == 1);
  CHECK(r.out.rfind("panoloc: " + dir + "/seq/frames/frame_0000.png: OpenCV's image and video I/O "
                    "(libpanotrack_opencv_io.so) could not be loaded: " + dir + "/missing.so: no such file", 0) == 0);
}

}  // namespace
}  // namespace pano

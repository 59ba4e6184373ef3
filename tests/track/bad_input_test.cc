// panoloc's errors: one line naming the file and the problem; a failing
// video does not stop the others.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "expect_error.h"
#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/render/writers.h"
#include "test_paths.h"
#include "panotrack/video/frame_source.h"
#include "track_fixture.h"

namespace pano {
namespace {

using test::ErrorOf;

TEST_CASE("panoloc rejects bad inputs with clear messages", "[bad_input]") {
  const std::string dir = test::ScratchDir("track_bad");
  SequenceCase c = MakePreset("paper-synthetic");
  c.poses.resize(4);
  SequenceWriteOptions w;
  w.overwrite = true;
  WriteSequence(c, dir + "/seq", w);
  PanolocOptions o;
  o.calib_path = dir + "/seq/calib.yaml";
  o.map_path = dir + "/seq/map.yaml";
  o.quiet = true;
  o.out_dir = dir + "/out";
  // One good and one missing video: the good one is done, the other reported.
  o.inputs = {dir + "/seq/video.mp4", dir + "/missing.mp4"};
  o.init = c.poses.front();
  std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 2);
  CHECK(s[0].ok);
  CHECK(s[0].n_ok == 4);
  CHECK_FALSE(s[1].ok);
  CHECK(s[1].error.find("missing.mp4") != std::string::npos);
  CHECK(s[1].error.find("no such file") != std::string::npos);
  // An empty file, and a file that is no video.
  std::ofstream(dir + "/empty.mp4").close();
  std::ofstream(dir + "/text.mp4") << "not a video\n";
  for (const char* name : {"/empty.mp4", "/text.mp4"}) {
    const std::string msg = ErrorOf([&] { FrameSource f(dir + name); });
    INFO(msg);
    CHECK(msg.find(dir + name) != std::string::npos);
  }
  // Frame size different from the calibration's.
  Calibration small = c.calib;
  small.sensor.image_width = 400;
  small.sensor.params.cx = 199.5;
  WriteCalibration(dir + "/small.yaml", small);
  o.inputs = {dir + "/seq/video.mp4"};
  o.calib_path = dir + "/small.yaml";
  o.overwrite = true;  // the CSV of the first run is there
  s = RunPanoloc(o);
  REQUIRE(s.size() == 1);
  CHECK_FALSE(s[0].ok);
  CHECK(s[0].error.find("does not match the calibration") != std::string::npos);
  o.calib_path = dir + "/seq/calib.yaml";
  // An initial pose outside the room.
  o.init = Pose2{-50, 20, 0};
  std::string msg = ErrorOf([&] { RunPanoloc(o); });
  CHECK(msg.find("--init") != std::string::npos);
  CHECK(msg.find("outside the room") != std::string::npos);
  o.init = c.poses.front();
  // A malformed map.
  std::ofstream(dir + "/bad_map.yaml") << "units: units\nsensor_height: [1, 2\n";
  o.map_path = dir + "/bad_map.yaml";
  msg = ErrorOf([&] { RunPanoloc(o); });
  CHECK(msg.find("bad_map.yaml") != std::string::npos);
  CHECK(msg.find("malformed YAML") != std::string::npos);
  o.map_path = dir + "/seq/map.yaml";
  // Options that cannot work together.
  o.inputs = {dir + "/seq/video.mp4", dir + "/seq/video.mp4"};
  o.out_dir.clear();
  o.output = dir + "/x.csv";
  CHECK(ErrorOf([&] { RunPanoloc(o); }).find("--out-dir") != std::string::npos);
  o.inputs.clear();
  CHECK(ErrorOf([&] { RunPanoloc(o); }).find("no input") != std::string::npos);
}

}  // namespace
}  // namespace pano

// panosim's jobs (pipeline/panosim.h): a still, a sequence and calibration
// images written as the program writes them.
#include <catch2/catch.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>

#include "expect_error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/panosim.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

TEST_CASE("still job: a preset's frame with the user's changes, as the renderer draws it", "[panosim_jobs]") {
  const std::string dir = test::ScratchDir("panosim_jobs_still");
  StillJob job;
  job.preset = "paper-real";
  job.frame = 5;
  job.output = dir + "/still.png";
  job.adjust.num_threads = 2;
  job.adjust.sensor = [](Sensor* s) { s->faults.mirror_offset[0] = 0.1; };
  job.adjust.options = [](RenderOptions* o) { o->noise_sigma = 0.0; };
  RunStill(job);
  const SequenceCase c = MakePreset("paper-real");
  Sensor sensor = c.calib.sensor;
  sensor.faults.mirror_offset[0] = 0.1;
  RenderOptions ro = c.options;
  ro.noise_sigma = 0.0;
  const cv::Mat expected = RenderStill(sensor, c.map, c.poses[5], ro);
  const cv::Mat written = cv::imread(job.output, cv::IMREAD_UNCHANGED);
  REQUIRE(written.size() == expected.size());
  CHECK(cv::norm(written, expected, cv::NORM_INF) == 0.0);

  // An existing output is kept; a preset and files together are refused.
  test::ExpectError([&] { RunStill(job); }, job.output, {"exists"});
  job.overwrite = true;
  job.calib_path = test::SourcePath("calib/paper-real.yaml");
  test::ExpectError([&] { RunStill(job); }, "--preset", {"not both"});
}

TEST_CASE("sequence job: files and a trajectory, the survey error asked for, frames without a video",
          "[panosim_jobs]") {
  const std::string dir = test::ScratchDir("panosim_jobs_sequence");
  const SequenceCase preset = MakePreset("paper-real");
  SequenceJob job;
  job.map_path = dir + "/map.yaml";
  job.calib_path = dir + "/calib.yaml";
  job.trajectory_path = dir + "/trajectory.csv";
  WriteMap(job.map_path, preset.map);
  WriteCalibration(job.calib_path, preset.calib);
  {
    std::ofstream t(job.trajectory_path);
    t << "x,y,theta\n";
    for (int i = 0; i < 3; ++i)
      t << preset.poses[i].x << "," << preset.poses[i].y << "," << preset.poses[i].theta << "\n";
  }
  job.survey_sigma = 0.5;
  job.output = dir + "/case";
  job.write.frames = true;
  job.write.video = false;
  job.adjust.num_threads = 2;
  const SequenceWriteResult r = RunSequence(job);
  CHECK(r.frames == 3);
  CHECK(fs::exists(job.output + "/frames/frame_0002.png"));
  CHECK(ReadPoseCsv(job.output + "/gt.csv").size() == 3);
  // The map written states its survey error; the room rendered beside it.
  CHECK(ReadMap(job.output + "/map.yaml").survey_sigma == 0.5);
  CHECK(fs::exists(job.output + "/map_true.yaml"));
  // Files without the trajectory: the option named.
  job.trajectory_path.clear();
  test::ExpectError([&] { RunSequence(job); }, "--trajectory", {"required"});
}

TEST_CASE("targets job: boards placed automatically, their target files written", "[panosim_jobs]") {
  const std::string dir = test::ScratchDir("panosim_jobs_targets");
  TargetsJob job;
  job.preset = "paper-real";
  job.board.cols = 9;
  job.board.rows = 6;
  job.board.square = 3.0;
  job.auto_count = 3;
  job.output = dir + "/boards";
  job.adjust.num_threads = 2;
  RunTargets(job);
  const TargetSet written = ReadTargets(job.output + "/targets.yaml");
  REQUIRE(written.images.size() == 3);
  CHECK(written.AllPosesKnown());
  CHECK(fs::exists(job.output + "/cal_002.png"));
  // Neither a poses file nor a count.
  job.auto_count.reset();
  job.write.overwrite = true;
  test::ExpectError([&] { RunTargets(job); }, "--poses or --auto", {"give the board poses file"});
}

}  // namespace
}  // namespace pano

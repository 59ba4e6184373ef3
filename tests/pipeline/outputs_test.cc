// Where panoloc's outputs go: distinct names under --out-dir, no output over
// an input, pose CSVs staged as <out>.partial, special files written as they
// are.
#include <catch2/catch.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

#include "expect_error.h"
#include "panotrack/core/error.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/pipeline/output_names.h"
#include "panotrack/pipeline/panoloc.h"
#include "pipeline_fixture.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::Scratch;

using test::ErrorOf;

namespace fs = std::filesystem;

TEST_CASE("output names: inputs with one name get their folders in front; clashes that remain are errors",
          "[output_names]") {
  const std::string dir = Scratch("pipeline_names");
  fs::create_directories(dir + "/x/frames");
  fs::create_directories(dir + "/y/frames");
  auto names = [&](const std::vector<std::string>& inputs) {
    std::vector<std::string> out;
    for (const std::string& p : OutputPathsInDir(inputs, "out")) out.push_back(fs::path(p).filename().string());
    return out;
  };
  CHECK(names({"a/run.mp4", "b/run.mp4"}) == std::vector<std::string>{"a_run.csv", "b_run.csv"});
  CHECK(names({"d/a/run.mp4", "e/a/run.mp4", "c/other.mp4"}) ==
        std::vector<std::string>{"d_a_run.csv", "e_a_run.csv", "other.csv"});
  CHECK(names({dir + "/x/frames", dir + "/y/frames/"}) == std::vector<std::string>{"x_frames.csv", "y_frames.csv"});
  CHECK(names({"seq/video.mp4", "run.mp4"}) == std::vector<std::string>{"seq_video.csv", "run.csv"});
  CHECK(names({"-", "cams/front.mkv"}) == std::vector<std::string>{"stdin.csv", "front.csv"});
  CHECK(names({"shots/f_%04d.png", "more/%04d.png"}) == std::vector<std::string>{"shots_f.csv", "more.csv"});
  CHECK(ErrorOf([&] { names({"a/run.mp4", "a/run.mkv"}); }).find("would both write run.csv") != std::string::npos);
  CHECK(ErrorOf([&] { names({"a/run.mp4", "a/../a/run.mp4"}); }).find("given twice") != std::string::npos);
}

TEST_CASE("output names: non-ASCII names kept, bytes that are not UTF-8 kept apart", "[output_names]") {
  auto names = [&](const std::vector<std::string>& inputs) {
    std::vector<std::string> out;
    for (const std::string& p : OutputPathsInDir(inputs, "out")) out.push_back(fs::path(p).filename().string());
    return out;
  };
  CHECK(names({"été.mp4", "ôté.mp4", "走廊.mp4", "Δ-run.mp4"}) ==
        std::vector<std::string>{"été.csv", "ôté.csv", "走廊.csv", "Δ-run.csv"});
  CHECK(names({"été/prise 1.mp4", "ôté/prise 1.mp4"}) ==
        std::vector<std::string>{"été_prise_1.csv", "ôté_prise_1.csv"});
  // Latin-1 names (not UTF-8), a stray continuation byte, an overlong '/', a C1 control.
  CHECK(names({"caf\xe9.mp4", "caf\xe8.mp4", "a\x80" "b.mp4", "x\xc0\xafy.mp4", "c\xc2\x85" "d.mp4"}) ==
        std::vector<std::string>{"caf_E9.csv", "caf_E8.csv", "a_80b.csv", "x_C0_AFy.csv", "c_C2_85d.csv"});
}

TEST_CASE("two inputs with one name under --out-dir: two CSVs, each with its own rows", "[output_names]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_names_run");
  for (const char* sub : {"/a", "/b"}) {
    fs::create_directories(dir + sub);
    fs::copy_file(c.video, dir + sub + "/run.mp4");
  }
  PanolocOptions o;
  o.inputs = {dir + "/a/run.mp4", dir + "/b/run.mp4"};
  o.out_dir = dir + "/out";
  o.calib_path = c.calib;
  o.map_path = c.map;
  o.init = c.init;
  o.jobs = 2;
  o.quiet = true;
  const std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 2);
  CHECK(s[0].output == dir + "/out/a_run.csv");
  CHECK(s[1].output == dir + "/out/b_run.csv");
  for (const VideoSummary& v : s) {
    INFO(v.error);
    CHECK(v.ok);
    const std::vector<PoseRow> rows = ReadPoseCsv(v.output);
    CHECK(rows.size() == 12);
    test::RequireConsecutive(rows);
  }
}

TEST_CASE("outputs never overwrite an input; -o and --out-dir together are refused", "[output_checks]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_checks");
  fs::copy_file(c.video, dir + "/run.mp4");
  const auto size_before = fs::file_size(dir + "/run.mp4");
  PanolocOptions o;
  o.inputs = {dir + "/run.mp4"};
  o.calib_path = c.calib;
  o.map_path = c.map;
  o.init = c.init;
  o.quiet = true;
  o.output = dir + "/../" + fs::path(dir).filename().string() + "/run.mp4";  // the input, spelt otherwise
  std::string msg = ErrorOf([&] { RunPanoloc(o); });
  CHECK(msg.find("-o") != std::string::npos);
  CHECK(msg.find("the same file as the input") != std::string::npos);
  CHECK(fs::file_size(dir + "/run.mp4") == size_before);
  o.output = c.calib;
  CHECK(ErrorOf([&] { RunPanoloc(o); }).find("(--calib)") != std::string::npos);
  o.output = dir + "/est.csv";
  o.gt = c.gt;
  o.plot = dir + "/est.csv";
  CHECK(ErrorOf([&] { RunPanoloc(o); }).find("--plot " + dir + "/est.csv: the same file as -o") != std::string::npos);
  o.plot.clear();
  o.out_dir = dir + "/out";
  msg = ErrorOf([&] { o.Check(); });
  CHECK(msg.find("-o (output) and --out-dir (out_dir)") != std::string::npos);
  CHECK_FALSE(fs::exists(dir + "/out"));
  o.out_dir.clear();
  o.num_threads = -1;
  CHECK(ErrorOf([&] { o.Check(); }).find("--threads (num_threads)") != std::string::npos);
}

PoseRow Row(int frame) {
  PoseRow r;
  r.frame = frame;
  r.time_s = 0.1 * frame;
  r.pose = {1.0 + frame, 2.0, 0.5};
  r.n_landmarks = 5;
  return r;
}

TEST_CASE("pose CSV staging: <out>.partial while written, <out> once closed; special files written directly",
          "[staging]") {
  const std::string dir = Scratch("pipeline_staging");
  const std::string p = dir + "/poses.csv";
  {
    PoseCsvWriter w(p, {}, PoseCsvStaging::kPartial);
    CHECK(w.written_path() == p + ".partial");
    w.Write(Row(0));
    w.Write(Row(1));
    // Flushed row by row into the partial file; nothing at <out> yet.
    CHECK(ReadPoseCsv(p + ".partial").size() == 2);
    CHECK_FALSE(fs::exists(p));
    w.Close();
  }
  CHECK(ReadPoseCsv(p).size() == 2);
  CHECK_FALSE(fs::exists(p + ".partial"));
  // Ended without Close (a failure): the rows stay under the partial name,
  // and the finished file of before is left as it was.
  {
    PoseCsvWriter w(p, {}, PoseCsvStaging::kPartial);
    w.Write(Row(0));
  }
  CHECK(ReadPoseCsv(p + ".partial").size() == 1);
  CHECK(ReadPoseCsv(p).size() == 2);
  // A FIFO is written through, never replaced by a file.
  const std::string fifo = dir + "/fifo";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  std::string received;
  std::thread reader([&] { received = test::ReadText(fifo); });
  {
    PoseCsvWriter w(fifo, {}, PoseCsvStaging::kPartial);
    CHECK(w.written_path() == fifo);
    w.Write(Row(0));
    w.Close();
  }
  reader.join();
  CHECK(received == std::string(kPoseCsvHeader) + "\n" + FormatPoseRow(Row(0)) + "\n");
  struct stat st;
  REQUIRE(::stat(fifo.c_str(), &st) == 0);
  CHECK(S_ISFIFO(st.st_mode));
  CHECK_FALSE(fs::exists(fifo + ".partial"));
  CHECK(PoseCsvWriter::WritesDirectly("/dev/null"));
  CHECK(PoseCsvWriter::WritesDirectly("-"));
  CHECK_FALSE(PoseCsvWriter::WritesDirectly(p));
}

TEST_CASE("the case.yaml beside an input: in its folder, then one up, also for a relative folder name",
          "[output_names]") {
  const std::string dir = Scratch("case_beside");
  fs::create_directories(fs::path(dir) / "frames");
  std::ofstream(fs::path(dir) / "case.yaml") << "initial_pose:\n  x: 40.0\n  \"y\": 35.0\n  theta: 0.25\n";
  // A folder named relative to the current one, whose parent path is empty:
  // the case.yaml one up is the current folder's. The current folder is
  // restored however the calls end (the process's other tests share it).
  std::vector<std::string> relative, here;
  std::optional<Pose2> pose;
  {
    struct InFolder {
      fs::path before = fs::current_path();
      explicit InFolder(const fs::path& dir) { fs::current_path(dir); }
      ~InFolder() { fs::current_path(before); }
    } in_scratch(dir);
    relative = CaseFilesBeside("frames");
    pose = InitialPoseBeside("frames");
    here = CaseFilesBeside(".");
  }
  REQUIRE(relative.size() == 1);
  CHECK(fs::equivalent(fs::path(dir) / relative[0], fs::path(dir) / "case.yaml"));
  REQUIRE(pose.has_value());
  CHECK(pose->x == 40.0);
  CHECK(pose->theta == 0.25);
  CHECK(here.size() == 1);  // "." and its parent: the one beside it only
  CHECK(CaseFilesBeside((fs::path(dir) / "frames").string()).size() == 1);
  CHECK(CaseFilesBeside((fs::path(dir) / "case.yaml").string()).size() == 1);
}

}  // namespace
}  // namespace pano

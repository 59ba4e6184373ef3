// The panoloc program as users run it: exit codes, signals, standard streams,
// live input, and the summary of runs that did not go to their end.
#include <catch2/catch.hpp>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "panotrack/io/pose_csv.h"
#include "pipeline_fixture.h"
#include "test_paths.h"
#include "test_skip.h"

namespace pano {
namespace {

using test::Scratch;
using test::FilesIn;

namespace fs = std::filesystem;

std::vector<std::string> Panoloc(const std::string& args) {
  std::vector<std::string> argv = {test::Program("panoloc")};
  for (const std::string& w : test::Words(args + " " + test::GetSmallCase().Args())) argv.push_back(w);
  return argv;
}

// panoloc on a long input, stopped by `sig` once some rows are written.
void CheckStoppedBy(int sig, int expected_code) {
  const std::string dir = Scratch("pipeline_cli_signal" + std::to_string(sig));
  const std::string input = test::LongFolder(dir, 4000);
  fs::create_directories(dir + "/out");
  const std::string csv = dir + "/out/est.csv";
  test::Child child = test::Spawn(Panoloc(input + " -o " + csv + " --debug-video " + dir + "/out/dbg.mp4"), dir);
  REQUIRE(test::WaitForLines(&child, csv + ".partial", 11));
  REQUIRE(::kill(child.pid, sig) == 0);
  const int code = test::Wait(&child);
  const std::string out = test::ReadText(child.out_path), err = test::ReadText(child.err_path);
  INFO(out << err);
  CHECK(code == expected_code);
  // Rows intact: well-formed, consecutive, up to the frame in progress.
  const std::vector<PoseRow> rows = ReadPoseCsv(csv);
  CHECK(rows.size() >= 10);
  CHECK(rows.size() < 4000);
  test::RequireConsecutive(rows);
  CHECK(out.find(std::to_string(rows.size()) + " frames") != std::string::npos);
  CHECK(out.find("(interrupted)") != std::string::npos);
  // The outputs are finished; no temporary file remains.
  CHECK(FilesIn(dir + "/out") == std::vector<std::string>{"dbg.mp4", "est.csv"});
}

TEST_CASE("panoloc stopped by SIGINT or SIGTERM: rows kept, summary says interrupted, 130 or 143",
          "[cli_signals]") {
  CheckStoppedBy(SIGINT, 130);
  CheckStoppedBy(SIGTERM, 143);
}

TEST_CASE("panoloc killed: the rows so far stay under a name that says partial", "[cli_signals]") {
  const std::string dir = Scratch("pipeline_cli_kill");
  const std::string input = test::LongFolder(dir, 4000);
  const std::string csv = dir + "/est.csv";
  test::Child child = test::Spawn(Panoloc(input + " -o " + csv), dir);
  REQUIRE(test::WaitForLines(&child, csv + ".partial", 11));
  REQUIRE(::kill(child.pid, SIGKILL) == 0);
  CHECK(test::Wait(&child) == 128 + SIGKILL);
  CHECK_FALSE(fs::exists(csv));
  const std::vector<PoseRow> rows = ReadPoseCsv(csv + ".partial");
  CHECK(rows.size() >= 10);
  test::RequireConsecutive(rows);
}

TEST_CASE("panoloc -o -: the CSV on stdout row by row, the summary on stderr; -o /dev/null stays a device",
          "[cli_streams]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_cli_streams");
  test::RunResult file = test::Run(Panoloc(c.video + " -o " + dir + "/est.csv"), dir);
  REQUIRE(file.code == 0);
  test::RunResult piped = test::Run(Panoloc(c.video + " -o -"), dir);
  INFO(piped.err);
  CHECK(piped.code == 0);
  CHECK(piped.out == test::ReadText(dir + "/est.csv"));
  CHECK(piped.err.find("12 frames, 12 ok, 0 lost") != std::string::npos);
  CHECK(piped.err.find("-> -") != std::string::npos);
  test::RunResult null = test::Run(Panoloc(c.video + " -o /dev/null"), dir);
  CHECK(null.code == 0);
  struct stat st;
  REQUIRE(::stat("/dev/null", &st) == 0);
  CHECK(S_ISCHR(st.st_mode));
  CHECK_FALSE(fs::exists("/dev/null.partial"));
}

TEST_CASE("panoloc - reads a video from standard input: the same rows as from the file", "[cli_stdin]") {
  if (!test::HaveFfmpegTool()) return test::Skip("the ffmpeg tool is not installed");
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_cli_stdin");
  // Matroska streams from a pipe (an mp4 written by OpenCV has its index at the end).
  test::RunFfmpeg("-i " + c.video + " -c copy " + dir + "/clip.mkv");
  test::RunResult file = test::Run(Panoloc(dir + "/clip.mkv -o " + dir + "/file.csv"), dir);
  INFO(file.out << file.err);
  REQUIRE(file.code == 0);
  test::RunResult piped = test::Run(Panoloc("- -o " + dir + "/pipe.csv"), dir, dir + "/clip.mkv");
  INFO(piped.out << piped.err);
  if (piped.code != 0 && piped.err.find("-: no such file") != std::string::npos)
    return test::Skip("this FrameSource does not read standard input");
  CHECK(piped.code == 0);
  CHECK(test::ReadText(dir + "/pipe.csv") == test::ReadText(dir + "/file.csv"));
}

TEST_CASE("panoloc exit codes: a folder that cannot be read, nothing tracked, a broken-off input",
          "[cli_exit]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_cli_exit");
  // An unreadable folder among the inputs fails alone (once it ended the whole run with abort()).
  fs::create_directories(dir + "/loop");
  fs::create_symlink("self", dir + "/loop/self");
  std::vector<std::string> unreadable = {dir + "/loop"};
  if (::geteuid() != 0) {  // permissions do not stop root
    fs::create_directories(dir + "/locked");
    fs::permissions(dir + "/locked", fs::perms::none);
    unreadable.push_back(dir + "/locked");
  }
  for (const std::string& folder : unreadable) {
    // --force: the second folder's run writes seq_video.csv again.
    test::RunResult r = test::Run(Panoloc(folder + " " + c.video + " --out-dir " + dir + "/out --force"), dir);
    INFO(r.out << r.err);
    CHECK(r.code == 1);
    CHECK(test::CountLines(r.err) == 1);
    CHECK(r.err.find(folder) != std::string::npos);
    CHECK(r.out.find("12 frames, 12 ok") != std::string::npos);
    CHECK(ReadPoseCsv(dir + "/out/seq_video.csv").size() == 12);
  }
  if (::geteuid() != 0) fs::permissions(dir + "/locked", fs::perms::owner_all);
  // Nothing tracked: exit 1 and the likely causes.
  const std::string blank = test::BlankFolder(dir, 10);
  test::RunResult r = test::Run(Panoloc(blank + " -o " + dir + "/blank.csv"), dir);
  INFO(r.out << r.err);
  CHECK(r.code == 1);
  CHECK(r.out.find("10 frames, 0 ok") != std::string::npos);
  CHECK(r.err.find("only 0 of 10 frames tracked") != std::string::npos);
  CHECK(r.err.find("likely causes") != std::string::npos);
  // A folder whose 8th image is broken: 7 rows, exit 1, the summary says why.
  fs::create_directories(dir + "/cut");
  for (int i = 0; i < c.n_frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/frame_%04d.png", i);
    if (i == 7) std::ofstream(dir + "/cut" + name) << "not a PNG";
    else fs::copy_file(c.frames + name, dir + "/cut" + name);
  }
  r = test::Run(Panoloc(dir + "/cut -o " + dir + "/cut.csv"), dir);
  INFO(r.out << r.err);
  CHECK(r.code == 1);
  CHECK(r.out.find("7 frames, 7 ok, 0 lost") != std::string::npos);
  CHECK(r.out.find("-> " + dir + "/cut.csv (incomplete: decode error at frame 7: ") != std::string::npos);
  // An input that broke off is an error on stderr too, not only in the summary.
  CHECK(r.err.find("panoloc: " + dir + "/cut: incomplete: decode error at frame 7: ") != std::string::npos);
  CHECK(ReadPoseCsv(dir + "/cut.csv").size() == 7);
  // Refused outputs: -o over the input, -o with --out-dir.
  r = test::Run(Panoloc(c.video + " -o " + c.video), dir);
  CHECK(r.code == 1);
  CHECK(r.err.find("the same file as the input") != std::string::npos);
  r = test::Run(Panoloc(c.video + " -o " + dir + "/x.csv --out-dir " + dir + "/o2"), dir);
  CHECK(r.code == 1);
  CHECK(r.err.find("--out-dir") != std::string::npos);
}

TEST_CASE("panoloc on a truncated video: the rows before the cut, exit 1, the summary says incomplete",
          "[cli_truncated]") {
  if (!test::HaveFfmpegTool()) return test::Skip("the ffmpeg tool is not installed");
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_cli_truncated");
  test::RunFfmpeg("-framerate 10 -i " + c.frames + "/frame_%04d.png -c:v libx264 -g 1 -qp 0 -pix_fmt yuv420p "
                  "-movflags +faststart " + dir + "/fast.mp4");
  const std::string whole = test::ReadText(dir + "/fast.mp4");
  std::ofstream(dir + "/run.mp4", std::ios::binary) << whole.substr(0, whole.size() / 2);
  test::RunResult r = test::Run(Panoloc(dir + "/run.mp4 -o " + dir + "/out.csv"), dir);
  INFO(r.out << r.err);
  if (r.code == 0) return test::Skip("this FrameSource does not report truncated videos");
  CHECK(r.code == 1);
  const std::vector<PoseRow> rows = ReadPoseCsv(dir + "/out.csv");
  REQUIRE(!rows.empty());
  CHECK(rows.size() < 12);
  const std::string n = std::to_string(rows.size());
  CHECK(r.out.find("run.mp4: " + n + " frames, " + n + " ok, 0 lost") != std::string::npos);
  CHECK(r.out.find("(incomplete: decode error at frame " + n + ": ") != std::string::npos);
}

}  // namespace
}  // namespace pano

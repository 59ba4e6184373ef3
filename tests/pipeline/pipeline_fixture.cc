#include "pipeline_fixture.h"

#include <catch2/catch.hpp>
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>

#include "panotrack/render/writers.h"
#include "test_paths.h"

namespace pano::test {

namespace fs = std::filesystem;

std::string SmallCase::Args() const {
  char pose[128];
  std::snprintf(pose, sizeof pose, "%.9g,%.9g,%.9g", init.x, init.y, init.theta);
  return "--calib " + calib + " --map " + map + " --init " + pose;
}

const SmallCase& GetSmallCase() {
  static const SmallCase c = [] {
    SmallCase s;
    const std::string root = ScratchDir("pipeline_case_" + std::to_string(::getpid()));
    SequenceCase sc = MakePreset("paper-synthetic");
    sc.poses.resize(static_cast<size_t>(s.n_frames));
    SequenceWriteOptions w;
    w.frames = true;
    w.overwrite = true;
    s.dir = root + "/seq";
    WriteSequence(sc, s.dir, w);
    s.video = s.dir + "/video.mp4";
    s.frames = s.dir + "/frames";
    s.calib = s.dir + "/calib.yaml";
    s.map = s.dir + "/map.yaml";
    s.gt = s.dir + "/gt.csv";
    s.init = sc.poses.front();
    return s;
  }();
  return c;
}

std::string LongFolder(const std::string& dir, int n) {
  const SmallCase& c = GetSmallCase();
  const std::string out = dir + "/long";
  fs::create_directories(out);
  const int period = 2 * c.n_frames;
  for (int i = 0; i < n; ++i) {
    const int k = i % period < c.n_frames ? i % period : period - 1 - i % period;
    char src[64], dst[64];
    std::snprintf(src, sizeof src, "/frame_%04d.png", k);
    std::snprintf(dst, sizeof dst, "/f_%06d.png", i);
    fs::create_symlink(c.frames + src, out + dst);
  }
  return out;
}

std::string BlankFolder(const std::string& dir, int n) {
  const SmallCase& c = GetSmallCase();
  const cv::Mat first = cv::imread(c.frames + "/frame_0000.png", cv::IMREAD_GRAYSCALE);
  REQUIRE(!first.empty());
  const cv::Mat grey(first.size(), CV_8UC1, cv::Scalar(128));
  const std::string out = dir + "/blank";
  fs::create_directories(out);
  for (int i = 0; i < n; ++i) {
    char name[64];
    std::snprintf(name, sizeof name, "/f_%04d.png", i);
    REQUIRE(cv::imwrite(out + name, grey));
  }
  return out;
}

void RequireConsecutive(const std::vector<PoseRow>& rows) {
  for (size_t i = 0; i < rows.size(); ++i) {
    INFO("row " << i);
    REQUIRE(rows[i].frame == static_cast<int>(i));
  }
}

bool HaveFfmpegTool() { return std::system("ffmpeg -version > /dev/null 2>&1") == 0; }

void RunFfmpeg(const std::string& args) {
  const std::string cmd = "ffmpeg -hide_banner -loglevel error -y " + args;
  INFO(cmd);
  REQUIRE(std::system(cmd.c_str()) == 0);
}

std::string Program(const std::string& name) {
  const char* dir = std::getenv("PANO_BIN_DIR");
  REQUIRE(dir != nullptr);
  return std::string(dir) + "/" + name;
}

Child Spawn(const std::vector<std::string>& argv, const std::string& scratch, const std::string& stdin_path) {
  static int counter = 0;
  Child c;
  const std::string base = scratch + "/child" + std::to_string(++counter);
  c.out_path = base + ".out";
  c.err_path = base + ".err";
  // Everything the child needs is prepared before fork: after it, only
  // async-signal-safe calls.
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const std::string in = stdin_path.empty() ? "/dev/null" : stdin_path;
  c.pid = ::fork();
  REQUIRE(c.pid >= 0);
  if (c.pid == 0) {
    const int fd_in = ::open(in.c_str(), O_RDONLY);
    const int fd_out = ::open(c.out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int fd_err = ::open(c.err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd_in < 0 || fd_out < 0 || fd_err < 0) ::_exit(126);
    ::dup2(fd_in, 0);
    ::dup2(fd_out, 1);
    ::dup2(fd_err, 2);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  return c;
}

int Wait(Child* c) {
  if (!c->ended) {
    REQUIRE(::waitpid(c->pid, &c->status, 0) == c->pid);
    c->ended = true;
  }
  if (WIFEXITED(c->status)) return WEXITSTATUS(c->status);
  return WIFSIGNALED(c->status) ? 128 + WTERMSIG(c->status) : -1;
}

bool WaitForLines(Child* c, const std::string& path, int lines) {
  // Not a time limit on the program: a guard against a test that would hang.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(1);
  while (std::chrono::steady_clock::now() < give_up) {
    if (CountLines(ReadText(path)) >= lines) return true;
    if (::waitpid(c->pid, &c->status, WNOHANG) == c->pid) {
      c->ended = true;
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(c->pid, SIGKILL);
  return false;
}

RunResult Run(const std::vector<std::string>& argv, const std::string& scratch, const std::string& stdin_path) {
  Child c = Spawn(argv, scratch, stdin_path);
  RunResult r;
  r.code = Wait(&c);
  r.out = ReadText(c.out_path);
  r.err = ReadText(c.err_path);
  return r;
}

std::vector<std::string> Words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

int CountLines(const std::string& text) {
  int n = 0;
  for (char ch : text) n += ch == '\n';
  return n;
}

std::string Scratch(const std::string& name) { return ScratchDir(name + "_" + std::to_string(::getpid())); }

std::vector<std::string> FilesIn(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

PanolocOptions OneInput(const std::string& input, const std::string& output) {
  const SmallCase& c = GetSmallCase();
  PanolocOptions o;
  o.inputs = {input};
  o.output = output;
  o.calib_path = c.calib;
  o.map_path = c.map;
  o.init = c.init;
  o.quiet = true;
  return o;
}

}  // namespace pano::test

// The decoding libraries print nothing of their own unless verbose: problems
// reach the caller as pano::Error.
#include <catch2/catch.hpp>
#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "panotrack/core/error.h"
#include "test_paths.h"
#include "test_skip.h"
#include "test_videos.h"
#include "panotrack/video/frame_source.h"
#include "panotrack/video/logging.h"

namespace pano {
namespace {

// What the process writes to its standard output and error (file
// descriptors 1 and 2, whoever writes) while `f` runs.
template <typename F>
std::string TerminalOutputOf(const std::string& scratch, F f) {
  const std::string file = scratch + "/terminal.txt";
  std::fflush(stdout);
  std::fflush(stderr);
  std::cout.flush();
  const int saved_out = dup(1), saved_err = dup(2);
  const int fd = open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  REQUIRE((saved_out >= 0 && saved_err >= 0 && fd >= 0));
  dup2(fd, 1);
  dup2(fd, 2);
  close(fd);
  f();
  std::fflush(stdout);
  std::fflush(stderr);
  std::cout.flush();
  std::cerr.flush();
  dup2(saved_out, 1);
  dup2(saved_err, 2);
  close(saved_out);
  close(saved_err);
  return test::ReadFileBytes(file);
}

TEST_CASE("decoders stay quiet unless verbose", "[quiet]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_quiet");
  test::MakeVideo(dir + "/a.mp4", 40, "-c:v libx264 -pix_fmt yuv420p");
  test::ScribbleFile(dir + "/a.mp4", dir + "/damaged.mp4", 0.5, 300);
  test::CutFile(dir + "/a.mp4", dir + "/no_index.mp4", 0.5);
  test::MakeVideo(dir + "/bgr.avi", 40, "-c:v rawvideo -pix_fmt bgr24");
  test::CutFile(dir + "/bgr.avi", dir + "/bgr_half.avi", 0.5);
  std::filesystem::create_directories(dir + "/frames");
  for (int i = 0; i < 3; ++i)
    REQUIRE(cv::imwrite(dir + "/frames/f" + std::to_string(i) + ".png", test::CodedFrame(i)));
  test::WriteFileBytes(dir + "/frames/f3.png", "not a png image");
  int port = 0;
  const int refusing = test::BindLoopback(SOCK_STREAM, &port);
  const std::vector<std::string> bad = {dir + "/damaged.mp4", dir + "/no_index.mp4", dir + "/bgr_half.avi",
                                        dir + "/frames/f%d.png", "/dev/video9",
                                        "tcp://127.0.0.1:" + std::to_string(port)};
  std::vector<std::string> errors;
  auto read_all_bad = [&] {
    errors.clear();
    for (const std::string& path : bad) {
      (void)FrameSource::FrameCount(path);
      errors.push_back(test::ReadAll(path).error);
    }
  };

  SetDecoderLogging(false);
  CHECK(TerminalOutputOf(dir, read_all_bad).empty());
  REQUIRE(errors.size() == bad.size());
  for (size_t i = 0; i < bad.size(); ++i) {
    INFO(errors[i]);
    const std::string named = i == 3 ? dir + "/frames/f3.png" : bad[i];  // the pattern's unreadable file
    CHECK(errors[i].find(named + ": ") == 0);
  }

  // The same with verbose decoders does reach the terminal: the check above
  // would see it.
  SetDecoderLogging(true);
  const std::string verbose = TerminalOutputOf(dir, read_all_bad);
  SetDecoderLogging(false);
  close(refusing);
  INFO(verbose);
  CHECK_FALSE(verbose.empty());
}

}  // namespace
}  // namespace pano

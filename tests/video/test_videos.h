// Small test videos made with the ffmpeg command-line tool from frames that
// carry their own index, so that a test can tell which frame it got.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "panotrack/video/frame_source.h"

namespace pano::test {

constexpr int kFrameWidth = 160, kFrameHeight = 120;
constexpr double kFrameRate = 25.0;

// Frame `index` (0..255): its bits as black or white stripes on the top half,
// changing noise on the bottom half (so that frames cost a realistic size).
cv::Mat CodedFrame(int index);
// The index CodedFrame wrote, read back from a decoded grey frame; -1 when
// the stripes are not clean black and white.
int FrameIndex(const cv::Mat& grey);

bool HaveFfmpegTool();
// Runs `ffmpeg -f rawvideo ... -i - <args> <out>` on frames 0..n-1 at
// kFrameRate; fails the test when ffmpeg fails.
void MakeVideo(const std::string& out, int n, const std::string& args);
// Runs `ffmpeg <args>` (for conversions of videos made by MakeVideo).
void RunFfmpeg(const std::string& args);

std::string ReadFileBytes(const std::string& path);
void WriteFileBytes(const std::string& path, const std::string& bytes);
// Keeps the first `fraction` of the file's bytes.
void CutFile(const std::string& from, const std::string& to, double fraction);
// Overwrites `count` bytes from `fraction` of the file on with a fixed
// pseudo-random sequence.
void ScribbleFile(const std::string& from, const std::string& to, double fraction, size_t count);

// Everything a FrameSource hands out until its end or its error.
struct ReadOutcome {
  std::vector<int> indices;
  std::vector<double> times;
  std::string error;     // "" for a clean end; also an error of the constructor
  int frame_count = -2;  // frame_count(); -2 when the constructor failed
};
ReadOutcome ReadAll(const std::string& path, double live_timeout_s = 10.0);
// The same with these options; `gop_parallel` (when given) is set to
// whether the source decoded groups of pictures in parallel.
ReadOutcome ReadAll(const std::string& path, const FrameSourceOptions& options, bool* gop_parallel = nullptr);
// A loopback port of the given socket type (SOCK_STREAM, SOCK_DGRAM), bound
// by the returned socket (close it to free the port). A TCP socket bound but
// not listening refuses connections.
int BindLoopback(int type, int* port);

// 0, 1, ..., n-1.
std::vector<int> Iota(int n);

}  // namespace pano::test

#include "test_videos.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <catch2/catch.hpp>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <numeric>

#include "panotrack/core/error.h"

namespace pano::test {

namespace {
constexpr int kStripeWidth = kFrameWidth / 8;
}

cv::Mat CodedFrame(int index) {
  cv::Mat f(kFrameHeight, kFrameWidth, CV_8UC1);
  for (int y = 0; y < kFrameHeight; ++y)
    for (int x = 0; x < kFrameWidth; ++x) {
      uchar v;
      if (y < kFrameHeight / 2)
        v = ((index >> (x / kStripeWidth)) & 1) ? 255 : 0;
      else
        v = static_cast<uchar>(
            (uint32_t(x) * 7919u + uint32_t(y) * 104729u + uint32_t(index) * 15485863u) * 2654435761u >> 24);
      f.at<uchar>(y, x) = v;
    }
  return f;
}

int FrameIndex(const cv::Mat& grey) {
  if (grey.rows != kFrameHeight || grey.cols != kFrameWidth || grey.type() != CV_8UC1) return -1;
  int index = 0;
  for (int bit = 0; bit < 8; ++bit) {
    const cv::Rect centre(bit * kStripeWidth + 5, 10, kStripeWidth - 10, kFrameHeight / 2 - 20);
    const double mean = cv::mean(grey(centre))[0];
    if (mean > 200) index |= 1 << bit;
    else if (mean > 55) return -1;  // neither black nor white
  }
  return index;
}

bool HaveFfmpegTool() { return std::system("ffmpeg -version > /dev/null 2>&1") == 0; }

void MakeVideo(const std::string& out, int n, const std::string& args) {
  std::signal(SIGPIPE, SIG_IGN);  // an ffmpeg that fails early closes the pipe
  const std::string cmd = "ffmpeg -hide_banner -loglevel error -y -f rawvideo -pix_fmt gray -s " +
                          std::to_string(kFrameWidth) + "x" + std::to_string(kFrameHeight) + " -r 25 -i - " +
                          args + " '" + out + "'";
  FILE* pipe = popen(cmd.c_str(), "w");
  REQUIRE(pipe != nullptr);
  for (int i = 0; i < n; ++i) {
    const cv::Mat f = CodedFrame(i);
    std::fwrite(f.data, 1, f.total(), pipe);
  }
  INFO(cmd);
  REQUIRE(pclose(pipe) == 0);
}

void RunFfmpeg(const std::string& args) {
  const std::string cmd = "ffmpeg -hide_banner -loglevel error -nostdin -y " + args;
  INFO(cmd);
  REQUIRE(std::system(cmd.c_str()) == 0);
}

std::string ReadFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE(in.good());
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteFileBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  REQUIRE(out.good());
}

void CutFile(const std::string& from, const std::string& to, double fraction) {
  const std::string bytes = ReadFileBytes(from);
  WriteFileBytes(to, bytes.substr(0, static_cast<size_t>(bytes.size() * fraction)));
}

void ScribbleFile(const std::string& from, const std::string& to, double fraction, size_t count) {
  std::string bytes = ReadFileBytes(from);
  const size_t start = static_cast<size_t>(bytes.size() * fraction);
  REQUIRE(start + count <= bytes.size());
  for (size_t i = 0; i < count; ++i) bytes[start + i] = static_cast<char>((i * 97 + 13) & 0xff);
  WriteFileBytes(to, bytes);
}

ReadOutcome ReadAll(const std::string& path, double live_timeout_s) {
  FrameSourceOptions options;
  options.live_timeout_s = live_timeout_s;
  return ReadAll(path, options);
}

ReadOutcome ReadAll(const std::string& path, const FrameSourceOptions& options, bool* gop_parallel) {
  ReadOutcome out;
  try {
    FrameSource source(path, options);
    if (gop_parallel) *gop_parallel = source.gop_parallel();
    out.frame_count = source.frame_count();
    cv::Mat grey;
    double t;
    while (source.Read(&grey, &t)) {
      out.indices.push_back(FrameIndex(grey));
      out.times.push_back(t);
    }
  } catch (const Error& e) {
    out.error = e.what();
  }
  return out;
}

int BindLoopback(int type, int* port) {
  const int fd = socket(AF_INET, type, 0);
  REQUIRE(fd >= 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  REQUIRE(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0);
  socklen_t len = sizeof(addr);
  REQUIRE(getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0);
  *port = ntohs(addr.sin_port);
  return fd;
}

std::vector<int> Iota(int n) {
  std::vector<int> v(n);
  std::iota(v.begin(), v.end(), 0);
  return v;
}

}  // namespace pano::test

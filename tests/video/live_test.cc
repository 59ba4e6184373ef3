// Standard input, streams and cameras: read as they arrive, no frame count,
// and a dead input fails with a one-line error instead of hanging.
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cerrno>
#include <filesystem>
#include <future>
#include <thread>

#include "panotrack/core/error.h"
#include "test_paths.h"
#include "test_skip.h"
#include "test_videos.h"
#include "panotrack/video/frame_source.h"

extern char** environ;

namespace pano {
namespace {

constexpr int kFrames = 50;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Makes `bytes` the process's standard input for the lifetime of the
// object, written from a thread of its own. With `hold_open` the writer keeps
// the pipe open after the bytes, like a live producer that has gone silent.
class StdinFeed {
 public:
  explicit StdinFeed(const std::string& bytes, bool hold_open = false) : bytes_(bytes) {
    signal(SIGPIPE, SIG_IGN);  // the reader may stop early
    int fds[2];
    REQUIRE(pipe(fds) == 0);
    saved_stdin_ = dup(0);
    REQUIRE(saved_stdin_ >= 0);
    REQUIRE(dup2(fds[0], 0) == 0);
    close(fds[0]);
    write_fd_ = fds[1];
    std::shared_future<void> released = release_.get_future().share();
    writer_ = std::thread([this, hold_open, released] {
      size_t done = 0;
      while (done < bytes_.size()) {
        const ssize_t n =
            write(write_fd_, bytes_.data() + done, std::min<size_t>(bytes_.size() - done, 4096));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        done += static_cast<size_t>(n);
      }
      if (hold_open) released.wait();
      close(write_fd_);
    });
  }
  ~StdinFeed() {
    dup2(saved_stdin_, 0);  // closes the pipe's read end: a blocked writer gives up
    close(saved_stdin_);
    release_.set_value();
    writer_.join();
  }

 private:
  std::string bytes_;
  int saved_stdin_ = -1, write_fd_ = -1;
  std::promise<void> release_;
  std::thread writer_;
};

TEST_CASE("standard input is read as a stream to its clean end", "[stdin]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_stdin");
  test::MakeVideo(dir + "/a.ts", kFrames, "-c:v libx264 -pix_fmt yuv420p -f mpegts");
  test::MakeVideo(dir + "/a.mkv", kFrames, "-c:v libx264 -pix_fmt yuv420p");
  CHECK(FrameSource::IsLive("-"));
  CHECK(FrameSource::FrameCount("-") == -1);
  for (const char* name : {"/a.ts", "/a.mkv"}) {
    test::ReadOutcome r;
    {
      StdinFeed feed(test::ReadFileBytes(dir + name));
      r = test::ReadAll("-");
    }
    INFO(name << ": " << r.error);
    CHECK(r.error.empty());
    CHECK(r.frame_count == -1);
    CHECK(r.indices == test::Iota(kFrames));
    for (size_t i = 0; i < r.times.size(); ++i)
      CHECK(r.times[i] == Approx(i / test::kFrameRate).margin(1e-3));
  }
  // Damaged or cut data on standard input is an error like in a file.
  test::ScribbleFile(dir + "/a.ts", dir + "/damaged.ts", 0.5, 300);
  test::CutFile(dir + "/a.mkv", dir + "/half.mkv", 0.5);
  for (const char* name : {"/damaged.ts", "/half.mkv"}) {
    test::ReadOutcome r;
    {
      StdinFeed feed(test::ReadFileBytes(dir + name));
      r = test::ReadAll("-");
    }
    INFO(name << ": " << r.error);
    const int k = static_cast<int>(r.indices.size());
    CHECK(r.indices == test::Iota(k));
    CHECK(k < kFrames);
    CHECK(Contains(r.error, "standard input: decode error at frame " + std::to_string(k) + ": "));
  }
}

TEST_CASE("standard input that goes silent times out, and closing does not wait for it", "[stdin]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_stdin_silent");
  // Long enough for FFmpeg's stream analysis to finish on the first half.
  test::MakeVideo(dir + "/a.ts", 150, "-c:v libx264 -pix_fmt yuv420p -f mpegts");
  const std::string bytes = test::ReadFileBytes(dir + "/a.ts");
  const std::string first_half = bytes.substr(0, bytes.size() / 2 / 188 * 188);  // whole TS packets
  test::ReadOutcome r;
  {
    StdinFeed feed(first_half, true);
    r = test::ReadAll("-", 0.5);
  }
  INFO(r.error);
  const int k = static_cast<int>(r.indices.size());
  CHECK(k > 40);
  CHECK(k < 150);
  CHECK(r.indices == test::Iota(k));
  CHECK(r.error == "standard input: decode error at frame " + std::to_string(k) + ": no data for 0.5 s");

  // No timeout to speak of: the destructor itself must stop the read that
  // waits for data (else this case never ends).
  {
    StdinFeed feed(first_half, true);
    FrameSourceOptions options;
    options.live_timeout_s = 1e6;
    FrameSource source("-", options);
    cv::Mat grey;
    for (int i = 0; i < 3; ++i) {
      REQUIRE(source.Read(&grey));
      CHECK(test::FrameIndex(grey) == i);
    }
  }
}

TEST_CASE("a UDP stream on loopback is followed until it stops", "[udp]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_udp");
  constexpr int kSent = 75;  // 3 s at 25 fps
  test::MakeVideo(dir + "/a.ts", kSent, "-c:v libx264 -pix_fmt yuv420p -g 10 -f mpegts");
  int port = 0;
  close(test::BindLoopback(SOCK_DGRAM, &port));
  const std::string url = "udp://127.0.0.1:" + std::to_string(port);
  CHECK(FrameSource::FrameCount(url) == -1);  // not opened: nobody is sending yet

  // The sender paces the stream in real time; the receiver opens at once, so
  // at most its first frames are missed.
  const std::string input = dir + "/a.ts", output = url + "?pkt_size=1316";
  std::vector<std::string> args = {"ffmpeg", "-hide_banner", "-loglevel", "error", "-nostdin", "-re",
                                   "-i", input, "-c", "copy", "-f", "mpegts", output};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t sender = 0;
  REQUIRE(posix_spawnp(&sender, "ffmpeg", nullptr, nullptr, argv.data(), environ) == 0);
  const test::ReadOutcome r = test::ReadAll(url, 2.0);
  int status = 0;
  if (waitpid(sender, &status, WNOHANG) == 0) kill(sender, SIGTERM);
  waitpid(sender, &status, 0);

  INFO(r.error);
  CHECK(r.frame_count == -1);
  REQUIRE(r.indices.size() >= 25);
  const int first = r.indices.front();
  CHECK(r.indices == [&] {
    std::vector<int> v = test::Iota(static_cast<int>(r.indices.size()));
    for (int& i : v) i += first;
    return v;
  }());
  // What the demuxer still held when the stream went silent is not handed
  // out (its last packet may be partial): at most the last few frames.
  CHECK(r.indices.back() <= kSent - 1);
  CHECK(r.indices.back() >= kSent - 3);
  REQUIRE(r.times.size() == r.indices.size());
  for (size_t i = 0; i < r.times.size(); ++i)
    CHECK(r.times[i] == Approx((r.indices[i] - first) / test::kFrameRate).margin(1e-3));
  // UDP has no end of stream: silence is reported once the frames are out.
  CHECK(r.error == url + ": decode error at frame " + std::to_string(r.indices.size()) + ": no data for 2 s");
}

TEST_CASE("a missing camera fails at once with one line", "[camera]") {
  if (std::filesystem::exists("/dev/video9")) return test::Skip("/dev/video9 exists here");
  CHECK(FrameSource::IsLive("/dev/video9"));
  CHECK(FrameSource::FrameCount("/dev/video9") == -1);
  const test::ReadOutcome r = test::ReadAll("/dev/video9");
  CHECK(r.error == "/dev/video9: no such camera device");
}

TEST_CASE("a dead stream URL fails with one line", "[url]") {
  int tcp_port = 0;
  const int tcp = test::BindLoopback(SOCK_STREAM, &tcp_port);  // bound, not listening: refuses
  for (const std::string& url : {"tcp://127.0.0.1:" + std::to_string(tcp_port),
                                 "http://127.0.0.1:" + std::to_string(tcp_port) + "/video.mp4"}) {
    CHECK(FrameSource::IsLive(url));
    CHECK(FrameSource::FrameCount(url) == -1);
    const test::ReadOutcome r = test::ReadAll(url);
    INFO(r.error);
    CHECK(r.error.find(url + ": cannot open as a video (") == 0);
    CHECK(Contains(r.error, "refused"));
    CHECK_FALSE(Contains(r.error, "\n"));
  }
  close(tcp);
  // Nobody sends to this port: the open gives up after the timeout.
  int udp_port = 0;
  const int udp = test::BindLoopback(SOCK_DGRAM, &udp_port);
  close(udp);
  const std::string url = "udp://127.0.0.1:" + std::to_string(udp_port);
  const test::ReadOutcome r = test::ReadAll(url, 0.5);
  CHECK(r.error == url + ": cannot open as a video (no data for 0.5 s)");
}

}  // namespace
}  // namespace pano

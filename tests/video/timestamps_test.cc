// Read(grey, &time_s) gives each frame's own presentation time, also for a
// variable frame rate, not index / fps.
#include <catch2/catch.hpp>

#include "test_paths.h"
#include "test_skip.h"
#include "test_videos.h"
#include "panotrack/video/frame_source.h"

namespace pano {
namespace {

constexpr int kFrames = 40;

// Irregular, increasing presentation times in milliseconds (gaps of 25 to
// 435 ms), written by ffmpeg's setpts filter.
int StampMs(int n) { return 5 * n * n + 40 * n + 20 * (n % 2); }
const char* kVfrFilter =
    "-vf settb=1/1000,setpts='5*N*N+40*N+20*mod(N\\,2)' -fps_mode passthrough -enc_time_base 1/1000";

void CheckStamps(const std::string& path, const test::ReadOutcome& r) {
  INFO(path << ": " << r.error);
  CHECK(r.error.empty());
  CHECK(r.indices == test::Iota(kFrames));
  REQUIRE(r.times.size() == r.indices.size());
  for (size_t i = 0; i < r.times.size(); ++i) {
    INFO("frame " << i);
    CHECK(r.times[i] == Approx(StampMs(static_cast<int>(i)) / 1000.0).margin(1e-3));
  }
}

TEST_CASE("frame times come from the video's timestamps", "[timestamps]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_timestamps");
  const std::string x264 = std::string(kVfrFilter) + " -c:v libx264 -pix_fmt yuv420p";
  test::MakeVideo(dir + "/vfr.mkv", kFrames, x264);
  test::MakeVideo(dir + "/vfr.mp4", kFrames, x264 + " -video_track_timescale 1000");
  test::MakeVideo(dir + "/vfr_90k.mp4", kFrames, x264 + " -video_track_timescale 90000");
  // No luma plane: through cv::VideoCapture.
  test::MakeVideo(dir + "/vfr_rgb.mkv", kFrames, std::string(kVfrFilter) + " -c:v png -pix_fmt rgb24");
  for (const char* name : {"/vfr.mkv", "/vfr.mp4", "/vfr_90k.mp4", "/vfr_rgb.mkv"})
    CheckStamps(dir + name, test::ReadAll(dir + name));

  // A stream that starts late: times still count from its first frame.
  test::RunFfmpeg("-i " + dir + "/vfr.mkv -c copy -output_ts_offset 7.5 -f mpegts " + dir + "/late.ts");
  CheckStamps(dir + "/late.ts", test::ReadAll(dir + "/late.ts"));
}

}  // namespace
}  // namespace pano

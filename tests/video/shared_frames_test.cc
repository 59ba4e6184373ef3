// Decoded frames are handed out without a copy: each cv::Mat shares the
// decoder's buffer and keeps it alive, so frames held by the caller stay
// intact while decoding goes on, and after the source is gone.
#include <catch2/catch.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "test_paths.h"
#include "test_skip.h"
#include "test_videos.h"
#include "panotrack/video/frame_source.h"
#include "panotrack/video/luma_decoder.h"

namespace pano {
namespace {

constexpr int kFrames = 40;

TEST_CASE("frames held by the caller stay intact after the decoder reuses its buffers", "[shared_frames]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  const std::string path = test::ScratchDir("video_shared") + "/x264.mp4";
  test::MakeVideo(path, kFrames, "-c:v libx264 -pix_fmt yuv420p -g 10 -bf 2");
  std::vector<cv::Mat> held;
  {
    // A small prefetch queue: the decoder recycles its buffers many times.
    FrameSourceOptions options;
    options.prefetch_bytes = 1;
    FrameSource source(path, options);
    cv::Mat grey;
    double t;
    for (int frame = 0; source.Read(&grey, &t); ++frame) {
      REQUIRE(grey.type() == CV_8UC1);
      REQUIRE(grey.cols == test::kFrameWidth);
      REQUIRE(grey.rows == test::kFrameHeight);
      if (frame % 3 == 0) held.push_back(grey);  // shares, no copy
    }
  }
  REQUIRE(held.size() == (kFrames + 2) / 3);
  for (size_t k = 0; k < held.size(); ++k) CHECK(test::FrameIndex(held[k]) == static_cast<int>(3 * k));
  // Copies of a frame share its buffer; a clone is a plain continuous image
  // with the same pixels.
  const cv::Mat copy = held[1];
  CHECK(copy.data == held[1].data);
  const cv::Mat clone = held[1].clone();
  CHECK(clone.isContinuous());
  CHECK(cv::norm(clone, held[1], cv::NORM_INF) == 0.0);
  held.clear();
  CHECK(test::FrameIndex(clone) == 3);
}

TEST_CASE("the luma decoder's frames name their row stride", "[shared_frames]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  // An odd width: FFmpeg pads its rows, so the frames are not continuous.
  const std::string dir = test::ScratchDir("video_stride");
  test::MakeVideo(dir + "/even.mp4", 5, "-c:v libx264 -pix_fmt yuv420p");
  const std::string path = dir + "/narrow.mp4";
  test::RunFfmpeg("-i " + dir + "/even.mp4 -vf crop=150:120:0:0 -c:v libx264 -pix_fmt yuv420p " + path);
  LumaDecoder decoder;
  std::string why;
  REQUIRE(decoder.Open(path, &why));
  cv::Mat grey;
  int n = 0;
  while (decoder.Read(&grey)) {
    ++n;
    CHECK(grey.cols == 150);
    CHECK(grey.rows == 120);
    CHECK(grey.step[0] >= 150);
    // Read through the stride: the stripes come back (the last one cut
    // short by the crop, so widened again).
    cv::Mat wide;
    cv::copyMakeBorder(grey, wide, 0, 0, 0, test::kFrameWidth - 150, cv::BORDER_REPLICATE);
    CHECK(test::FrameIndex(wide) == n - 1);
  }
  CHECK(n == 5);
}

}  // namespace
}  // namespace pano

// Decoding on NVDEC hands out the same luma planes as the CPU's decoder (H.264
// decoding is exact), frame for frame; where no device can be used, kCuda is
// an error naming the input and kAuto decodes on the CPU.
#include <catch2/catch.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "test_paths.h"
#include "test_skip.h"
#include "test_videos.h"
#include "panotrack/core/error.h"
#include "panotrack/video/frame_source.h"
#include "panotrack/video/luma_decoder.h"

namespace pano {
namespace {

constexpr int kFrames = 62;

// Every frame's luma plane, cloned (the decoder's buffers go back to it).
std::vector<cv::Mat> DecodeAll(const std::string& path, HardwareDecoding hardware, bool* on_device) {
  LumaDecoder decoder;
  LumaDecoderOptions options;
  options.hardware = hardware;
  std::string why;
  REQUIRE(decoder.Open(path, &why, options));
  *on_device = decoder.hardware();
  std::vector<cv::Mat> frames;
  cv::Mat grey;
  while (decoder.Read(&grey)) frames.push_back(grey.clone());
  return frames;
}

// Why NVDEC cannot decode `path`; "" when it can.
std::string NvdecMissing(const std::string& path) {
  LumaDecoder decoder;
  LumaDecoderOptions options;
  options.hardware = HardwareDecoding::kCuda;
  std::string why;
  if (decoder.Open(path, &why, options)) return "";
  return why.empty() ? "unknown" : why;
}

std::string MakeClip(const std::string& name, const std::string& args) {
  const std::string path = test::ScratchDir("video_hardware_decoding") + "/" + name;
  test::MakeVideo(path, kFrames, args);
  return path;
}

// Through a FrameSource, kAuto gives the frames (indices, times, count) of
// kNone, decoded on the device or not as `on_device` says.
void CheckAutoAsCpu(const std::string& clip, bool on_device) {
  FrameSourceOptions options;
  options.hardware = HardwareDecoding::kAuto;
  {
    FrameSource source(clip, options);
    CHECK(source.hardware_decoding() == on_device);
  }
  const test::ReadOutcome automatic = test::ReadAll(clip, options);
  options.hardware = HardwareDecoding::kNone;
  const test::ReadOutcome cpu = test::ReadAll(clip, options);
  CHECK(automatic.error.empty());
  CHECK(automatic.indices == test::Iota(kFrames));
  CHECK(automatic.times == cpu.times);
  CHECK(automatic.frame_count == cpu.frame_count);
}

TEST_CASE("NVDEC hands out the CPU decoder's luma planes", "[hardware_decoding]") {
  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  // 160 x 120: the coded picture has 128 rows, cropped to 120. B-frames
  // reordered, IDR pictures every 10 frames; a 4:2:0 and a 4:4:4 stream
  // (which NVDEC may refuse: then kCuda must say so, and kAuto fall back).
  const std::string clip = MakeClip("x264_g10.mp4", "-c:v libx264 -pix_fmt yuv420p -g 10 -bf 3");
  const std::string missing = NvdecMissing(clip);
  if (!missing.empty()) return test::Skip("hardware_decoding needs NVDEC: " + missing);
  bool on_device = false, on_cpu = true;
  const std::vector<cv::Mat> gpu = DecodeAll(clip, HardwareDecoding::kCuda, &on_device);
  const std::vector<cv::Mat> cpu = DecodeAll(clip, HardwareDecoding::kNone, &on_cpu);
  CHECK(on_device);
  CHECK_FALSE(on_cpu);
  REQUIRE(gpu.size() == static_cast<size_t>(kFrames));
  REQUIRE(cpu.size() == gpu.size());
  int equal = 0;
  for (size_t i = 0; i < gpu.size(); ++i) {
    INFO("frame " << i);
    REQUIRE(gpu[i].size() == cpu[i].size());
    const bool same = cv::norm(gpu[i], cpu[i], cv::NORM_INF) == 0.0;
    CHECK(same);
    equal += same;
    CHECK(test::FrameIndex(gpu[i]) == static_cast<int>(i));
  }
  CHECK(equal == kFrames);
  CheckAutoAsCpu(clip, true);  // kAuto takes the device
  // A stream NVDEC takes or refuses: equal frames, or an error that says so.
  const std::string yuv444 = MakeClip("x264_444.mp4", "-c:v libx264 -pix_fmt yuv444p -g 10");
  if (NvdecMissing(yuv444).empty()) {
    LumaDecoder decoder;
    LumaDecoderOptions cuda;
    cuda.hardware = HardwareDecoding::kCuda;
    std::string why;
    REQUIRE(decoder.Open(yuv444, &why, cuda));
    cv::Mat grey;
    try {
      std::vector<cv::Mat> frames;
      while (decoder.Read(&grey)) frames.push_back(grey.clone());
      bool on_cpu444 = true;
      const std::vector<cv::Mat> reference = DecodeAll(yuv444, HardwareDecoding::kNone, &on_cpu444);
      REQUIRE(frames.size() == reference.size());
      for (size_t i = 0; i < frames.size(); ++i) CHECK(cv::norm(frames[i], reference[i], cv::NORM_INF) == 0.0);
      WARN("NVDEC decoded the 4:4:4 stream");
    } catch (const Error& e) {
      CHECK_THAT(e.what(), Catch::Contains("NVDEC cannot decode this stream (h264, 160 x 120)"));
      WARN("NVDEC refused the 4:4:4 stream: " << e.what());
    }
  }
}

TEST_CASE("without NVDEC, cuda is an error naming the input and auto decodes on the CPU",
          "[hardware_fallback]") {
  CHECK(ParseHardwareDecoding("none") == HardwareDecoding::kNone);
  CHECK(ParseHardwareDecoding("cuda") == HardwareDecoding::kCuda);
  CHECK(ParseHardwareDecoding("auto") == HardwareDecoding::kAuto);
  CHECK_THROWS_AS(ParseHardwareDecoding("gpu"), Error);
  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string clip = MakeClip("x264_fallback.mp4", "-c:v libx264 -pix_fmt yuv420p -g 10");
  const std::string missing = NvdecMissing(clip);
  if (missing.empty()) return test::Skip("hardware_fallback needs a machine without NVDEC");
  FrameSourceOptions options;
  options.hardware = HardwareDecoding::kCuda;
  try {
    FrameSource source(clip, options);
    FAIL("kCuda opened without NVDEC");
  } catch (const Error& e) {
    const std::string what = e.what();
    CHECK(what.rfind(clip + ": cannot decode (NVDEC: ", 0) == 0);
    CHECK(what.find('\n') == std::string::npos);
  }
  CheckAutoAsCpu(clip, false);  // kAuto decodes on the CPU
}

}  // namespace
}  // namespace pano

// A video that ends early or holds damaged data is an error that names the
// input and the frame, after every good frame; a clean video ends cleanly.
#include <catch2/catch.hpp>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "test_paths.h"
#include "test_skip.h"
#include "test_videos.h"
#include "panotrack/video/frame_source.h"
#include "panotrack/video/luma_decoder.h"

namespace pano {
namespace {

constexpr int kFrames = 62;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// The frames before the error are 0, 1, ..., k-1 and the error names the
// input and frame k, with the expected reason.
void CheckFailsAfterGoodFrames(const std::string& path, const test::ReadOutcome& r,
                               const std::string& reason) {
  INFO(path << ": " << r.error);
  const int k = static_cast<int>(r.indices.size());
  CHECK(r.indices == test::Iota(k));
  CHECK(k < kFrames);
  CHECK(Contains(r.error, path + ": decode error at frame " + std::to_string(k) + ": "));
  CHECK(Contains(r.error, reason));
  CHECK_FALSE(Contains(r.error, "\n"));
}

TEST_CASE("clean videos of several encodings end without an error", "[clean]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_clean");
  struct Encoding {
    std::string file, args;
    int listed;  // frames the container lists; -1 none
  };
  const std::vector<Encoding> encodings = {
      {"x264.mp4", "-c:v libx264 -pix_fmt yuv420p", kFrames},
      {"x264_faststart.mp4", "-c:v libx264 -pix_fmt yuv420p -movflags +faststart", kFrames},
      {"x264.mkv", "-c:v libx264 -pix_fmt yuv420p", -1},
      {"mpeg4.avi", "-c:v mpeg4 -q:v 2", kFrames},
      {"mjpeg.avi", "-c:v mjpeg -q:v 2", kFrames},
      {"mpeg2.ts", "-c:v mpeg2video -q:v 2", -1},
      {"vp9.webm", "-c:v libvpx-vp9 -pix_fmt yuv420p -crf 20 -b:v 0 -deadline realtime -cpu-used 8", -1},
      {"ffv1_gray.mkv", "-c:v ffv1 -pix_fmt gray", -1},
  };
  for (const Encoding& e : encodings) {
    const std::string path = dir + "/" + e.file;
    test::MakeVideo(path, kFrames, e.args);
    const test::ReadOutcome r = test::ReadAll(path);
    INFO(path << ": " << r.error);
    CHECK(r.error.empty());
    CHECK(r.indices == test::Iota(kFrames));
    CHECK(r.frame_count == e.listed);
    CHECK(FrameSource::FrameCount(path) == e.listed);
    REQUIRE(r.times.size() == r.indices.size());
    for (size_t i = 0; i < r.times.size(); ++i)
      CHECK(r.times[i] == Approx(i / test::kFrameRate).margin(1e-3));
  }
  // A video whose name holds a '%' is no image pattern.
  std::filesystem::copy_file(dir + "/x264.mp4", dir + "/x264_%d.mp4");
  CHECK(test::ReadAll(dir + "/x264_%d.mp4").indices == test::Iota(kFrames));
  CHECK(FrameSource::FrameCount(dir + "/x264_%d.mp4") == kFrames);
}

TEST_CASE("a truncated video fails after its last good frame", "[truncated]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_truncated");
  // The index at the front: the container lists 62 frames, half of them are there.
  test::MakeVideo(dir + "/front.mp4", kFrames, "-c:v libx264 -pix_fmt yuv420p -movflags +faststart");
  test::CutFile(dir + "/front.mp4", dir + "/front_half.mp4", 0.5);
  test::ReadOutcome r = test::ReadAll(dir + "/front_half.mp4");
  CheckFailsAfterGoodFrames(dir + "/front_half.mp4", r, "truncated file (container lists 62 frames)");
  CHECK(r.indices.size() > 10);
  CHECK(FrameSource::FrameCount(dir + "/front_half.mp4") == kFrames);

  // The index at the end is lost with the second half: the file cannot be opened.
  test::MakeVideo(dir + "/end.mp4", kFrames, "-c:v libx264 -pix_fmt yuv420p");
  test::CutFile(dir + "/end.mp4", dir + "/end_half.mp4", 0.5);
  r = test::ReadAll(dir + "/end_half.mp4");
  INFO(r.error);
  CHECK(r.frame_count == -2);
  CHECK(r.error == dir + "/end_half.mp4: cannot open as a video (moov atom not found)");
  CHECK(FrameSource::FrameCount(dir + "/end_half.mp4") == -1);

  // Matroska lists its duration, not its frames.
  test::MakeVideo(dir + "/a.mkv", kFrames, "-c:v libx264 -pix_fmt yuv420p");
  test::CutFile(dir + "/a.mkv", dir + "/a_half.mkv", 0.5);
  r = test::ReadAll(dir + "/a_half.mkv");
  CheckFailsAfterGoodFrames(dir + "/a_half.mkv", r,
                            "truncated or damaged file (container lists 2.48 s, data ends at ");
  CHECK(r.indices.size() > 10);

  // AVI keeps its frame count in the header.
  test::MakeVideo(dir + "/a.avi", kFrames, "-c:v mpeg4 -q:v 2");
  test::CutFile(dir + "/a.avi", dir + "/a_half.avi", 0.5);
  r = test::ReadAll(dir + "/a_half.avi");
  CheckFailsAfterGoodFrames(dir + "/a_half.avi", r, "truncated file (container lists 62 frames)");
  CHECK(r.indices.size() > 10);
}

TEST_CASE("damaged bytes in the middle of a video are a decode error", "[corrupt]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_corrupt");
  struct Case {
    std::string file, args;
  };
  const std::vector<Case> cases = {
      {"x264.mp4", "-c:v libx264 -pix_fmt yuv420p"},
      {"x264_nob.mp4", "-c:v libx264 -pix_fmt yuv420p -bf 0"},
      {"x264.mkv", "-c:v libx264 -pix_fmt yuv420p"},
      {"mpeg4.avi", "-c:v mpeg4 -q:v 2"},
      {"x264.ts", "-c:v libx264 -pix_fmt yuv420p"},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.file, damaged = dir + "/damaged_" + c.file;
    test::MakeVideo(path, kFrames, c.args);
    test::ScribbleFile(path, damaged, 0.5, 300);
    const test::ReadOutcome r = test::ReadAll(damaged);
    CheckFailsAfterGoodFrames(damaged, r, "");
    CHECK(r.indices.size() > 10);
    // The same frames and error whatever the decoding threads (frame threads
    // flag damage only now and then), run after run.
    for (int threads : {1, 2, 8, 8, 16, 16}) {
      FrameSourceOptions options;
      options.decoder_threads = threads;
      const test::ReadOutcome again = test::ReadAll(damaged, options);
      INFO(damaged << " on " << threads << " decoding threads: " << again.error);
      CHECK(again.indices == r.indices);
      CHECK(again.error == r.error);
    }
  }
}

TEST_CASE("videos without a luma plane go through cv::VideoCapture with the same checks", "[fallback]") {
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_fallback");
  const std::string avi = dir + "/bgr.avi", mov = dir + "/rgb.mov";
  test::MakeVideo(avi, kFrames, "-c:v rawvideo -pix_fmt bgr24");
  test::MakeVideo(mov, kFrames, "-c:v png -pix_fmt rgb24 -movflags +faststart");
  for (const std::string& path : {avi, mov}) {
    if (LumaDecoderAvailable()) {  // these really take the fallback
      LumaDecoder luma;
      std::string why;
      CHECK_FALSE(luma.Open(path, &why));
      CHECK(luma.container_opened());
      CHECK(Contains(why, "has no 8-bit luma plane"));
    }
    const test::ReadOutcome r = test::ReadAll(path);
    INFO(path << ": " << r.error);
    CHECK(r.error.empty());
    CHECK(r.indices == test::Iota(kFrames));
    CHECK(r.frame_count == kFrames);
    for (size_t i = 0; i < r.times.size(); ++i)
      CHECK(r.times[i] == Approx(i / test::kFrameRate).margin(1e-3));

    const std::string half = dir + "/half_" + std::filesystem::path(path).filename().string();
    test::CutFile(path, half, 0.5);
    const test::ReadOutcome h = test::ReadAll(half);
    CheckFailsAfterGoodFrames(half, h, "truncated or damaged file (container lists 62 frames)");
    CHECK(h.indices.size() > 10);
  }
}

TEST_CASE("an unreadable image in a folder or a pattern is an error after the good ones", "[images]") {
  const std::string dir = test::ScratchDir("video_images");
  std::filesystem::create_directories(dir + "/frames");
  for (int i = 0; i < 6; ++i) {
    const std::string name = dir + "/frames/f" + std::to_string(i) + ".png";
    if (i == 4) test::WriteFileBytes(name, "not a png image");
    else REQUIRE(cv::imwrite(name, test::CodedFrame(i)));
  }
  test::ReadOutcome r = test::ReadAll(dir + "/frames");
  CHECK(r.indices == test::Iota(4));
  CHECK(r.error == dir + "/frames/f4.png: cannot decode the image");
  for (double t : r.times) CHECK(std::isnan(t));

  r = test::ReadAll(dir + "/frames/f%d.png");
  CHECK(r.indices == test::Iota(4));
  CHECK(r.error == dir + "/frames/f4.png: cannot decode the image");
  CHECK(FrameSource::FrameCount(dir + "/frames/f%d.png") == 6);
  // Numbering from 1, and a pattern that is not one integer conversion.
  std::filesystem::create_directories(dir + "/from1");
  for (int i = 1; i <= 3; ++i)
    REQUIRE(
        cv::imwrite(dir + "/from1/g_" + std::to_string(1000 + i).substr(1) + ".pgm", test::CodedFrame(i)));
  r = test::ReadAll(dir + "/from1/g_%03d.pgm");
  CHECK(r.error.empty());
  CHECK(r.indices == std::vector<int>{1, 2, 3});
  CHECK(r.frame_count == 3);
  r = test::ReadAll(dir + "/from1/g_%s.pgm");
  CHECK(r.error ==
        dir + "/from1/g_%s.pgm: unsupported pattern (one %d conversion expected, e.g. frame_%04d.png)");
  for (double t : r.times) CHECK(std::isnan(t));
}

TEST_CASE("16-bit and floating point images are read as a camera's full range in 8 bits", "[image_depth]") {
  const std::string dir = test::ScratchDir("video_image_depth");
  cv::Mat grey(48, 64, CV_8U);
  for (int y = 0; y < grey.rows; ++y)
    for (int x = 0; x < grey.cols; ++x) grey.at<uint8_t>(y, x) = static_cast<uint8_t>((x * 4 + y) % 256);
  cv::Mat wide, colour, real;
  grey.convertTo(wide, CV_16U, 256.0);  // the 8-bit image in the high byte
  cv::cvtColor(wide, colour, cv::COLOR_GRAY2BGR);
  grey.convertTo(real, CV_32F, 1.0 / 255);
  for (const auto& [name, image] : {std::pair<std::string, cv::Mat>{"grey16.png", wide}, {"colour16.png", colour},
                                    {"float.tiff", real}}) {
    std::filesystem::create_directories(dir + "/" + name);
    const std::string file = dir + "/" + name + "/" + name;
    REQUIRE(cv::imwrite(file, image));
    REQUIRE(cv::imread(file, cv::IMREAD_UNCHANGED).depth() == image.depth());
    FrameSource source(dir + "/" + name, FrameSourceOptions());
    cv::Mat read;
    double t;
    REQUIRE(source.Read(&read, &t));
    INFO(name);
    REQUIRE(read.type() == CV_8U);
    CHECK(cv::norm(read, grey, cv::NORM_INF) == 0);
  }
}

}  // namespace
}  // namespace pano

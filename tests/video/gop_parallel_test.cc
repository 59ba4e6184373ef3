// Decoding groups of pictures in parallel hands out the same frames, with
// the same times, in the same order as one decoder does, and fails on a
// damaged or truncated file after the same good frames as a single-threaded
// decoder, naming the same frame.
#include <catch2/catch.hpp>
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

FrameSourceOptions Options(bool gop_parallel) {
  FrameSourceOptions options;
  options.decoder_threads = 2;
  options.gop_parallel_bytes = gop_parallel ? size_t(64) << 20 : 0;
  return options;
}

TEST_CASE("groups of pictures decoded in parallel give the frames one decoder gives", "[gop_parallel]") {
  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_gop_parallel");
  struct Encoding {
    std::string file, args;
    bool parallel;  // expected to be decoded in parallel
  };
  const std::vector<Encoding> encodings = {
      // IDR pictures every 10 frames, B-frames reordered across them.
      {"x264_g10.mp4", "-c:v libx264 -pix_fmt yuv420p -g 10 -bf 3", true},
      {"x264_g20_nob.mp4", "-c:v libx264 -pix_fmt yuv420p -g 20 -bf 0", true},
      // Parameter sets repeated in band at every IDR picture.
      {"x264_headers.mp4", "-c:v libx264 -pix_fmt yuv420p -g 12 -x264-params repeat-headers=1", true},
      // Keyframes that are no IDR pictures: one segment, decoded whole.
      {"x264_open.mp4", "-c:v libx264 -pix_fmt yuv420p -g 10 -x264-params open-gop=1", true},
      {"x265_g16.mp4", "-c:v libx265 -pix_fmt yuv420p -x265-params keyint=16:min-keyint=16:open-gop=0:log-level=0",
       true},
      // One group of pictures; other codecs and containers: one decoder.
      {"x264_one_gop.mp4", "-c:v libx264 -pix_fmt yuv420p", false},
      {"x264_g10.mkv", "-c:v libx264 -pix_fmt yuv420p -g 10", false},
      {"mpeg4_g10.avi", "-c:v mpeg4 -q:v 2 -g 10", false},
  };
  for (const Encoding& e : encodings) {
    const std::string path = dir + "/" + e.file;
    test::MakeVideo(path, kFrames, e.args);
    bool parallel = false, single = true;
    const test::ReadOutcome p = test::ReadAll(path, Options(true), &parallel);
    const test::ReadOutcome s = test::ReadAll(path, Options(false), &single);
    INFO(path << ": " << p.error << " / " << s.error);
    CHECK(parallel == e.parallel);
    CHECK_FALSE(single);
    CHECK(p.error.empty());
    CHECK(s.error.empty());
    CHECK(p.indices == test::Iota(kFrames));
    CHECK(p.indices == s.indices);
    CHECK(p.times == s.times);
  }
  // Groups of pictures larger than the memory allowed: one decoder.
  FrameSourceOptions small = Options(true);
  small.gop_parallel_bytes = 9 * test::kFrameWidth * test::kFrameHeight;  // 10-frame groups
  bool parallel = true;
  const test::ReadOutcome r = test::ReadAll(dir + "/x264_g10.mp4", small, &parallel);
  CHECK_FALSE(parallel);
  CHECK(r.indices == test::Iota(kFrames));
  small.gop_parallel_bytes = 10 * test::kFrameWidth * test::kFrameHeight;
  CHECK(test::ReadAll(dir + "/x264_g10.mp4", small, &parallel).indices == test::Iota(kFrames));
  CHECK(parallel);
  // A single thread: one decoder.
  FrameSourceOptions one = Options(true);
  one.decoder_threads = 1;
  CHECK(test::ReadAll(dir + "/x264_g10.mp4", one, &parallel).indices == test::Iota(kFrames));
  CHECK_FALSE(parallel);
}

TEST_CASE("the last groups of pictures go to one decoder with all the threads where two would share them unevenly",
          "[gop_parallel]") {
  // Segments of equal cost, an even count: the two decoders share them.
  CHECK(detail::FirstTailSegment({1, 1, 1, 1}) == -1);
  CHECK(detail::FirstTailSegment(std::vector<double>(12, 1.0)) == -1);
  CHECK(detail::FirstTailSegment({1, 1}) == -1);
  // An odd count: the last one alone (1 + 1 / 1.6 instead of 2).
  CHECK(detail::FirstTailSegment({1, 1, 1}) == 2);
  CHECK(detail::FirstTailSegment({1, 1, 1, 1, 1}) == 4);
  // Five groups and a short sixth (x264's 250-frame groups, 1320 frames):
  // the last two (2 + 1.28 / 1.6 instead of 3).
  CHECK(detail::FirstTailSegment({1, 1, 1, 1, 1, 0.28}) == 4);
  // A short last one on an even count, not short enough to pay.
  CHECK(detail::FirstTailSegment({1, 1, 1, 1, 1, 1, 1, 0.5}) == -1);
  // One decoder's share far the longer: all of it on all the threads.
  CHECK(detail::FirstTailSegment({1, 0.1}) == 0);
  CHECK(detail::FirstTailSegment({}) == -1);
  CHECK(detail::FirstTailSegment({1}) == 0);

  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_gop_tail");
  LumaDecoderOptions options;
  options.num_threads = 2;
  options.gop_parallel_bytes = size_t(64) << 20;
  // 20-frame segments (IDR pictures every 10 frames, segments of at least
  // 16): three of them have a tail, four have none; the frames are those
  // of one decoder either way.
  for (const int frames : {60, 80}) {
    const std::string path = dir + "/g10_" + std::to_string(frames) + ".mp4";
    test::MakeVideo(path, frames, "-c:v libx264 -pix_fmt yuv420p -g 10 -bf 0");
    LumaDecoder decoder;
    std::string why;
    REQUIRE(decoder.Open(path, &why, options));
    INFO(path);
    CHECK(decoder.gop_parallel());
    CHECK(decoder.gop_tail() == (frames == 60));
    std::vector<int> seen;
    cv::Mat grey;
    while (decoder.Read(&grey)) seen.push_back(test::FrameIndex(grey));
    CHECK(seen == test::Iota(frames));
  }
  // Four threads, two for each decoder: no tail (its plan's speed-up is
  // that of one thread against two).
  options.num_threads = 4;
  LumaDecoder four;
  std::string why;
  REQUIRE(four.Open(dir + "/g10_60.mp4", &why, options));
  CHECK(four.gop_parallel());
  CHECK_FALSE(four.gop_tail());
}

TEST_CASE("frames held by the caller stay intact while groups of pictures decode in parallel",
          "[gop_parallel]") {
  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string path = test::ScratchDir("video_gop_parallel_held") + "/g10.mp4";
  test::MakeVideo(path, kFrames, "-c:v libx264 -pix_fmt yuv420p -g 10");
  // Every third frame held to the end, the others let go at once: the
  // buffers of those are filled again, never those of the held ones.
  FrameSource source(path, Options(true));
  REQUIRE(source.gop_parallel());
  std::vector<cv::Mat> held;
  std::vector<int> seen;
  cv::Mat grey;
  for (int i = 0; source.Read(&grey); ++i) {
    seen.push_back(test::FrameIndex(grey));
    if (i % 3 == 0) held.push_back(grey);
    grey.release();
  }
  CHECK(seen == test::Iota(kFrames));
  REQUIRE(held.size() == (kFrames + 2) / 3);
  for (size_t k = 0; k < held.size(); ++k) CHECK(test::FrameIndex(held[k]) == static_cast<int>(3 * k));
}

TEST_CASE("groups of pictures decoded in parallel fail where one decoder fails", "[gop_parallel]") {
  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_gop_parallel_errors");
  const std::string args = "-c:v libx264 -pix_fmt yuv420p -g 10 -movflags +faststart";
  test::MakeVideo(dir + "/a.mp4", kFrames, args);
  struct Case {
    std::string file, reason;
  };
  test::CutFile(dir + "/a.mp4", dir + "/cut.mp4", 0.6);
  test::ScribbleFile(dir + "/a.mp4", dir + "/scribbled.mp4", 0.5, 300);
  const std::vector<Case> cases = {{"cut.mp4", "truncated file (container lists 62 frames)"},
                                   {"scribbled.mp4", ""}};
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.file;
    bool parallel = false;
    const test::ReadOutcome p = test::ReadAll(path, Options(true), &parallel);
    // One single-threaded decoder: FFmpeg's frame threads may miss that
    // a frame was concealed.
    FrameSourceOptions one = Options(false);
    one.decoder_threads = 1;
    const test::ReadOutcome s = test::ReadAll(path, one);
    INFO(path << ": " << p.error << " / " << s.error);
    CHECK(parallel);
    const int k = static_cast<int>(p.indices.size());
    CHECK(k > 10);
    CHECK(k < kFrames);
    CHECK(p.indices == test::Iota(k));
    CHECK(p.error.find(path + ": decode error at frame " + std::to_string(k) + ": " + c.reason) == 0);
    CHECK(p.error.find('\n') == std::string::npos);
    CHECK(p.indices == s.indices);
    CHECK(p.error == s.error);
  }
}

// Every frame and the error, read straight from a LumaDecoder.
test::ReadOutcome ReadLuma(const std::string& path, const LumaDecoderOptions& options) {
  test::ReadOutcome out;
  try {
    LumaDecoder decoder;
    std::string why;
    if (!decoder.Open(path, &why, options)) throw Error(path + ": " + why);
    cv::Mat grey;
    while (decoder.Read(&grey)) out.indices.push_back(test::FrameIndex(grey));
  } catch (const Error& e) {
    out.error = e.what();
  }
  return out;
}

TEST_CASE("a file damaged where a group of pictures starts fails the same way on every run, whatever the threads",
          "[gop_parallel]") {
  if (!LumaDecoderAvailable()) return test::Skip("built without FFmpeg");
  if (!test::HaveFfmpegTool()) return test::Skip("no ffmpeg command-line tool");
  const std::string dir = test::ScratchDir("video_gop_damage");
  test::MakeVideo(dir + "/a.mp4", kFrames, "-c:v libx264 -pix_fmt yuv420p -g 10 -movflags +faststart");
  // Seven tenths in: the IDR picture that starts the third segment (frame
  // 40), where the tail decoder's frame threads take over from the two.
  const std::string path = dir + "/damaged.mp4";
  test::ScribbleFile(dir + "/a.mp4", path, 0.7, 300);
  LumaDecoderOptions reference;
  reference.num_threads = 2;
  reference.gop_parallel_bytes = size_t(64) << 20;
  reference.gop_tail = false;
  const test::ReadOutcome expected = ReadLuma(path, reference);
  INFO(expected.error);
  REQUIRE_FALSE(expected.error.empty());
  REQUIRE(expected.indices == test::Iota(static_cast<int>(expected.indices.size())));
  // With the tail (two threads) and with frame threads in both decoders
  // (four): the frame threads flag damage only now and then, so each run
  // decodes again without them once damage shows, from the same frame on.
  for (const int threads : {2, 4}) {
    LumaDecoderOptions options = reference;
    options.num_threads = threads;
    options.gop_tail = true;
    for (int run = 0; run < 5; ++run) {
      const test::ReadOutcome got = ReadLuma(path, options);
      INFO(threads << " threads, run " << run << ": " << got.error);
      CHECK(got.indices == expected.indices);
      CHECK(got.error == expected.error);
    }
  }
}

}  // namespace
}  // namespace pano

// The calibration's input without a target file (ReadTargetInput): a folder
// of images in natural order, and a video's frames sampled and read.
#include <catch2/catch.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <cmath>
#include <filesystem>
#include <string>

#include "expect_error.h"
#include "panotrack/calibrate/calibrate.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/target_input.h"
#include "test_paths.h"
#include "test_skip.h"

namespace pano {
namespace {

using test::ErrorOf;

TargetInputBoard Board(const std::string& spec) {
  TargetInputBoard in;
  in.board_given = true;
  in.board = ParseBoardSpec(spec, 3.0, 2.2);
  return in;
}

TEST_CASE("a folder of images: natural order, each image loaded; the board required", "[folder_input]") {
  const std::string dir = test::ScratchDir("calibrate_folder");
  // Image k is uniformly grey at 10 k: the order shows in the pixels.
  for (int k : {10, 2, 1}) cv::imwrite(dir + "/image_" + std::to_string(k) + ".png", cv::Mat(8, 12, CV_8UC1, cv::Scalar(10 * k)));
  const TargetSet t = ReadTargetInput(dir, Board("7x11"));
  REQUIRE(t.images.size() == 3);
  CHECK(t.images[0].file == "image_1.png");
  CHECK(t.images[1].file == "image_2.png");
  CHECK(t.images[2].file == "image_10.png");
  CHECK(t.units == "cm");
  const std::vector<cv::Mat> images = LoadTargetImages(t);
  REQUIRE(images.size() == 3);
  CHECK(images[2].at<uint8_t>(4, 4) == 100);
  CHECK(ErrorOf([&] { ReadTargetInput(dir, TargetInputBoard()); }).find("--board: required with a folder") == 0);
  // A target file gives its own board.
  TargetSet file = t;
  WriteTargets(dir + "/targets.yml", file, false);
  CHECK(ErrorOf([&] { ReadTargetInput(dir + "/targets.yml", Board("7x11")); }).find("is a target file") !=
        std::string::npos);
  CHECK(ReadTargetInput(dir + "/targets.yml", TargetInputBoard()).images.size() == 3);
  // Images of two sizes: the error names both.
  cv::imwrite(dir + "/image_11.png", cv::Mat(9, 12, CV_8UC1, cv::Scalar(0)));
  CHECK(ErrorOf([&] { LoadTargetImages(ReadTargetInput(dir, Board("7x11"))); })
            .find("image_11.png: image size 12x9 differs from image_1.png (12x8)") == 0);
}

TEST_CASE("a video: every N-th frame, named VIDEO#FRAME, read front to back", "[video_input]") {
  const std::string dir = test::ScratchDir("calibrate_video");
  const std::string path = dir + "/run.avi";
  // 95 frames, frame f uniformly grey at 2 f (MJPG keeps flat frames flat).
  {
    cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0, cv::Size(64, 48), false);
    if (!writer.isOpened()) {
      test::Skip("OpenCV cannot write an MJPG video here");
      return;
    }
    for (int f = 0; f < 95; ++f) writer.write(cv::Mat(48, 64, CV_8UC1, cv::Scalar(2 * f)));
  }
  CHECK(CountVideoFrames(path) == 95);
  TargetInputBoard in = Board("charuco:7x11");
  const TargetSet t = ReadTargetInput(path, in);  // about 30 frames: every 4th
  REQUIRE(t.images.size() == 24);
  CHECK(t.images[1].file == "run.avi#4");
  CHECK(t.board.IsCharuco());
  const std::vector<cv::Mat> frames = LoadTargetImages(t);
  REQUIRE(frames.size() == 24);
  for (size_t k = 0; k < frames.size(); ++k) {
    INFO("frame " << t.images[k].frame);
    CHECK(frames[k].type() == CV_8UC1);
    CHECK(std::abs(cv::mean(frames[k])[0] - 2.0 * t.images[k].frame) < 1.5);
  }
  in.every = 40;
  const TargetSet sparse = ReadTargetInput(path, in);
  REQUIRE(sparse.images.size() == 3);
  CHECK(sparse.images[2].file == "run.avi#80");
  CHECK(std::abs(cv::mean(LoadTargetImages(sparse)[2])[0] - 160.0) < 1.5);
  CHECK(ErrorOf([&] { ReadTargetInput(path, TargetInputBoard()); }).find("--board: required with a video") == 0);
  // Cut in half: an error naming the video and the frame, not the frames before the cut.
  std::filesystem::resize_file(path, std::filesystem::file_size(path) / 2);
  const std::string error = ErrorOf([&] { ReadTargetInput(path, in); });
  INFO(error);
  CHECK(error.find(path + ": decode error at frame ") == 0);
  CHECK(error.find("truncated") != std::string::npos);
}

}  // namespace
}  // namespace pano

// Calibration input without a target file: the --board spec, natural order,
// the input's kind, a folder's images and a video's sampled frames; and the
// ChArUco fields of the target file.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "expect_error.h"
#include "panotrack/core/error.h"
#include "panotrack/io/targets.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::ErrorOf;

TEST_CASE("--board specs: chessboard and ChArUco, cols x rows inner corners", "[board_spec]") {
  const TargetBoard c = ParseBoardSpec("7x11", 30.0);
  CHECK(c.type == "chessboard");
  CHECK(c.cols == 7);
  CHECK(c.rows == 11);
  CHECK(c.square == 30.0);
  const TargetBoard a = ParseBoardSpec("charuco:7x11", 30.0, 22.0, "DICT_5X5_50");
  CHECK(a.IsCharuco());
  CHECK(a.cols == 7);
  CHECK(a.rows == 11);
  CHECK(a.marker == 22.0);
  CHECK(a.dictionary == "DICT_5X5_50");
  CHECK(CharucoMarkerCount(a) == 48);
  for (const char* bad : {"7", "7x", "x11", "7x11x2", "-7x11", "7 x 11", "charuco:", "hex:7x11"})
    CHECK(ErrorOf([&] { ParseBoardSpec(bad, 30.0, 22.0); }).find("--board: expected COLSxROWS") == 0);
  CHECK(ErrorOf([] { ParseBoardSpec("1x11", 30.0); }).find("2..1000 inner corners") != std::string::npos);
  CHECK(ErrorOf([] { ParseBoardSpec("7x11", 0.0); }).find("positive square") != std::string::npos);
  CHECK(ErrorOf([] { ParseBoardSpec("charuco:7x11", 30.0, 0.0); }) ==
        "--marker: a ChArUco board (--board charuco:7x11) needs the side of its markers");
  CHECK(ErrorOf([] { ParseBoardSpec("charuco:7x11", 30.0, 30.0); }).find("marker side") != std::string::npos);
  CHECK(ErrorOf([] { ParseBoardSpec("charuco:7x11", 30.0, 22.0, "DICT_9X9"); }).find("unknown ArUco dictionary") !=
        std::string::npos);
  // 96 squares need 48 markers: DICT_APRILTAG_16h5 has 30.
  CHECK(ErrorOf([] { ParseBoardSpec("charuco:7x11", 30.0, 22.0, "DICT_APRILTAG_16h5"); })
            .find("needs 48 markers, DICT_APRILTAG_16h5 has 30") != std::string::npos);
  CHECK(ArucoDictionaryId("DICT_4X4_50") == 0);
  CHECK(ArucoDictionaryId("DICT_APRILTAG_36h11") == 20);
  CHECK(ArucoDictionarySize(ArucoDictionaryId("DICT_ARUCO_ORIGINAL")) == 1024);
}

TEST_CASE("natural order: digit runs as numbers", "[natural_order]") {
  std::vector<std::string> names = {"image_10.png", "image_2.png", "image_1.png", "img.png",
                                    "image_02.png", "image_1a.png", "Image_3.png", "image_100.png"};
  std::sort(names.begin(), names.end(), NaturalLess);
  CHECK(names == std::vector<std::string>{"Image_3.png", "image_1.png", "image_1a.png", "image_02.png",
                                          "image_2.png", "image_10.png", "image_100.png", "img.png"});
  CHECK(NaturalLess("a9", "a10"));
  CHECK_FALSE(NaturalLess("a10", "a9"));
  CHECK(NaturalLess("a", "a0"));
  CHECK_FALSE(NaturalLess("a1", "a1"));
  CHECK(NaturalLess("frame_99999999999999999999", "frame_100000000000000000000"));  // past 64 bits
}

TEST_CASE("a folder of images: image files only, in natural order; video frames sampled", "[folder_frames]") {
  namespace fs = std::filesystem;
  const std::string dir = test::ScratchDir("io_targets_folder");
  for (const char* name : {"cal_10.png", "cal_2.PNG", "cal_1.jpg", "notes.txt", "targets.yaml"})
    std::ofstream(dir + "/" + name) << "x";
  fs::create_directory(dir + "/sub.png");  // a folder, not an image
  const TargetBoard board = ParseBoardSpec("9x6", 3.0);
  CHECK(ClassifyTargetInput(dir) == TargetInputKind::kImageFolder);
  CHECK(ClassifyTargetInput(dir + "/targets.yaml") == TargetInputKind::kTargetFile);
  CHECK(ClassifyTargetInput(dir + "/missing.YML") == TargetInputKind::kTargetFile);  // ReadTargets says it is missing
  CHECK(ClassifyTargetInput(dir + "/notes.txt") == TargetInputKind::kVideo);
  CHECK(ErrorOf([&] { ClassifyTargetInput(dir + "/missing.avi"); }).find("no such target file") != std::string::npos);
  const TargetSet t = TargetsFromFolder(dir, board, "mm");
  REQUIRE(t.images.size() == 3);
  CHECK(t.images[0].file == "cal_1.jpg");
  CHECK(t.images[1].file == "cal_2.PNG");
  CHECK(t.images[2].file == "cal_10.png");
  CHECK(t.images[2].resolved == dir + "/cal_10.png");
  CHECK(t.units == "mm");
  CHECK(t.board.cols == 9);
  CHECK_FALSE(t.AllPosesKnown());
  const std::string empty = test::ScratchDir("io_targets_empty");
  CHECK(ErrorOf([&] { TargetsFromFolder(empty, board, "cm"); }).find("no images in the folder") != std::string::npos);

  // 95 frames: every 4th by default (ceil(95 / 30)): 24 frames, 0..92.
  CHECK(DefaultFrameStep(95) == 4);
  CHECK(DefaultFrameStep(30) == 1);
  CHECK(DefaultFrameStep(1) == 1);
  const TargetSet v = TargetsFromVideoFrames("/data/run.mp4", 95, 0, board, "cm");
  REQUIRE(v.images.size() == 24);
  CHECK(v.images[0].file == "run.mp4#0");
  CHECK(v.images[23].file == "run.mp4#92");
  CHECK(v.images[23].frame == 92);
  CHECK(v.images[23].resolved == "/data/run.mp4");
  CHECK(TargetsFromVideoFrames("run.mp4", 95, 10, board, "cm").images.size() == 10);
  CHECK(ErrorOf([&] { TargetsFromVideoFrames("run.mp4", 0, 0, board, "cm"); }).find("no frames") != std::string::npos);
}

TEST_CASE("ChArUco fields of the target file", "[charuco_yaml]") {
  TargetSet t;
  t.board = ParseBoardSpec("charuco:7x11", 3.0, 2.2, "DICT_5X5_100");
  t.images.push_back({"a.png", "", false, {}, {}});
  const std::string dir = test::ScratchDir("io_targets_charuco");
  WriteTargets(dir + "/t.yaml", t);
  const TargetSet back = ReadTargets(dir + "/t.yaml");
  CHECK(back.board.type == "charuco");
  CHECK(back.board.cols == 7);
  CHECK(back.board.rows == 11);
  CHECK(back.board.marker == 2.2);
  CHECK(back.board.dictionary == "DICT_5X5_100");
  // A chessboard's file has neither field.
  TargetSet c = t;
  c.board = ParseBoardSpec("7x11", 3.0);
  CHECK(TargetsToYaml(c).find("marker") == std::string::npos);
  auto read = [&](const std::string& board_text) {
    std::ofstream(dir + "/b.yaml") << "board:\n" << board_text << "images:\n  - file: a.png\n";
    return ErrorOf([&] { ReadTargets(dir + "/b.yaml"); });
  };
  CHECK(read("  type: charuco\n  cols: 7\n  rows: 11\n  square: 3\n").find("board.marker: missing") !=
        std::string::npos);
  CHECK(read("  type: charuco\n  cols: 7\n  rows: 11\n  square: 3\n  marker: 2\n  dictionary: DICT_4X4_5\n")
            .find("unknown ArUco dictionary 'DICT_4X4_5'") != std::string::npos);
  CHECK(read("  type: charuco\n  cols: 7\n  rows: 11\n  square: 3\n  marker: 2\n") == "");  // DICT_4X4_50 by default
}

}  // namespace
}  // namespace pano

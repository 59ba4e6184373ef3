// Readers facing files that are not what they claim: folders, endless
// streams, wrong kinds of YAML node, absurd sizes. Each is refused with one
// pano::Error line that names the file and the problem.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "expect_error.h"
#include "panotrack/core/error.h"
#include "core/test_fifo.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/targets.h"
#include "panotrack/io/yaml_util.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::ExpectError;

namespace fs = std::filesystem;

std::string Write(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string p = dir + "/" + name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

const std::string kCalib =
    "model: sphere\nunits: cm\nimage_width: 500\nimage_height: 500\nfocal_px: 590.0\ncx: 249.5\n"
    "cy: 249.5\nmirror_radius: 4.9\nmirror_distance: 15.1\n";
const std::string kMap =
    "units: cm\nsensor_height: 30.0\nroom:\n  min: [0, 0]\n  max: [200, 200]\n  height: 120\n"
    "rectangles:\n  - id: door\n    from: [0.0, 50.0]\n    to: [0.0, 90.0]\n    z: [0.0, 100.0]\n";
const std::string kTargets =
    "units: cm\nboard:\n  type: chessboard\n  cols: 9\n  rows: 6\n  square: 3.0\nimages:\n"
    "  - file: cal_000.png\n";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

TEST_CASE("a folder given as a file", "[bad_input]") {
  const std::string dir = test::ScratchDir("io_bad_folder");
  fs::create_directories(dir + "/calib.yaml");
  ExpectError([&] { ReadCalibration(dir + "/calib.yaml"); }, dir + "/calib.yaml", {"folder"});
  ExpectError([&] { ReadMap(dir + "/calib.yaml"); }, dir + "/calib.yaml", {"folder"});
  ExpectError([&] { ReadTargets(dir + "/calib.yaml"); }, dir + "/calib.yaml", {"folder"});
}

TEST_CASE("the wrong kind of node: lists or mappings for scalars and the reverse", "[bad_input]") {
  const std::string dir = test::ScratchDir("io_bad_kind");
  using Fragments = std::initializer_list<std::string>;
  auto calib = [&](const std::string& name, const std::string& text, Fragments frags) {
    const std::string p = Write(dir, name, text);
    ExpectError([&] { ReadCalibration(p); }, p, frags);
  };
  calib("units.yaml", Replace(kCalib, "units: cm", "units: [a, b]"), {"units", "string", "a list"});
  calib("focal.yaml", Replace(kCalib, "focal_px: 590.0", "focal_px: {x: 1}"),
        {"focal_px", "number", "a mapping"});
  calib("width.yaml", Replace(kCalib, "image_width: 500", "image_width: [500]"), {"image_width", "integer"});
  calib("model.yaml", Replace(kCalib, "model: sphere", "model: {sphere: 1}"), {"model", "string"});
  calib("lut.yaml", kCalib + "lut: [a.lut]\n", {"lut", "string", "a list"});
  // Keys that are not plain strings, and keys given twice (yaml-cpp keeps the first silently).
  calib("complex_key.yaml", kCalib + "? [a, b]\n: 1\n", {"line 10", "key", "plain string"});
  calib("map_key.yaml", kCalib + "{x: 1}: 2\n", {"key", "plain string"});
  calib("dup.yaml", kCalib + "focal_px: 600\n", {"line 10", "duplicate key 'focal_px'"});
  calib("two_docs.yaml", kCalib + "---\nmodel: conic\n", {"more than one YAML document"});
  calib("scalar_top.yaml", "just a line\n", {"mapping"});
  calib("nul.yaml", kCalib + std::string("extra: 1\0\n", 10), {"NUL"});
  // Nesting deeper than yaml-cpp's guard: an error, not a stack overflow.
  calib("deep.yaml", "model: " + std::string(100000, '[') + std::string(100000, ']') + "\n",
        {"malformed YAML"});
  calib("deep_open.yaml", "model: " + std::string(100000, '[') + "\n", {});
  calib("undefined_alias.yaml", Replace(kCalib, "cx: 249.5", "cx: *nowhere"), {"malformed YAML"});

  auto map = [&](const std::string& name, const std::string& text, std::initializer_list<std::string> frags) {
    const std::string p = Write(dir, name, text);
    ExpectError([&] { ReadMap(p); }, p, frags);
  };
  map("id.yaml", Replace(kMap, "id: door", "id: [a, b]"), {"rectangles[0].id", "string", "a list"});
  map("room.yaml", Replace(kMap, "room:\n  min: [0, 0]\n  max: [200, 200]\n  height: 120\n", "room: 5\n"),
      {"room", "mapping", "'5'"});
  map("rects.yaml", kMap.substr(0, kMap.find("rectangles:")) + "rectangles: door\n",
      {"rectangles", "list", "'door'"});
  map("rect_scalar.yaml", kMap.substr(0, kMap.find("rectangles:")) + "rectangles:\n  - door\n",
      {"rectangles[0]", "mapping", "'door'"});
  map("from.yaml", Replace(kMap, "from: [0.0, 50.0]", "from: 3"), {"rectangles[0].from", "2 numbers", "'3'"});
  map("from_map.yaml", Replace(kMap, "from: [0.0, 50.0]", "from: {x: 0, y: 50}"),
      {"rectangles[0].from", "2 numbers", "a mapping"});
  map("nested.yaml", Replace(kMap, "from: [0.0, 50.0]", "from: [[0.0], 50.0]"),
      {"rectangles[0].from[0]", "number", "a list"});
  map("units.yaml", Replace(kMap, "units: cm", "units: {a: b}"), {"units", "string", "a mapping"});
  // Aliases that make a node contain itself: read as the wrong kind, never followed for ever.
  map("cycle.yaml", kMap.substr(0, kMap.find("rectangles:")) + "rectangles: &r [*r]\n",
      {"rectangles[0]", "mapping", "a list"});
  map("room_cycle.yaml", Replace(kMap, "room:\n  min: [0, 0]", "room: &r\n  min: *r"),
      {"room.min", "2 numbers", "a mapping"});

  auto targets = [&](const std::string& name, const std::string& text,
                     std::initializer_list<std::string> frags) {
    const std::string p = Write(dir, name, text);
    ExpectError([&] { ReadTargets(p); }, p, frags);
  };
  targets("board.yaml", kTargets.substr(0, kTargets.find("board:")) + "board: 5\nimages:\n  - file: a.png\n",
          {"board", "mapping"});
  targets("images.yaml", kTargets.substr(0, kTargets.find("images:")) + "images: a.png\n",
          {"images", "list"});
  targets("image_scalar.yaml", Replace(kTargets, "  - file: cal_000.png", "  - cal_000.png"),
          {"images[0]", "mapping", "'cal_000.png'"});
  targets("file.yaml", Replace(kTargets, "file: cal_000.png", "file: [a, b]"), {"images[0].file", "string"});
  targets("cols.yaml", Replace(kTargets, "cols: 9", "cols: {n: 9}"), {"board.cols", "integer", "a mapping"});
}

TEST_CASE("every yaml-cpp exception escaping a reader becomes pano::Error naming the file", "[bad_input]") {
  const YAML::Node scalar = YAML::Load("5");
  const YAML::Node list = YAML::Load("[1, 2]");
  ExpectError([&] { return GuardYaml("sub.yaml", [&] { return scalar["x"].as<int>(); }); }, "sub.yaml", {});
  ExpectError([&] { return GuardYaml("conv.yaml", [&] { return list.as<std::string>(); }); }, "conv.yaml",
              {"line 1"});
  ExpectError([&] { return GuardYaml("missing.yaml", [&] { return scalar["x"]["y"].as<double>(); }); },
              "missing.yaml", {});
  CHECK(GuardYaml("fine.yaml", [&] { return scalar.as<int>(); }) == 5);
}

TEST_CASE("absurd numbers: image and board sizes past their limits, huge integers", "[bad_input]") {
  const std::string dir = test::ScratchDir("io_bad_numbers");
  using Fragments = std::initializer_list<std::string>;
  auto calib = [&](const std::string& name, const std::string& text, Fragments frags) {
    const std::string p = Write(dir, name, text);
    ExpectError([&] { ReadCalibration(p); }, p, frags);
  };
  auto sized = [](const std::string& width, const std::string& height) {
    return Replace(Replace(kCalib, "image_width: 500", "image_width: " + width), "image_height: 500",
                   "image_height: " + height);
  };
  const std::string huge = sized("200000", "200000");
  calib("huge.yaml", huge, {"image_width", "1 to 32768", "200000"});
  const std::string many = sized("30000", "30000");
  calib("many.yaml", many, {"image_width/image_height", "30000 x 30000", "268435456 pixels"});
  calib("zero.yaml", Replace(kCalib, "image_height: 500", "image_height: 0"), {"image_height", "1 to 32768"});
  calib("long.yaml", Replace(kCalib, "image_width: 500", "image_width: 99999999999999999999999"),
        {"image_width", "integer"});
  calib("inf.yaml", Replace(kCalib, "cx: 249.5", "cx: 1e999"), {"cx", "number"});
  calib("dotinf.yaml", Replace(kCalib, "cy: 249.5", "cy: -.inf"), {"cy", "finite"});
  // The largest image within the limits reads.
  const std::string side = sized("32768", "8192");
  CHECK(ReadCalibration(Write(dir, "side.yaml", side)).sensor.image_width == 32768);

  const std::string p = Write(dir, "board.yaml", Replace(kTargets, "cols: 9", "cols: 100000"));
  ExpectError([&] { ReadTargets(p); }, p, {"board", "at most 1000", "100000 x 6"});
}

TEST_CASE("endless and oversized inputs given as YAML files", "[bad_input]") {
  const std::string dir = test::ScratchDir("io_bad_endless");
  {
    // A FIFO fed with comment lines for ever: read to the limit, then refused.
    std::string lines;
    for (int i = 0; i < 4096; ++i) lines += "# more and more\n";
    test::EndlessFifo fifo(dir + "/calib.yaml", kCalib, lines);
    ExpectError([&] { ReadCalibration(fifo.path()); }, fifo.path(), {"64 MiB"});
  }
  if (fs::is_character_file("/dev/zero"))
    ExpectError([&] { ReadMap("/dev/zero"); }, "/dev/zero", {"64 MiB"});
  if (fs::is_character_file("/dev/urandom"))
    ExpectError([&] { ReadTargets("/dev/urandom"); }, "/dev/urandom", {"64 MiB"});
  // A regular file over the limit is refused by its size, before reading.
  const std::string big = dir + "/big.yaml";
  {
    std::ofstream out(big);
    out << kMap;
  }
  fs::resize_file(big, kMaxYamlBytes + 1);
  ExpectError([&] { ReadMap(big); }, big, {"too large", "64 MiB"});
  // Within the byte limit but past the node limit (yaml-cpp needs ~500 bytes a node).
  std::string nodes = kCalib + "k1_std: [";
  nodes.reserve(2 * kMaxYamlNodes + 100);
  for (size_t i = 0; i < kMaxYamlNodes; ++i) nodes += "1,";
  nodes += "1]\n";
  const std::string p = Write(dir, "nodes.yaml", nodes);
  ExpectError([&] { ReadCalibration(p); }, p, {"more than 1000000 YAML nodes"});
}

}  // namespace
}  // namespace pano

// Readers and writers of every file format: round trips, and each bad
// case rejected with a message naming the file, the key or line, and what was
// expected.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <random>
#include <filesystem>
#include <fstream>

#include "expect_error.h"
#include "panotrack/core/angles.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/io/targets.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::ExpectError;

std::string Write(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string p = dir + "/" + name;
  std::ofstream(p) << text;
  return p;
}

const char* kCalib = R"(model: sphere
units: cm
image_width: 500
image_height: 500
focal_px: 590.0
cx: 249.5
cy: 249.5
aspect: 1.0
mirror_radius: 4.9
mirror_distance: 15.1
lut: sensor.lut
some_future_key: 3
)";

TEST_CASE("calibration: read, write, read back; bad files", "[calibration]") {
  const std::string dir = test::ScratchDir("io_calib");
  const std::string p = Write(dir, "c.yaml", kCalib);
  const Calibration c = ReadCalibration(p);
  CHECK(c.sensor.model == MirrorModel::kSphere);
  CHECK(c.sensor.mirror_radius() == 4.9);
  CHECK(c.sensor.mirror_distance() == Approx(15.1).epsilon(1e-15));
  CHECK(c.sensor.params.azimuth_offset == 0.0);
  CHECK(c.lut_resolved == dir + "/sensor.lut");
  CHECK(c.extras.at("some_future_key") == 3.0);
  Calibration c2 = c;
  c2.sensor.params.azimuth_offset = 0.25;
  c2.extras["focal_px_std"] = 0.125;
  WriteCalibration(dir + "/out.yaml", c2);
  const Calibration c3 = ReadCalibration(dir + "/out.yaml");
  CHECK(c3.sensor.params.focal_px == c2.sensor.params.focal_px);
  CHECK(c3.sensor.params.azimuth_offset == 0.25);
  CHECK(c3.sensor.mirror_distance() == Approx(15.1).epsilon(1e-15));
  CHECK(c3.extras.at("focal_px_std") == 0.125);
  // The paper sensors in calib/ read.
  CHECK(ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor.image_width == 640);
  CHECK(ReadCalibration(test::SourcePath("calib/paper-synthetic.yaml")).sensor.image_width == 500);

  auto bad = [&](const std::string& name, const std::string& text,
                 std::initializer_list<std::string> frags) {
    const std::string path = Write(dir, name, text);
    ExpectError([&] { ReadCalibration(path); }, path, frags);
  };
  std::string s = kCalib;
  bad("missing.yaml", s.substr(s.find("units")), {"model", "missing"});
  bad("model.yaml", "model: paraboloid\n" + s.substr(s.find("units")), {"model", "paraboloid"});
  std::string nan = s;
  nan.replace(nan.find("590.0"), 5, ".nan");
  bad("nan.yaml", nan, {"focal_px", "finite"});
  std::string word = s;
  word.replace(word.find("590.0"), 5, "big");
  bad("word.yaml", word, {"focal_px", "number", "big"});
  std::string inside = s;
  inside.replace(inside.find("15.1"), 4, "4.0");
  bad("inside.yaml", inside, {"mirror_distance", "mirror_radius"});
  std::string negf = s;
  negf.replace(negf.find("590.0"), 5, "-590");
  bad("negf.yaml", negf, {"focal_px", "positive"});
  bad("syntax.yaml", "model: [sphere\nunits: cm\n", {"malformed YAML", "line"});
  bad("list.yaml", "- 1\n- 2\n", {"mapping"});
  ExpectError([&] { ReadCalibration(dir + "/absent.yaml"); }, dir + "/absent.yaml", {"cannot open"});
}

const char* kMap = R"(units: cm
sensor_height: 30.0
room:
  min: [0, 0]
  max: [200, 200]
  height: 120
  wall_shade: 0.55
  floor_shade: 0.35
  ceiling_shade: 0.8
rectangles:
  - id: door
    from: [0.0, 50.0]
    to:   [0.0, 90.0]
    z: [0.0, 100.0]
    shade: 0.1
boxes:
  - id: crate
    min: [120, 40, 0]
    max: [150, 70, 45]
    shade: 0.9
)";

TEST_CASE("map: read, write, read back; bad files", "[map]") {
  const std::string dir = test::ScratchDir("io_map");
  const Map m = ReadMap(Write(dir, "m.yaml", kMap));
  REQUIRE(m.rectangles.size() == 1);
  REQUIRE(m.boxes.size() == 1);
  CHECK(m.rectangles[0].id == "door");
  CHECK(m.rectangles[0].to.y() == 90.0);
  CHECK(m.boxes[0].max.z() == 45.0);
  CHECK(m.room.ceiling_shade == 0.8);
  CHECK(m.IsFree(100, 100));
  CHECK_FALSE(m.IsFree(130, 50));   // inside the crate
  CHECK_FALSE(m.IsFree(-5, 100));   // outside the room
  Map with = m;
  with.distractors.push_back({"poster", {200, 20}, {200, 60}, 40, 80, 0.9});
  WriteMap(dir + "/out.yaml", with, /*with_distractors=*/false);
  const Map back = ReadMap(dir + "/out.yaml");
  CHECK(back.distractors.empty());
  CHECK(back.rectangles[0].from == m.rectangles[0].from);
  CHECK(back.boxes[0].min == m.boxes[0].min);
  WriteMap(dir + "/with.yaml", with, true);
  CHECK(ReadMap(dir + "/with.yaml").distractors.size() == 1);

  auto bad = [&](const std::string& name, std::string text, const std::string& from,
                 const std::string& to, std::initializer_list<std::string> frags) {
    if (!from.empty()) text.replace(text.find(from), from.size(), to);
    const std::string path = Write(dir, name, text);
    ExpectError([&] { ReadMap(path); }, path, frags);
  };
  bad("z.yaml", kMap, "z: [0.0, 100.0]", "z: [100.0, 0.0]", {"rectangles[0].z", "top > bottom"});
  bad("from.yaml", kMap, "from: [0.0, 50.0]", "from: [0.0]", {"rectangles[0].from", "2 numbers"});
  bad("shade.yaml", kMap, "shade: 0.1", "shade: 1.7", {"rectangles[0].shade", "0 and 1"});
  bad("box.yaml", kMap, "max: [150, 70, 45]", "max: [110, 70, 45]", {"boxes[0]", "max > min"});
  bad("dup.yaml", kMap, "id: crate", "id: door", {"duplicate id", "door"});
  bad("height.yaml", kMap, "sensor_height: 30.0", "sensor_height: -3", {"sensor_height"});
  bad("nosh.yaml", kMap, "sensor_height: 30.0\n", "", {"sensor_height", "missing"});
  bad("ceiling.yaml", kMap, "height: 120", "height: 20", {"room.height"});
  bad("empty.yaml", "units: cm\nsensor_height: 30\n", "", "", {"no rectangles"});
}

TEST_CASE("map: a landmark's shade is optional (unknown), written back only when known", "[map_shade]") {
  const std::string dir = test::ScratchDir("io_map_shade");
  std::string text = kMap;
  for (const std::string key : {"    shade: 0.1\n", "    shade: 0.9\n"}) text.erase(text.find(key), key.size());
  REQUIRE(text.find("  shade:") == std::string::npos);
  const Map m = ReadMap(Write(dir, "m.yaml", text));
  REQUIRE(m.rectangles.size() == 1);
  REQUIRE(m.boxes.size() == 1);
  CHECK_FALSE(m.rectangles[0].shade_known());
  CHECK(std::isnan(m.rectangles[0].shade));
  CHECK_FALSE(m.boxes[0].shade_known());
  CHECK(m.room.wall_shade == 0.55);  // the room's shades keep their defaults
  const std::string yaml = MapToYaml(m, false);
  CHECK(yaml.find("  shade:") == std::string::npos);
  WriteMap(dir + "/out.yaml", m, false);
  const Map back = ReadMap(dir + "/out.yaml");
  CHECK_FALSE(back.rectangles[0].shade_known());
  CHECK_FALSE(back.boxes[0].shade_known());
  CHECK(back.rectangles[0].from == m.rectangles[0].from);
  CHECK(MapToYaml(back, false) == yaml);
  // One known, one unknown: each written as it is.
  Map mixed = m;
  mixed.boxes[0].shade = 0.25;
  const Map mixed_back = ReadMap(Write(dir, "mixed.yaml", MapToYaml(mixed, false)));
  CHECK_FALSE(mixed_back.rectangles[0].shade_known());
  CHECK(mixed_back.boxes[0].shade == 0.25);
  // A distractor (only rendered) without a shade keeps the default.
  const Map d = ReadMap(Write(dir, "d.yaml", text + "distractors:\n  - id: panel\n    from: [10, 199]\n"
                                                   "    to: [40, 199]\n    z: [20, 60]\n"));
  REQUIRE(d.distractors.size() == 1);
  CHECK(d.distractors[0].shade == MapRectangle().shade);
}

TEST_CASE("pose CSV: a row's text is printf's (%.6f, %.4f, %.6g), whatever the values", "[pose_csv]") {
  // The formatting as printf writes it, the reference.
  auto printf_row = [](const PoseRow& r) {
    char buf[1024];
    if (r.status == PoseStatus::kLost)
      std::snprintf(buf, sizeof buf, "%d,%.6f,,,,%s,%d,", r.frame, r.time_s, PoseStatusName(r.status),
                    r.n_landmarks);
    else
      std::snprintf(buf, sizeof buf, "%d,%.6f,%.4f,%.4f,%.6f,%s,%d,%.4f", r.frame, r.time_s, r.pose.x, r.pose.y,
                    WrapAngle(r.pose.theta), PoseStatusName(r.status), r.n_landmarks, r.residual);
    std::string s = buf;
    for (double e : r.extra) {
      s += ',';
      if (std::isfinite(e)) {
        std::snprintf(buf, sizeof buf, "%.6g", e);
        s += buf;
      }
    }
    return s;
  };
  std::mt19937 rng(20261130);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-12, 12);
  auto value = [&] {
    const double m = mantissa(rng);  // (one draw per statement: operand order is the compiler's choice)
    return m * std::pow(10.0, exponent(rng));
  };
  const std::vector<double> special = {0.0,    -0.0,    0.00005, -0.00005, 0.000049999, 1e-300, -1e300,
                                       1e308,  123.45675, 2.5e-7, 999999.5, 0.12345650, std::nan(""),
                                       HUGE_VAL, -HUGE_VAL};
  for (int k = 0; k < 3000; ++k) {
    PoseRow r;
    r.frame = k * 7919 % 100003;
    const bool pick_special = k % 3 == 0;
    auto next = [&](size_t i) { return pick_special ? special[(k + i) % special.size()] : value(); };
    r.time_s = std::abs(next(0));
    r.pose = {next(1), next(2), next(3)};
    r.status = k % 5 == 0 ? PoseStatus::kLost : k % 5 == 1 ? PoseStatus::kInit : PoseStatus::kOk;
    r.n_landmarks = k % 40;
    r.residual = std::abs(next(4));
    r.extra = {next(5), next(6), next(7), next(8)};
    const std::string want = printf_row(r), got = FormatPoseRow(r);
    INFO("row " << k);
    REQUIRE(got == want);
  }
}

TEST_CASE("pose CSV: rows written and flushed one by one, read back; bad files", "[pose_csv]") {
  const std::string dir = test::ScratchDir("io_pose");
  const std::string p = dir + "/poses.csv";
  {
    PoseCsvWriter w(p, {"cov_xx"});
    PoseRow r;
    r.frame = 0;
    r.pose = {100.0, 50.0, 0.785398};
    r.status = PoseStatus::kInit;
    r.n_landmarks = 0;
    w.Write(r);
    r.frame = 1;
    r.time_s = 0.1;
    r.status = PoseStatus::kOk;
    r.n_landmarks = 7;
    r.residual = 0.31;
    r.extra = {0.02};
    w.Write(r);
    // Flushed: the rows are on disk before the writer closes.
    std::ifstream in(p);
    std::string all((std::istreambuf_iterator<char>(in)), {});
    CHECK(all == "frame,time_s,x,y,theta_rad,status,n_landmarks,residual,cov_xx\n"
                 "0,0.000000,100.0000,50.0000,0.785398,init,0,0.0000,\n"
                 "1,0.100000,100.0000,50.0000,0.785398,ok,7,0.3100,0.02\n");
    r.frame = 2;
    r.status = PoseStatus::kLost;
    r.n_landmarks = 1;
    w.Write(r);
  }
  const std::vector<PoseRow> rows = ReadPoseCsv(p);
  REQUIRE(rows.size() == 3);
  CHECK(rows[1].pose.x == 100.0);
  CHECK(rows[1].status == PoseStatus::kOk);
  CHECK(rows[1].n_landmarks == 7);
  CHECK(rows[1].residual == 0.31);
  REQUIRE(rows[1].extra.size() == 1);
  CHECK(rows[1].extra[0] == 0.02);
  CHECK(rows[2].status == PoseStatus::kLost);

  const std::string hdr = "frame,time_s,x,y,theta_rad,status,n_landmarks,residual\n";
  auto bad = [&](const std::string& name, const std::string& text,
                 std::initializer_list<std::string> frags) {
    const std::string path = Write(dir, name, text);
    ExpectError([&] { ReadPoseCsv(path); }, path, frags);
  };
  bad("hdr.csv", "frame,x,y\n1,2,3\n", {"line 1", "header"});
  bad("empty.csv", "", {"empty"});
  bad("cols.csv", hdr + "0,0.0,1,2,3,ok,4\n", {"line 2", "8 columns"});
  bad("num.csv", hdr + "0,0.0,1,abc,3,ok,4,0.1\n", {"line 2", "column y", "abc"});
  bad("status.csv", hdr + "0,0.0,1,2,3,fine,4,0.1\n", {"line 2", "status", "fine"});
  bad("lost.csv", hdr + "0,0.0,1,2,3,lost,4,\n", {"line 2", "lost", "empty"});
  bad("order.csv", hdr + "1,0.0,1,2,3,ok,4,0.1\n0,0.1,1,2,3,ok,4,0.1\n", {"line 3", "increase"});
  bad("nan.csv", hdr + "0,0.0,nan,2,3,ok,4,0.1\n", {"line 2", "finite"});
}

TEST_CASE("calibration targets: read, write, read back; bad files", "[targets]") {
  const std::string dir = test::ScratchDir("io_targets");
  const std::string text = R"(units: cm
board:
  type: chessboard
  cols: 9
  rows: 6
  square: 3.0
images:
  - file: cal_000.png
    rvec: [0.1, -1.2, 0.3]
    tvec: [40.0, 0.0, 5.0]
  - file: cal_001.png
    rvec: [0.2, -1.2, 0.3]
    tvec: [0.0, 40.0, 5.0]
)";
  const TargetSet t = ReadTargets(Write(dir, "t.yaml", text));
  REQUIRE(t.images.size() == 2);
  CHECK(t.AllPosesKnown());
  CHECK(t.board.cols == 9);
  CHECK(t.images[0].resolved == dir + "/cal_000.png");
  CHECK(t.images[1].tvec[1] == 40.0);
  WriteTargets(dir + "/unknown.yaml", t, false);
  const TargetSet u = ReadTargets(dir + "/unknown.yaml");
  CHECK_FALSE(u.AllPosesKnown());
  CHECK(u.images[1].file == "cal_001.png");
  // The real data set's target file reads.
  const std::string real = test::SourcePath("../shared/data/real/miniomni/targets.yaml");
  if (std::filesystem::exists(real)) {
    const TargetSet r = ReadTargets(real);
    CHECK(r.images.size() == 15);
    CHECK(r.board.cols == 7);
    CHECK(r.units == "mm");
  }
  auto bad = [&](const std::string& name, std::string body, const std::string& from,
                 const std::string& to, std::initializer_list<std::string> frags) {
    if (!from.empty()) body.replace(body.find(from), from.size(), to);
    const std::string path = Write(dir, name, body);
    ExpectError([&] { ReadTargets(path); }, path, frags);
  };
  bad("type.yaml", text, "type: chessboard", "type: hexagon", {"board.type", "hexagon"});
  bad("cols.yaml", text, "cols: 9", "cols: 1", {"board", "2 x 2"});
  bad("half.yaml", text, "    tvec: [40.0, 0.0, 5.0]\n", "", {"images[0]", "both rvec and tvec"});
  bad("rvec.yaml", text, "rvec: [0.1, -1.2, 0.3]", "rvec: [0.1, -1.2]", {"images[0].rvec", "3 numbers"});
  bad("noimg.yaml", text.substr(0, text.find("images:")), "", "", {"images", "missing"});
}

TEST_CASE("atomic files never leave a half-written file behind", "[atomic]") {
  const std::string dir = test::ScratchDir("io_atomic");
  const std::string p = dir + "/out.txt";
  {
    AtomicFile f(p);
    f.Write("partial");
    // destroyed without Commit(): as if an error happened mid-way
  }
  CHECK_FALSE(std::filesystem::exists(p));
  CHECK(std::distance(std::filesystem::directory_iterator(dir), {}) == 0);
  WriteFileAtomic(p, "whole");
  CHECK(ReadFile(p) == "whole");
  CHECK_THROWS_AS(WriteFileAtomic(dir + "/no/such/dir/x.txt", "x"), Error);
}

}  // namespace
}  // namespace pano

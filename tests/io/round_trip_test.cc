// Writers against strings that YAML would misread and numbers at the edges
// of double precision: whatever is written reads back field by field,
// bit for bit, and writing it again gives the same text.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/targets.h"
#include "panotrack/io/yaml_util.h"
#include "panotrack/sensor/catadioptric.h"
#include "test_paths.h"
#include "test_rng.h"

namespace pano {
namespace {

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

#define CHECK_SAME(a, b)                             \
  do {                                               \
    INFO(#a " = " << YamlDouble(a) << ", " #b " = " << YamlDouble(b)); \
    CHECK(SameBits((a), (b)));                       \
  } while (0)

// Strings and numbers chosen to trip a YAML writer.
class Nasty {
 public:
  explicit Nasty(std::mt19937_64& rng) : rng_(rng) {}

  std::string String() {
    static const char* const kPieces[] = {
        ": ", "#", " #", "# ", "'", "\"", "- ", "-", " ", "  ", "{", "}", "[", "]", "{}", "[]", "&", "*",
        "!", "|", ">", "%", "@", "`", ",", "?", "\\", "\t", "\n", "\r\n", "\x01", "\x7f", "\xc3\xa9",
        "\xe6\x97\xa5\xe6\x9c\xac", "\xf0\x9f\x99\x82", "\xc2\x85", "\xe2\x80\xa8", "\xc2\xa0",
        "\xef\xbb\xbf",
        "yes", "no", "Yes", "NO", "on", "off", "y", "n", "true", "False", "null", "Null", "~", "1e3", "-1",
        "0x1F", "0o17", ".inf", "-.inf", ".nan", "1_000", "12:30", "---", "...", "a", "door", "id", "x.png",
        "/", "..", "<<", "=", "&anchor", "*alias", "!!str", "%YAML"};
    constexpr size_t kCount = sizeof kPieces / sizeof kPieces[0];
    if (Chance(0.08)) return "";
    std::string s;
    const int n = 1 + static_cast<int>(rng_() % 5);
    for (int i = 0; i < n; ++i) s += kPieces[rng_() % kCount];
    return s;
  }

  // Any finite double, the edges included.
  double Any() {
    std::uniform_real_distribution<double> unit(1.0, 2.0);
    const double sign = Chance(0.5) ? -1.0 : 1.0;
    switch (rng_() % 8) {
      case 0: return 0.0;
      case 1: return -0.0;
      case 2: return std::uniform_real_distribution<double>(-1000.0, 1000.0)(rng_);
      case 3: return sign * std::ldexp(unit(rng_), -1074 + static_cast<int>(rng_() % 80));  // subnormal
      case 4: return sign * std::ldexp(unit(rng_), 900 + static_cast<int>(rng_() % 123));   // near the top
      case 5: {
        for (;;) {
          const uint64_t bits = rng_();
          double d;
          std::memcpy(&d, &bits, sizeof d);
          if (std::isfinite(d)) return d;
        }
      }
      case 6: return static_cast<double>(static_cast<int64_t>(rng_() % 2000001) - 1000000);
      default: return sign * unit(rng_) * std::pow(10.0, static_cast<int>(rng_() % 41) - 20);
    }
  }
  double Positive() {
    for (;;) {
      const double d = std::abs(Any());
      if (d > 0.0) return d;
    }
  }
  // A map coordinate: the edge cases of Any() within the +-1e6 map units
  // that maps accept.
  double Coordinate() {
    for (;;) {
      const double d = Any();
      if (std::abs(d) < 1e6) return d;
    }
  }
  double PositiveCoordinate() {
    for (;;) {
      const double d = std::abs(Coordinate());
      if (d > 0.0) return d;
    }
  }
  double Shade() {
    switch (rng_() % 5) {
      case 0: return 0.0;
      case 1: return 1.0;
      case 2: return -0.0;
      case 3: return std::ldexp(1.0, -1074);
      default: return std::uniform_real_distribution<double>(0.0, 1.0)(rng_);
    }
  }
  bool Chance(double p) { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < p; }
  int Int(int lo, int hi) { return lo + static_cast<int>(rng_() % static_cast<uint64_t>(hi - lo + 1)); }
  std::string UniqueId(std::set<std::string>* used) {
    for (;;) {
      std::string id = String();
      if (used->insert(id).second) return id;
    }
  }

 private:
  std::mt19937_64& rng_;
};

MapRectangle RandomRectangle(Nasty& g, std::set<std::string>* ids) {
  MapRectangle r;
  r.id = g.UniqueId(ids);
  do {
    r.from = {g.Coordinate(), g.Coordinate()};
    r.to = {g.Coordinate(), g.Coordinate()};
  } while (!((r.to - r.from).norm() > 0.0));
  do {
    r.z0 = g.Coordinate();
    r.z1 = g.Coordinate();
  } while (!(r.z1 > r.z0));
  r.shade = g.Shade();
  return r;
}

Map RandomMap(Nasty& g) {
  Map m;
  m.units = g.String();
  m.sensor_height = g.PositiveCoordinate();
  if (g.Chance(0.7)) {
    m.room.present = true;
    do {
      m.room.min = {g.Coordinate(), g.Coordinate()};
      m.room.max = {g.Coordinate(), g.Coordinate()};
    } while (!(m.room.max.x() > m.room.min.x() && m.room.max.y() > m.room.min.y()));
    do m.room.height = g.PositiveCoordinate();
    while (!(m.room.height > m.sensor_height));
    m.room.wall_shade = g.Shade();
    m.room.floor_shade = g.Shade();
    m.room.ceiling_shade = g.Shade();
  }
  std::set<std::string> ids;
  const int n_rect = g.Int(0, 4), n_box = n_rect == 0 ? g.Int(1, 3) : g.Int(0, 3);
  for (int i = 0; i < n_rect; ++i) m.rectangles.push_back(RandomRectangle(g, &ids));
  for (int i = 0; i < n_box; ++i) {
    MapBox b;
    b.id = g.UniqueId(&ids);
    do {
      b.min = {g.Coordinate(), g.Coordinate(), g.Coordinate()};
      b.max = {g.Coordinate(), g.Coordinate(), g.Coordinate()};
    } while (!(b.max.array() > b.min.array()).all());
    b.shade = g.Shade();
    m.boxes.push_back(b);
  }
  for (int i = g.Int(0, 2); i > 0; --i) m.distractors.push_back(RandomRectangle(g, &ids));
  return m;
}

void CheckSameRectangles(const std::vector<MapRectangle>& a, const std::vector<MapRectangle>& b) {
  REQUIRE(a.size() == b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    CHECK(a[i].id == b[i].id);
    CHECK_SAME(a[i].from.x(), b[i].from.x());
    CHECK_SAME(a[i].from.y(), b[i].from.y());
    CHECK_SAME(a[i].to.x(), b[i].to.x());
    CHECK_SAME(a[i].to.y(), b[i].to.y());
    CHECK_SAME(a[i].z0, b[i].z0);
    CHECK_SAME(a[i].z1, b[i].z1);
    CHECK_SAME(a[i].shade, b[i].shade);
  }
}

TEST_CASE("random maps with nasty ids and edge-case numbers round-trip exactly", "[fuzz]") {
  PANO_SEEDED_RNG(20261129);
  Nasty g(rng);
  const std::string dir = test::ScratchDir("io_fuzz_map");
  const std::string path = dir + "/map.yaml";
  for (int iter = 0; iter < 300; ++iter) {
    INFO("map " << iter);
    const Map m = RandomMap(g);
    REQUIRE_NOTHROW(CheckMap(m, "random map"));
    const bool with_distractors = g.Chance(0.5);
    WriteMap(path, m, with_distractors);
    const std::string text = ReadFile(path);
    INFO("file:\n" << text);
    CHECK(text == MapToYaml(m, with_distractors));
    const Map back = ReadMap(path);
    CHECK(back.units == m.units);
    CHECK_SAME(back.sensor_height, m.sensor_height);
    REQUIRE(back.room.present == m.room.present);
    if (m.room.present) {
      CHECK_SAME(back.room.min.x(), m.room.min.x());
      CHECK_SAME(back.room.min.y(), m.room.min.y());
      CHECK_SAME(back.room.max.x(), m.room.max.x());
      CHECK_SAME(back.room.max.y(), m.room.max.y());
      CHECK_SAME(back.room.height, m.room.height);
      CHECK_SAME(back.room.wall_shade, m.room.wall_shade);
      CHECK_SAME(back.room.floor_shade, m.room.floor_shade);
      CHECK_SAME(back.room.ceiling_shade, m.room.ceiling_shade);
    }
    CheckSameRectangles(back.rectangles, m.rectangles);
    REQUIRE(back.boxes.size() == m.boxes.size());
    for (size_t i = 0; i < m.boxes.size(); ++i) {
      CHECK(back.boxes[i].id == m.boxes[i].id);
      for (int k = 0; k < 3; ++k) {
        CHECK_SAME(back.boxes[i].min[k], m.boxes[i].min[k]);
        CHECK_SAME(back.boxes[i].max[k], m.boxes[i].max[k]);
      }
      CHECK_SAME(back.boxes[i].shade, m.boxes[i].shade);
    }
    CheckSameRectangles(back.distractors, with_distractors ? m.distractors : std::vector<MapRectangle>{});
    CHECK(MapToYaml(back, with_distractors) == text);
    // Numbers stay plain YAML numbers, never quoted strings.
    CHECK(YAML::Load(text)["sensor_height"].Tag() == "?");
  }
}

TEST_CASE("strings that YAML would misread are quoted; numbers stay plain", "[quoting]") {
  const std::string dir = test::ScratchDir("io_quoting");
  Map m;
  m.sensor_height = 30.0;
  m.units = "cm # centimetres";
  const char* ids[] = {"door: left", "# 2", "- dash", "'single'", "\"double\"", "{x}", "[y]", "yes", "~",
                       "null", "1e3", " padded ", "", "a\nb", "&a *b !c |d >e %f @g `h"};
  double x = 0.0;
  for (const char* id : ids) {
    m.rectangles.push_back({id, {x, 0.0}, {x + 10.0, 0.0}, 0.0, 50.0, 0.5});
    x += 20.0;
  }
  const std::string map_path = dir + "/map.yaml";
  WriteMap(map_path, m);
  const Map back = ReadMap(map_path);
  CHECK(back.units == m.units);
  REQUIRE(back.rectangles.size() == m.rectangles.size());
  for (size_t i = 0; i < m.rectangles.size(); ++i) CHECK(back.rectangles[i].id == m.rectangles[i].id);
  const std::string map_text = ReadFile(map_path);
  INFO(map_text);
  CHECK(map_text.find("sensor_height: 30.0\n") != std::string::npos);
  CHECK(map_text.find("  - id: \"door: left\"\n    from: [0.0, 0.0]\n") != std::string::npos);
  CHECK(map_text.find("id: \"yes\"") != std::string::npos);

  Calibration c;
  c.sensor.image_width = c.sensor.image_height = 500;
  c.sensor.params.focal_px = 590.0;
  c.sensor.params.cx = c.sensor.params.cy = 249.5;
  SetSphereMirror(&c.sensor.params, 4.9, 15.1);
  c.units = "mm: really";
  c.lut = "tables/sensor #1.lut";
  c.extras["rms: px"] = 0.25;
  // A comment whose carriage return or NEL would end the comment line for some readers.
  c.comment = "fitted by hand\rmodel: conic\nsecond line\xc2\x85units: km";
  const std::string calib_path = dir + "/calib.yaml";
  WriteCalibration(calib_path, c);
  const std::string calib_text = ReadFile(calib_path);
  INFO(calib_text);
  CHECK(calib_text.rfind("# fitted by hand model: conic\n# second line units: km\nmodel: sphere\n", 0) == 0);
  CHECK(calib_text.find("focal_px: 590.0\n") != std::string::npos);
  CHECK(calib_text.find("image_width: 500\n") != std::string::npos);
  CHECK(calib_text.find("mirror_distance: 15.1\n") != std::string::npos);
  const Calibration cb = ReadCalibration(calib_path);
  CHECK(cb.sensor.model == MirrorModel::kSphere);
  CHECK(cb.units == "mm: really");
  CHECK(cb.lut_resolved == dir + "/tables/sensor #1.lut");
  CHECK(cb.extras.at("rms: px") == 0.25);
  // An extra key may not repeat one of the calibration's own.
  c.extras["focal_px"] = 1.0;
  CHECK_THROWS_WITH(WriteCalibration(calib_path, c),
                    Catch::Contains(calib_path) && Catch::Contains("focal_px"));

  TargetSet t;
  t.board.cols = 9;
  t.board.rows = 6;
  t.board.square = 3.0;
  t.images.push_back({"cal 000: left.png", "", true, {0.1, -1.2, 0.3}, {40.0, 0.0, 5.0}});
  t.images.push_back({"#1.png", "", false, {}, {}});
  const std::string targets_path = dir + "/targets.yaml";
  WriteTargets(targets_path, t);
  const TargetSet tb = ReadTargets(targets_path);
  REQUIRE(tb.images.size() == 2);
  CHECK(tb.images[0].file == "cal 000: left.png");
  CHECK(tb.images[0].tvec[0] == 40.0);
  CHECK(tb.images[1].file == "#1.png");
  CHECK(tb.images[1].resolved == dir + "/#1.png");
}

TEST_CASE("doubles are written in the shortest text that reads back exactly", "[quoting]") {
  CHECK(YamlDouble(590.0) == "590.0");
  CHECK(YamlDouble(0.1) == "0.1");
  CHECK(YamlDouble(-0.0) == "-0.0");
  CHECK(YamlDouble(1e-300) == "1.0e-300");
  CHECK(YamlDouble(-2e20) == "-2.0e+20");
  CHECK(YamlDouble(0.1 + 0.2) == "0.30000000000000004");
  CHECK(YamlDouble(std::ldexp(1.0, -1074)) == "4.94066e-324");
  CHECK(YamlDouble(1.0 / 0.0) == ".inf");
  CHECK(YamlDouble(-1.0 / 0.0) == "-.inf");
  CHECK(YamlDouble(std::nan("")) == ".nan");
}

Calibration RandomCalibration(Nasty& g) {
  for (;;) {
    Calibration c;
    Sensor& s = c.sensor;
    s.model = g.Chance(0.5) ? MirrorModel::kSphere : MirrorModel::kConic;
    s.image_width = g.Int(1, kMaxImageSide);
    const long long max_height = std::min<long long>(kMaxImageSide, kMaxImagePixels / s.image_width);
    s.image_height = g.Int(1, static_cast<int>(max_height));
    SensorParams<double>& p = s.params;
    p.focal_px = g.Positive();
    p.cx = g.Any();
    p.cy = g.Any();
    p.aspect = g.Positive();
    p.azimuth_offset = g.Any();
    // Zero-valued optional keys are left out of the file and read back as +0.
    p.k1 = g.Chance(0.3) ? 0.0 : g.Any();
    p.k2 = g.Chance(0.3) ? 0.0 : g.Any();
    if (p.k1 == 0.0 && p.k2 == 0.0) p.k1 = p.k2 = 0.0;
    p.rim_radius = g.Chance(0.5) ? 0.0 : g.Positive();
    if (s.model == MirrorModel::kSphere) {
      // As the reader stores a sphere: from mirror_radius and mirror_distance.
      const double radius = g.Positive();
      const double distance = radius + g.Positive();
      if (!(distance > radius)) continue;
      SetSphereMirror(&p, radius, distance);
    } else {
      p.curvature_radius = g.Positive();
      p.conic_constant = g.Any();
      p.vertex_distance = g.Positive();
    }
    try {
      s.Check("random calibration");
    } catch (const Error&) {
      continue;
    }
    c.units = g.String();
    if (g.Chance(0.7)) c.lut = g.String();
    for (int i = g.Int(0, 3); i > 0; --i) {
      std::string key = g.String();
      if (key == "model" || key == "units" || key == "lut") continue;
      c.extras[key] = g.Any();
    }
    if (g.Chance(0.5)) c.comment = g.String() + "\n" + g.String();
    return c;
  }
}

TEST_CASE("random calibrations with nasty strings and edge-case numbers round-trip exactly", "[fuzz]") {
  PANO_SEEDED_RNG(1129);
  Nasty g(rng);
  const std::string dir = test::ScratchDir("io_fuzz_calib");
  const std::string path = dir + "/calib.yaml";
  for (int iter = 0; iter < 300; ++iter) {
    INFO("calibration " << iter);
    const Calibration c = RandomCalibration(g);
    WriteCalibration(path, c);
    const std::string text = ReadFile(path);
    INFO("file:\n" << text);
    CHECK(text == CalibrationToYaml(c));
    Calibration back = ReadCalibration(path);
    CHECK(back.sensor.model == c.sensor.model);
    CHECK(back.sensor.image_width == c.sensor.image_width);
    CHECK(back.sensor.image_height == c.sensor.image_height);
    const SensorParams<double>&p = c.sensor.params, &q = back.sensor.params;
    CHECK_SAME(q.focal_px, p.focal_px);
    CHECK_SAME(q.cx, p.cx);
    CHECK_SAME(q.cy, p.cy);
    CHECK_SAME(q.aspect, p.aspect);
    CHECK_SAME(q.azimuth_offset, p.azimuth_offset);
    CHECK_SAME(q.k1, p.k1);
    CHECK_SAME(q.k2, p.k2);
    CHECK_SAME(q.curvature_radius, p.curvature_radius);
    CHECK_SAME(q.conic_constant, p.conic_constant);
    CHECK_SAME(q.vertex_distance, p.vertex_distance);
    CHECK_SAME(q.rim_radius, p.rim_radius);
    CHECK(back.units == c.units);
    CHECK(back.lut == c.lut);
    CHECK(back.lut_resolved == (c.lut.empty() ? "" : JoinPath(dir, c.lut)));
    REQUIRE(back.extras.size() == c.extras.size());
    for (const auto& kv : c.extras) {
      INFO("extra key '" << kv.first << "'");
      REQUIRE(back.extras.count(kv.first) == 1);
      CHECK_SAME(back.extras.at(kv.first), kv.second);
    }
    back.comment = c.comment;  // comments are written, not read
    CHECK(CalibrationToYaml(back) == text);
    CHECK(YAML::Load(text)["focal_px"].Tag() == "?");
  }
}

TEST_CASE("random target sets with nasty file names round-trip exactly", "[fuzz]") {
  PANO_SEEDED_RNG(29);
  Nasty g(rng);
  const std::string dir = test::ScratchDir("io_fuzz_targets");
  const std::string path = dir + "/targets.yaml";
  for (int iter = 0; iter < 300; ++iter) {
    INFO("target set " << iter);
    TargetSet t;
    t.units = g.String();
    t.board.cols = g.Int(2, kMaxBoardCorners);
    t.board.rows = g.Int(2, kMaxBoardCorners);
    t.board.square = g.Positive();
    for (int i = g.Int(1, 4); i > 0; --i) {
      TargetImage im;
      // Names are unique in a target file (the calibration is keyed by them).
      auto taken = [&](const std::string& f) {
        for (const TargetImage& other : t.images)
          if (other.file == f) return true;
        return false;
      };
      do im.file = g.String();
      while (taken(im.file));
      im.has_pose = g.Chance(0.6);
      if (im.has_pose) im.rvec = {g.Any(), g.Any(), g.Any()}, im.tvec = {g.Any(), g.Any(), g.Any()};
      t.images.push_back(im);
    }
    const bool with_poses = g.Chance(0.7);
    WriteTargets(path, t, with_poses);
    const std::string text = ReadFile(path);
    INFO("file:\n" << text);
    CHECK(text == TargetsToYaml(t, with_poses));
    const TargetSet back = ReadTargets(path);
    CHECK(back.units == t.units);
    CHECK(back.board.type == t.board.type);
    CHECK(back.board.cols == t.board.cols);
    CHECK(back.board.rows == t.board.rows);
    CHECK_SAME(back.board.square, t.board.square);
    REQUIRE(back.images.size() == t.images.size());
    for (size_t i = 0; i < t.images.size(); ++i) {
      CHECK(back.images[i].file == t.images[i].file);
      CHECK(back.images[i].resolved == JoinPath(dir, t.images[i].file));
      REQUIRE(back.images[i].has_pose == (with_poses && t.images[i].has_pose));
      if (!back.images[i].has_pose) continue;
      for (int k = 0; k < 3; ++k) {
        CHECK_SAME(back.images[i].rvec[k], t.images[i].rvec[k]);
        CHECK_SAME(back.images[i].tvec[k], t.images[i].tvec[k]);
      }
    }
    CHECK(TargetsToYaml(back, with_poses) == text);
  }
}

}  // namespace
}  // namespace pano

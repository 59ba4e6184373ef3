// The E(D,Z) table against the exact model, its inverse, and its file format.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "panotrack/core/error.h"
#include "core/test_fifo.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/lut/radius_table.h"
#include "test_paths.h"
#include "test_rng.h"

namespace pano {
namespace {

Sensor PaperSensor() { return ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor; }
// A 200 x 200 cm room seen from a pinhole 30 cm above the floor, ceiling 120.
LutRanges RoomRanges() { return {10.0, 450.0, -30.0, 90.0}; }

const RadiusTable& PaperTable() {
  static const RadiusTable t = RadiusTable::Build(PaperSensor(), RoomRanges());
  return t;
}

TEST_CASE("bilinear E(D,Z) is within 0.02 px of the exact model between the nodes",
          "[interpolation]") {
  PANO_SEEDED_RNG(7);
  const RadiusTable& t = PaperTable();
  const Sensor& s = t.sensor();
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  double worst = 0.0;
  int tested = 0, missed = 0;
  const int nd = t.size().n_distance, ne = t.size().n_elevation;
  // Cell centres (the worst place for bilinear interpolation) and random
  // points inside cells, over the whole table.
  for (int k = 0; k < 200000; ++k) {
    const double fi = (k % 2 == 0) ? std::floor(uni(rng) * (nd - 1)) + 0.5 : uni(rng) * (nd - 1);
    const double fj = (k % 2 == 0) ? std::floor(uni(rng) * (ne - 1)) + 0.5 : uni(rng) * (ne - 1);
    const double D = std::exp(t.log_d_min() + fi * t.log_d_step());
    const double Z = D * std::tan(t.elev_min() + fj * t.elev_step());
    double exact;
    if (!s.image_radius(D, Z, &exact)) continue;
    double approx;
    if (!t.radius(D, Z, &approx)) {
      ++missed;  // next to the edge of the visible region: a node is not visible
      continue;
    }
    worst = std::max(worst, std::abs(approx - exact));
    ++tested;
  }
  INFO("tested " << tested << " points, " << missed << " next to the visibility edge");
  CHECK(tested > 100000);
  CHECK(missed < tested / 300);  // measured 206 of 183 701 at worst over 10 seeds
  CHECK(worst < 0.003);          // measured 0.00106 px at worst over 10 seeds
  WARN("E(D,Z) table: worst interpolation error " << worst << " px over " << tested << " points");
}

TEST_CASE("tabulated inverse D = E^-1(R, Z) round-trips through the exact model", "[inverse]") {
  PANO_SEEDED_RNG(11);
  const RadiusTable& t = PaperTable();
  const Sensor& s = t.sensor();
  std::uniform_real_distribution<double> d(15.0, 300.0), z(-29.0, 89.0);
  double worst_px = 0.0, worst_band_px = 0.0;
  int tested = 0, degenerate = 0;
  // Points at the height of the mirror itself project to (nearly) the
  // horizon circle whatever their distance (dR/dD -> 0): there E^-1 is
  // degenerate and the table may decline to answer. Anywhere else it must.
  const double band_lo = s.params.vertex_distance - 1.0;
  const double band_hi = s.mirror_distance() + s.mirror_radius() + 1.0;
  for (int k = 0; k < 50000; ++k) {
    const double D = d(rng), Z = z(rng);
    double R;
    // Skip grazing points imaged within 0.05 px of the limb, where a tiny
    // error in D moves the point off the mirror.
    if (!s.image_radius(D, Z, &R) || R > s.limb_radius() - 0.05) continue;
    double D_table;
    const bool in_band = Z > band_lo && Z < band_hi;
    if (!t.distance(R, Z, &D_table)) {
      INFO("D " << D << " Z " << Z << " R " << R);
      REQUIRE(in_band);
      ++degenerate;
      continue;
    }
    // Error expressed in pixels: where the tabulated D would be imaged.
    double R_back;
    INFO("D " << D << " Z " << Z << " R " << R << " D_table " << D_table);
    REQUIRE(s.image_radius(D_table, Z, &R_back));
    if (in_band) {
      worst_band_px = std::max(worst_band_px, std::abs(R_back - R));
    } else {
      worst_px = std::max(worst_px, std::abs(R_back - R));
      ++tested;
    }
  }
  CHECK(tested > 35000);
  CHECK(degenerate < tested / 800);  // measured 19 of about 44 000 at worst over 10 seeds
  CHECK(worst_px < 0.02);
  // In the band (R, Z) barely constrains D, for the table as for the sensor
  // itself, yet the answer stays within a fraction of a pixel (measured
  // 0.236 px at worst over 10 seeds).
  CHECK(worst_band_px < 0.6);
  WARN("inverse table: worst error " << worst_px << " px over " << tested
                                     << " points outside the mirror's height band, "
                                     << worst_band_px << " px inside it");
  // The exact closed-form inverse is exact.
  double D_exact, R;
  REQUIRE(s.image_radius(120.0, 25.0, &R));
  REQUIRE(s.inverse_image_radius(R, 25.0, &D_exact));
  CHECK(D_exact == Approx(120.0).epsilon(500 * std::numeric_limits<double>::epsilon()));
}

TEST_CASE("a table is the same built on one thread or on three", "[threads]") {
  const std::string dir = test::ScratchDir("lut_threads");
  LutSize small;
  small.n_distance = small.n_elevation = small.n_radius = small.n_height = 96;
  RadiusTable::Build(PaperSensor(), RoomRanges(), small, 1).Save(dir + "/one.lut");
  RadiusTable::Build(PaperSensor(), RoomRanges(), small, 3).Save(dir + "/three.lut");
  auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const std::string one = bytes(dir + "/one.lut");
  CHECK(one.size() > 4 * 96 * 96);
  CHECK(one == bytes(dir + "/three.lut"));
  CHECK_THROWS_WITH(RadiusTable::Build(PaperSensor(), RoomRanges(), small, -2),
                    Catch::Contains("num_threads: expected 0 (every core) or 1..1024, got -2"));
}

TEST_CASE("table files: round trip, corrupt, truncated and mismatched files", "[file_format]") {
  const std::string dir = test::ScratchDir("lut_file");
  const Sensor s = PaperSensor();
  LutSize small;
  small.n_distance = small.n_elevation = small.n_radius = 64;
  small.n_height = 32;
  const RadiusTable t = RadiusTable::Build(s, RoomRanges(), small);
  const std::string path = dir + "/sensor.lut";
  t.Save(path);
  REQUIRE(std::filesystem::exists(path));
  // No temporary file is left behind.
  int n_files = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) (void)e, ++n_files;
  CHECK(n_files == 1);

  const RadiusTable back = RadiusTable::Load(path, &s);
  double a, b;
  REQUIRE(t.radius(100.0, 10.0, &a));
  REQUIRE(back.radius(100.0, 10.0, &b));
  CHECK(a == b);
  CHECK(back.Matches(s));
  CHECK(back.Covers(RoomRanges()));

  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto write = [&](const std::string& name, const std::string& content) {
    std::ofstream out(dir + "/" + name, std::ios::binary);
    out << content;
    return dir + "/" + name;
  };
  auto expect_error = [](const std::string& p, const std::string& fragment, const Sensor* sensor) {
    try {
      RadiusTable::Load(p, sensor);
      FAIL("loading " << p << " should have failed");
    } catch (const Error& e) {
      const std::string msg = e.what();
      INFO(msg);
      CHECK(msg.find(p) != std::string::npos);
      CHECK(msg.find(fragment) != std::string::npos);
    }
  };
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x40;
  expect_error(write("flipped.lut", flipped), "checksum", nullptr);
  expect_error(write("truncated.lut", bytes.substr(0, bytes.size() - 100)), "truncated", nullptr);
  expect_error(write("tiny.lut", bytes.substr(0, 20)), "truncated", nullptr);
  std::string magic = bytes;
  magic[0] = 'X';
  expect_error(write("magic.lut", magic), "magic", nullptr);
  expect_error(dir + "/missing.lut", "cannot open", nullptr);
  Sensor other = s;
  other.params.focal_px += 1.0;
  expect_error(path, "other sensor parameters", &other);
}

TEST_CASE("table files that are folders, endless streams or lie about their size", "[bad_file]") {
  const std::string dir = test::ScratchDir("lut_bad_file");
  LutSize small;
  small.n_distance = small.n_elevation = small.n_radius = small.n_height = 16;
  const std::string path = dir + "/sensor.lut";
  RadiusTable::Build(PaperSensor(), RoomRanges(), small).Save(path);
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto expect_error = [](const std::string& p, std::initializer_list<std::string> fragments) {
    try {
      RadiusTable::Load(p);
      FAIL("loading " << p << " should have failed");
    } catch (const Error& e) {
      const std::string msg = e.what();
      INFO(msg);
      CHECK(msg.find(p) != std::string::npos);
      CHECK(msg.find('\n') == std::string::npos);
      for (const auto& f : fragments) CHECK(msg.find(f) != std::string::npos);
    }
  };
  // The header's layout: sizes at byte 144 (four int32), image size at 16.
  auto with_ints = [&](const std::string& name, size_t offset, std::initializer_list<int32_t> values) {
    std::string b = bytes;
    for (int32_t v : values) {
      std::memcpy(&b[offset], &v, sizeof v);
      offset += sizeof v;
    }
    std::ofstream(dir + "/" + name, std::ios::binary) << b;
    return dir + "/" + name;
  };
  std::filesystem::create_directories(dir + "/folder.lut");
  expect_error(dir + "/folder.lut", {"folder"});
  // Sizes beyond the limits, or within them but larger than the file: refused
  // from the header, before anything is allocated for them.
  expect_error(with_ints("huge.lut", 144, {100000, 100000, 100000, 100000}),
               {"table sizes", "100000 x 100000"});
  expect_error(with_ints("negative.lut", 144, {-5, 16, 16, 16}), {"table sizes"});
  expect_error(with_ints("large.lut", 144, {10000, 10000, 16, 16}),
               {"truncated or padded", "expected 400001192"});
  expect_error(with_ints("image.lut", 16, {200000, 200000}), {"image size", "200000 x 200000"});
  if (std::filesystem::is_character_file("/dev/zero")) expect_error("/dev/zero", {"bad magic"});
  if (std::filesystem::is_character_file("/dev/urandom")) expect_error("/dev/urandom", {"bad magic"});
  {
    // A whole valid table, then zeros without end: read as far as the header
    // declares, then refused.
    test::EndlessFifo fifo(dir + "/endless.lut", bytes, std::string(65536, '\0'));
    expect_error(fifo.path(), {"padded", std::to_string(bytes.size()) + " bytes"});
  }
}

TEST_CASE("ranges for a map cover the room seen from anywhere in it", "[ranges]") {
  Map m;
  m.sensor_height = 30.0;
  m.room.present = true;
  m.room.min = {0, 0};
  m.room.max = {200, 200};
  m.room.height = 120;
  m.rectangles.push_back({"door", {0, 50}, {0, 90}, 0, 100, 0.1});
  const Sensor s = PaperSensor();
  const LutRanges r = RangesForMap(m, s);
  CHECK(r.d_max >= std::hypot(200.0, 200.0));
  CHECK(r.z_min <= -30.0);
  CHECK(r.z_max >= 90.0);
  CHECK(r.d_min > 0.0);
  // A corner a hair below the floor (a measured or refined map): still covered.
  m.rectangles.push_back({"low", {200, 50}, {200, 90}, -0.5, 100, 0.1});
  CHECK(RangesForMap(m, s).z_min <= -30.5);
  CHECK(RangesForMap(m, s).z_max == r.z_max);
  LutRanges bad{10.0, 5.0, 0.0, 1.0};
  CHECK_THROWS_AS(bad.Check("x"), Error);
  LutSize tiny;
  tiny.n_distance = 1;
  CHECK_THROWS_AS(RadiusTable::Build(s, r, tiny), Error);
}

}  // namespace
}  // namespace pano

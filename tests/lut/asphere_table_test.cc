// Tables of an even-asphere mirror: the terms are saved with the table (under
// its checksum), a table does not match a sensor whose terms differ, and the
// cache key covers them.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>

#include "panotrack/lut/table_cache.h"
#include "test_paths.h"

namespace pano {
namespace {

Sensor AsphereSensor(double a4, double a6) {
  Sensor s = MakeSphereSensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1);
  s.model = MirrorModel::kAsphere;
  s.params.asphere_a4 = a4;
  s.params.asphere_a6 = a6;
  return s;
}
LutRanges RoomRanges() { return {10.0, 450.0, -30.0, 90.0}; }
LutSize SmallSize() {
  LutSize n;
  n.n_distance = n.n_elevation = n.n_radius = 96;
  n.n_height = 48;
  return n;
}

TEST_CASE("an asphere table keeps its terms, its checksum covers them", "[asphere_table]") {
  const std::string dir = test::ScratchDir("asphere_table");
  const Sensor s = AsphereSensor(0.05, -0.01);
  const RadiusTable t = RadiusTable::Build(s, RoomRanges(), SmallSize());
  const std::string path = dir + "/a.lut";
  t.Save(path);
  const RadiusTable back = RadiusTable::Load(path, &s);
  CHECK(back.sensor().model == MirrorModel::kAsphere);
  CHECK(back.sensor().params.asphere_a4 == 0.05);
  CHECK(back.sensor().params.asphere_a6 == -0.01);
  CHECK(back.Matches(s));
  CHECK_FALSE(back.Matches(AsphereSensor(0.051, -0.01)));
  CHECK_FALSE(back.Matches(AsphereSensor(0.05, 0.0)));
  CHECK_THROWS_WITH(RadiusTable::Load(path, &static_cast<const Sensor&>(AsphereSensor(0.06, -0.01))),
                    Catch::Contains("other sensor parameters"));
  // The table follows the model: E(D, Z) at a point equals the exact solve.
  double r_table, r_exact;
  REQUIRE(back.radius(120.0, 20.0, &r_table));
  REQUIRE(s.image_radius(120.0, 20.0, &r_exact));
  CHECK(r_table == Approx(r_exact).margin(0.01));
  // One flipped bit in the terms (just after the header) fails the checksum.
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(f)), {});
  const size_t tail = bytes.size() - sizeof(uint64_t) - (96 * 96 + 96 * 48) * sizeof(float) - 2 * sizeof(double);
  f.seekp(static_cast<std::streamoff>(tail + 3));
  f.put(static_cast<char>(bytes[tail + 3] ^ 0x10));
  f.close();
  CHECK_THROWS_WITH(RadiusTable::Load(path), Catch::Contains("checksum"));
}

TEST_CASE("the cache key covers the asphere terms", "[asphere_table]") {
  const std::string k1 = RadiusTableCacheKey(AsphereSensor(0.05, 0.0), RoomRanges(), SmallSize());
  const std::string k2 = RadiusTableCacheKey(AsphereSensor(0.05, 1e-6), RoomRanges(), SmallSize());
  const std::string k3 = RadiusTableCacheKey(AsphereSensor(0.0500001, 0.0), RoomRanges(), SmallSize());
  CHECK(k1 != k2);
  CHECK(k1 != k3);
  CHECK(k2 != k3);
}

}  // namespace
}  // namespace pano

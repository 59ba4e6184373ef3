// The on-disk table cache: keys, hits that give the very table a build
// gives, cache files that are corrupt, truncated or another table's, cache
// folders that cannot be written, and runs filling the cache at once.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "panotrack/io/calibration.h"
#include "panotrack/lut/table_cache.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

Sensor PaperSensor() { return ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor; }
LutRanges RoomRanges() { return {10.0, 450.0, -30.0, 90.0}; }
LutSize SmallSize() {
  LutSize n;
  n.n_distance = n.n_elevation = n.n_radius = 96;
  n.n_height = 48;
  return n;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}
// A table's saved bytes: equal bytes, equal tables (every node, bit for bit).
std::string Bytes(const RadiusTable& t, const std::string& dir) {
  const std::string path = dir + "/compare.lut";
  t.Save(path);
  std::string b = ReadBytes(path);
  fs::remove(path);
  return b;
}
int CountFiles(const std::string& dir) {
  int n = 0;
  for (auto& e : fs::directory_iterator(dir)) (void)e, ++n;
  return n;
}

struct Notes {
  std::vector<std::string> notes, traces;
  TableCacheOptions Options(const std::string& dir) {
    TableCacheOptions o;
    o.dir = dir;
    o.on_note = [this](const std::string& s) { notes.push_back(s); };
    o.on_trace = [this](const std::string& s) { traces.push_back(s); };
    return o;
  }
};

TEST_CASE("cache keys: one per sensor, ranges and size", "[table_cache]") {
  const Sensor s = PaperSensor();
  const std::string key = RadiusTableCacheKey(s, RoomRanges(), SmallSize());
  CHECK(key.size() == 16);
  CHECK(key.find_first_not_of("0123456789abcdef") == std::string::npos);
  CHECK(RadiusTableCacheKey(s, RoomRanges(), SmallSize()) == key);
  Sensor other = s;
  other.params.focal_px += 1e-9;  // any bit of the calibration
  CHECK(RadiusTableCacheKey(other, RoomRanges(), SmallSize()) != key);
  other = s;
  other.params.k1 = 0.01;
  CHECK(RadiusTableCacheKey(other, RoomRanges(), SmallSize()) != key);
  other = s;
  other.image_width += 2;
  CHECK(RadiusTableCacheKey(other, RoomRanges(), SmallSize()) != key);
  LutRanges higher = RoomRanges();
  higher.z_min -= 1.0;  // another map or sensor_height
  CHECK(RadiusTableCacheKey(s, higher, SmallSize()) != key);
  LutSize finer = SmallSize();
  finer.n_height += 1;
  CHECK(RadiusTableCacheKey(s, RoomRanges(), finer) != key);
  CHECK(RadiusTableCachePath("/c", s, RoomRanges(), SmallSize()) == "/c/radius-table-" + key + ".lut");
}

TEST_CASE("the default cache folder follows XDG_CACHE_HOME, else HOME", "[table_cache]") {
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  const char* home = std::getenv("HOME");
  const std::string saved_xdg = xdg ? xdg : "", saved_home = home ? home : "";
  ::setenv("XDG_CACHE_HOME", "/var/cache/me", 1);
  CHECK(DefaultTableCacheDir() == "/var/cache/me/panotrack");
  ::setenv("XDG_CACHE_HOME", "relative", 1);  // invalid by the XDG spec: ignored
  ::setenv("HOME", "/home/me", 1);
  CHECK(DefaultTableCacheDir() == "/home/me/.cache/panotrack");
  ::unsetenv("XDG_CACHE_HOME");
  CHECK(DefaultTableCacheDir() == "/home/me/.cache/panotrack");
  ::unsetenv("HOME");
  CHECK(DefaultTableCacheDir().empty());
  if (xdg) ::setenv("XDG_CACHE_HOME", saved_xdg.c_str(), 1);
  if (home) ::setenv("HOME", saved_home.c_str(), 1);
}

TEST_CASE("a second load hits the cache and gives the table a build gives", "[table_cache]") {
  const std::string scratch = test::ScratchDir("table_cache_hit");
  const std::string dir = scratch + "/cache/panotrack";  // created when missing
  const Sensor s = PaperSensor();
  const std::string fresh = Bytes(RadiusTable::Build(s, RoomRanges(), SmallSize()), scratch);
  Notes n;
  TableCacheOutcome outcome;
  const RadiusTable first = LoadOrBuildRadiusTable(s, RoomRanges(), SmallSize(), n.Options(dir), &outcome);
  CHECK(outcome == TableCacheOutcome::kBuilt);
  const std::string path = RadiusTableCachePath(dir, s, RoomRanges(), SmallSize());
  CHECK(fs::exists(path));
  CHECK(CountFiles(dir) == 1);  // no temporary file left
  const RadiusTable second = LoadOrBuildRadiusTable(s, RoomRanges(), SmallSize(), n.Options(dir), &outcome);
  CHECK(outcome == TableCacheOutcome::kHit);
  CHECK(Bytes(first, scratch) == fresh);
  CHECK(Bytes(second, scratch) == fresh);
  CHECK(n.notes.empty());
  REQUIRE(n.traces.size() == 3);  // miss, stored, hit
  CHECK(n.traces[2].find("from the cache") != std::string::npos);

  // Another calibration: another file, the first one kept.
  Sensor other = s;
  other.params.cx += 0.5;
  LoadOrBuildRadiusTable(other, RoomRanges(), SmallSize(), n.Options(dir), &outcome);
  CHECK(outcome == TableCacheOutcome::kBuilt);
  CHECK(CountFiles(dir) == 2);

  // No folder: built, nothing written.
  const RadiusTable none = LoadOrBuildRadiusTable(s, RoomRanges(), SmallSize(), TableCacheOptions(), &outcome);
  CHECK(outcome == TableCacheOutcome::kDisabled);
  CHECK(Bytes(none, scratch) == fresh);
}

TEST_CASE("corrupt, truncated or foreign cache files are rejected and rebuilt", "[table_cache]") {
  const std::string dir = test::ScratchDir("table_cache_bad");
  const Sensor s = PaperSensor();
  const std::string path = RadiusTableCachePath(dir, s, RoomRanges(), SmallSize());
  const std::string fresh = Bytes(RadiusTable::Build(s, RoomRanges(), SmallSize()), dir);
  Sensor other = s;
  other.params.focal_px += 3.0;
  const std::string foreign = Bytes(RadiusTable::Build(other, RoomRanges(), SmallSize()), dir);

  std::string flipped = fresh;
  flipped[fresh.size() / 2] ^= 0x08;
  const struct {
    const char* what;
    std::string bytes;
    const char* says;
  } cases[] = {
      {"a flipped bit", flipped, "checksum"},
      {"a truncated file", fresh.substr(0, fresh.size() - 1000), "truncated"},
      {"an empty file", "", "truncated"},
      {"another calibration's table", foreign, "built for other sensor parameters"},
      {"a text file", "not a table\n", "truncated"},
  };
  for (const auto& c : cases) {
    SECTION(c.what) {
      WriteBytes(path, c.bytes);
      Notes n;
      TableCacheOutcome outcome;
      const RadiusTable t = LoadOrBuildRadiusTable(s, RoomRanges(), SmallSize(), n.Options(dir), &outcome);
      CHECK(outcome == TableCacheOutcome::kBuilt);
      CHECK(Bytes(t, dir) == fresh);
      REQUIRE(n.notes.size() == 1);
      INFO(n.notes[0]);
      CHECK(n.notes[0].find("ignoring cached table") != std::string::npos);
      CHECK(n.notes[0].find(path) != std::string::npos);
      CHECK(n.notes[0].find(c.says) != std::string::npos);
      CHECK(ReadBytes(path) == fresh);  // replaced by the good table
      LoadOrBuildRadiusTable(s, RoomRanges(), SmallSize(), n.Options(dir), &outcome);
      CHECK(outcome == TableCacheOutcome::kHit);
    }
  }
}

TEST_CASE("a cache folder that cannot be written: the table is built all the same", "[table_cache]") {
  const std::string dir = test::ScratchDir("table_cache_unwritable");
  WriteBytes(dir + "/file", "a file where the cache folder should be");
  const Sensor s = PaperSensor();
  Notes n;
  TableCacheOutcome outcome;
  const RadiusTable t =
      LoadOrBuildRadiusTable(s, RoomRanges(), SmallSize(), n.Options(dir + "/file/panotrack"), &outcome);
  CHECK(outcome == TableCacheOutcome::kNotStored);
  CHECK(Bytes(t, dir) == Bytes(RadiusTable::Build(s, RoomRanges(), SmallSize()), dir));
  REQUIRE(n.notes.size() == 1);
  CHECK(n.notes[0].find("cannot store the table in the cache") != std::string::npos);
}

TEST_CASE("runs filling the cache at once all get the table; the file stays whole", "[table_cache]") {
  const std::string dir = test::ScratchDir("table_cache_parallel");
  const Sensor s = PaperSensor();
  const std::string fresh = Bytes(RadiusTable::Build(s, RoomRanges(), SmallSize()), dir);
  const int n_runs = 6;
  std::vector<RadiusTable> tables(n_runs);
  std::vector<std::thread> runs;
  for (int i = 0; i < n_runs; ++i)
    runs.emplace_back([&, i] {
      TableCacheOptions o;
      o.dir = dir + "/cache";
      tables[i] = LoadOrBuildRadiusTable(s, RoomRanges(), SmallSize(), o);
    });
  for (auto& r : runs) r.join();
  for (const RadiusTable& t : tables) CHECK(Bytes(t, dir) == fresh);
  CHECK(CountFiles(dir + "/cache") == 1);
  CHECK(ReadBytes(RadiusTableCachePath(dir + "/cache", s, RoomRanges(), SmallSize())) == fresh);
}

}  // namespace
}  // namespace pano

// panoloc with its table cache: the poses of a run that builds and stores
// the table, of one that loads it, of one that finds it corrupt, and of one
// without a cache are the same to the last digit; the program's options.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/lut/table_cache.h"
#include "panotrack/pipeline/panoloc.h"
#include "pipeline_fixture.h"

namespace pano {
namespace {

namespace fs = std::filesystem;
using test::OneInput;
using test::Scratch;

// The cache file panoloc uses for the small case.
std::string CacheFileOf(const std::string& dir) {
  const test::SmallCase& c = test::GetSmallCase();
  const Calibration calib = ReadCalibration(c.calib);
  return RadiusTableCachePath(dir, calib.sensor, RangesForMap(ReadMap(c.map), calib.sensor), LutSize());
}

TEST_CASE("poses are identical with a cold, a warm, a corrupt and no table cache", "[table_cache]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_table_cache");
  const std::string cache = dir + "/cache";
  auto run = [&](const std::string& name, const std::string& cache_dir) {
    PanolocOptions o = OneInput(c.video, dir + "/" + name + ".csv");
    o.table_cache_dir = cache_dir;
    const std::vector<VideoSummary> s = RunPanoloc(o);
    REQUIRE(s.size() == 1);
    INFO(s[0].error);
    REQUIRE(s[0].ok);
    CHECK(s[0].n_ok == c.n_frames);
    return test::ReadText(o.output);
  };
  const std::string cold = run("cold", cache);
  const std::string file = CacheFileOf(cache);
  REQUIRE(fs::exists(file));
  const auto written = fs::last_write_time(file);
  const std::string warm = run("warm", cache);
  CHECK(fs::last_write_time(file) == written);  // loaded, not rebuilt
  CHECK(warm == cold);
  CHECK(test::CountLines(warm) == c.n_frames + 1);

  // A cache file cut short (a full disk, a crash of an older writer) is rebuilt.
  fs::resize_file(file, fs::file_size(file) / 2);
  CHECK(run("corrupt", cache) == cold);
  CHECK(fs::file_size(file) > 8000000);  // whole again
  CHECK(run("none", "") == cold);
}

TEST_CASE("panoloc --table-cache and --no-table-cache", "[table_cache]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_table_cache_cli");
  const std::string cache = dir + "/tables";
  const std::string panoloc = test::Program("panoloc");
  auto args = [&](const std::string& out, std::vector<std::string> extra) {
    std::vector<std::string> a = {panoloc, c.video, "-o", dir + "/" + out};
    for (const std::string& w : test::Words(c.Args())) a.push_back(w);
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  test::RunResult r = test::Run(args("a.csv", {"--table-cache", cache, "-v"}), dir);
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK(fs::exists(CacheFileOf(cache)));
  CHECK(r.err.find("lookup table not in the cache") != std::string::npos);
  r = test::Run(args("b.csv", {"--table-cache", cache, "-v"}), dir);
  CHECK(r.code == 0);
  CHECK(r.err.find("lookup table from the cache: " + CacheFileOf(cache)) != std::string::npos);
  CHECK(test::ReadText(dir + "/a.csv") == test::ReadText(dir + "/b.csv"));
  // Quiet about the cache without -v.
  r = test::Run(args("c.csv", {"--table-cache", cache}), dir);
  CHECK(r.code == 0);
  CHECK(r.err.find("cache") == std::string::npos);
  // --no-table-cache: no default cache folder created.
  const std::string home = dir + "/home";
  std::vector<std::string> no_cache = {"/usr/bin/env", "XDG_CACHE_HOME=" + home};
  for (const std::string& w : args("e.csv", {"--no-table-cache"})) no_cache.push_back(w);
  r = test::Run(no_cache, dir);
  CHECK(r.code == 0);
  CHECK_FALSE(fs::exists(home));
  CHECK(test::ReadText(dir + "/a.csv") == test::ReadText(dir + "/e.csv"));
  // By default: $XDG_CACHE_HOME/panotrack.
  std::vector<std::string> by_default = {"/usr/bin/env", "XDG_CACHE_HOME=" + home};
  for (const std::string& w : args("f.csv", {})) by_default.push_back(w);
  r = test::Run(by_default, dir);
  CHECK(r.code == 0);
  CHECK(fs::exists(CacheFileOf(home + "/panotrack")));
  r = test::Run(args("g.csv", {"--no-table-cache", "--table-cache", cache}), dir);
  CHECK(r.code == 1);
  CHECK(r.err.find("--table-cache and --no-table-cache") != std::string::npos);
}

}  // namespace
}  // namespace pano

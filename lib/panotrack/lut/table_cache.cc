#include "panotrack/lut/table_cache.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"

namespace pano {

namespace {

namespace fs = std::filesystem;

// Bump when RadiusTable::Build computes different values for the same
// inputs (a new node spacing, a changed sensor model): old cache files then
// stop matching any key and are simply no longer used.
constexpr uint32_t kBuildVersion = 1;

// FNV-1a, 64 bits, fed field by field.
class KeyHasher {
 public:
  template <typename T>
  void Add(const T& value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    for (unsigned char b : bytes) {
      h_ ^= b;
      h_ *= 1099511628211ULL;
    }
  }
  uint64_t value() const { return h_; }

 private:
  uint64_t h_ = 1469598103934665603ULL;
};

// The sensor parameters the table depends on (those RadiusTable::Save records).
// The last two, the even-asphere terms, enter the cache key only when non-zero
// (so that the keys of conic and sphere tables stay as they were).
constexpr int kNumParamFields = 13;
void ParamFields(const SensorParams<double>& p, const double* out[kNumParamFields]) {
  const double* f[kNumParamFields] = {&p.focal_px, &p.cx, &p.cy, &p.aspect, &p.azimuth_offset, &p.k1, &p.k2,
                                      &p.curvature_radius, &p.conic_constant, &p.vertex_distance, &p.rim_radius,
                                      &p.asphere_a4, &p.asphere_a6};
  for (int i = 0; i < kNumParamFields; ++i) out[i] = f[i];
}

// Bitwise equality: the key is over the bits, so the file must match them.
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Why a loaded table is not the one asked for; empty when it is.
std::string Mismatch(const RadiusTable& t, const Sensor& sensor, const LutRanges& ranges, const LutSize& size) {
  const Sensor& s = t.sensor();
  if (s.model != sensor.model || s.image_width != sensor.image_width || s.image_height != sensor.image_height)
    return "another sensor model or image size";
  const double* a[kNumParamFields];
  const double* b[kNumParamFields];
  ParamFields(s.params, a);
  ParamFields(sensor.params, b);
  for (int i = 0; i < kNumParamFields; ++i)
    if (!SameBits(*a[i], *b[i])) return "other sensor parameters";
  const LutRanges& r = t.ranges();
  if (!SameBits(r.d_min, ranges.d_min) || !SameBits(r.d_max, ranges.d_max) || !SameBits(r.z_min, ranges.z_min) ||
      !SameBits(r.z_max, ranges.z_max))
    return "other distance or height ranges";
  const LutSize& n = t.size();
  if (n.n_distance != size.n_distance || n.n_elevation != size.n_elevation || n.n_radius != size.n_radius ||
      n.n_height != size.n_height)
    return "other table sizes";
  return "";
}

void Say(const std::function<void(const std::string&)>& f, const std::string& text) {
  if (f) f(text);
}

}  // namespace

std::string DefaultTableCacheDir() {
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  // The XDG spec: a relative XDG_CACHE_HOME is invalid and to be ignored.
  if (xdg && xdg[0] == '/') return (fs::path(xdg) / "panotrack").string();
  const char* home = std::getenv("HOME");
  if (home && home[0] != '\0') return (fs::path(home) / ".cache" / "panotrack").string();
  return "";
}

std::string RadiusTableCacheKey(const Sensor& sensor, const LutRanges& ranges, const LutSize& size) {
  KeyHasher h;
  h.Add(static_cast<uint32_t>(kRadiusTableFormatVersion));
  h.Add(kBuildVersion);
  h.Add(static_cast<int32_t>(sensor.model));
  h.Add(static_cast<int32_t>(sensor.image_width));
  h.Add(static_cast<int32_t>(sensor.image_height));
  const double* p[kNumParamFields];
  ParamFields(sensor.params, p);
  for (int i = 0; i < 11; ++i) h.Add(*p[i]);
  if (sensor.params.asphere_a4 != 0.0 || sensor.params.asphere_a6 != 0.0)
    for (int i = 11; i < kNumParamFields; ++i) h.Add(*p[i]);
  for (double v : {ranges.d_min, ranges.d_max, ranges.z_min, ranges.z_max}) h.Add(v);
  for (int n : {size.n_distance, size.n_elevation, size.n_radius, size.n_height}) h.Add(static_cast<int32_t>(n));
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h.value()));
  return hex;
}

std::string RadiusTableCachePath(const std::string& dir, const Sensor& sensor, const LutRanges& ranges,
                                 const LutSize& size) {
  return (fs::path(dir) / ("radius-table-" + RadiusTableCacheKey(sensor, ranges, size) + ".lut")).string();
}

RadiusTable LoadOrBuildRadiusTable(const Sensor& sensor, const LutRanges& ranges, const LutSize& size,
                                   const TableCacheOptions& cache, TableCacheOutcome* outcome, int num_threads) {
  TableCacheOutcome result = TableCacheOutcome::kDisabled;
  if (cache.dir.empty()) {
    if (outcome) *outcome = result;
    return RadiusTable::Build(sensor, ranges, size, num_threads);
  }
  // Invalid requests fail as Build would, before the cache is touched.
  sensor.Check("lookup table");
  ranges.Check("lookup table");
  size.Check("lookup table");
  CheckThreadCount(num_threads, "lookup table: num_threads");
  const std::string path = RadiusTableCachePath(cache.dir, sensor, ranges, size);
  std::error_code ec;
  if (fs::exists(path, ec)) {
    try {
      RadiusTable t = RadiusTable::Load(path);
      const std::string why = Mismatch(t, sensor, ranges, size);
      if (why.empty()) {
        Say(cache.on_trace, "lookup table from the cache: " + path);
        if (outcome) *outcome = TableCacheOutcome::kHit;
        return t;
      }
      Say(cache.on_note, "ignoring cached table " + path + ": built for " + why + "; rebuilding it");
    } catch (const Error& e) {
      Say(cache.on_note, std::string("ignoring cached table: ") + e.what() + "; rebuilding it");
    }
  } else {
    Say(cache.on_trace, "lookup table not in the cache: building " + path);
  }
  RadiusTable t = RadiusTable::Build(sensor, ranges, size, num_threads);
  result = TableCacheOutcome::kBuilt;
  try {
    fs::create_directories(cache.dir, ec);
    if (ec) throw Error(cache.dir + ": cannot create the table cache folder: " + ec.message());
    t.Save(path);
    Say(cache.on_trace, "lookup table stored in the cache: " + path);
  } catch (const std::exception& e) {
    result = TableCacheOutcome::kNotStored;
    Say(cache.on_note, std::string("cannot store the table in the cache: ") + e.what());
  }
  if (outcome) *outcome = result;
  return t;
}

}  // namespace pano

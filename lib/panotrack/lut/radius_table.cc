#include "panotrack/lut/radius_table.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "panotrack/core/angles.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/scene/map.h"

namespace pano {

namespace {

constexpr char kMagic[8] = {'P', 'A', 'N', 'O', 'L', 'U', 'T', '\0'};
constexpr uint32_t kVersion = kRadiusTableFormatVersion;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

constexpr uint64_t kFnvBasis = 1469598103934665603ULL;
// Image sizes a table may record: those a calibration file may declare (io/calibration.h).
constexpr int kMaxImageSide = 32768;
constexpr long long kMaxImagePixels = 16384LL * 16384LL;
constexpr int kMaxAxisNodes = 100000;

// FNV-1a over `data`, continuing from `h` (a checksum computed piece by piece).
uint64_t Fnv1a64(const void* bytes, size_t n, uint64_t h = kFnvBasis) {
  const uint8_t* data = static_cast<const uint8_t*>(bytes);
  for (size_t i = 0; i < n; ++i) {
    h ^= data[i];
    h *= 1099511628211ULL;
  }
  return h;
}

// Fixed-layout header, all little-endian doubles/ints as on x86-64 and ARM64.
struct Header {
  char magic[8];
  uint32_t version;
  uint32_t model;
  int32_t image_width, image_height;
  double params[11];
  double ranges[4];
  int32_t n_distance, n_elevation, n_radius, n_height;
};

// The unified profile has no mirror terms: its xi takes the conic
// constant's place (the header's model says which).
void PackParams(const Sensor& s, double* out) {
  const SensorParams<double>& p = s.params;
  const double v[11] = {p.focal_px, p.cx, p.cy, p.aspect, p.azimuth_offset, p.k1, p.k2,
                        p.curvature_radius, p.unified ? p.xi : p.conic_constant, p.vertex_distance, p.rim_radius};
  std::memcpy(out, v, sizeof v);
}

// An asphere table's header is followed by its even-asphere terms (a4, a6),
// covered by the checksum; sphere and conic tables have none, as before.
constexpr int kNumAsphereTerms = 2;
bool HasAsphereTail(uint32_t model) { return model == static_cast<uint32_t>(MirrorModel::kAsphere); }

// Bilinear interpolation of grid g (ny rows of nx) at fractional (fx, fy).
inline bool Bilinear(const std::vector<float>& g, int nx, int ny, double fx, double fy,
                     double* out) {
  if (!(fx >= 0.0) || !(fy >= 0.0) || fx > nx - 1 || fy > ny - 1) return false;
  int ix = std::min(static_cast<int>(fx), nx - 2);
  int iy = std::min(static_cast<int>(fy), ny - 2);
  const double tx = fx - ix, ty = fy - iy;
  const float* r0 = &g[static_cast<size_t>(iy) * nx + ix];
  const float* r1 = r0 + nx;
  const double v = (1 - ty) * ((1 - tx) * r0[0] + tx * r0[1]) + ty * ((1 - tx) * r1[0] + tx * r1[1]);
  if (std::isnan(v)) return false;
  *out = v;
  return true;
}

}  // namespace

void LutRanges::Check(const std::string& what) const {
  if (!(d_min > 0.0) || !(d_max > d_min) || !std::isfinite(d_max))
    throw Error(what + ": distance range: expected 0 < d_min < d_max");
  if (!(z_max > z_min) || !std::isfinite(z_min) || !std::isfinite(z_max))
    throw Error(what + ": height range: expected z_min < z_max");
}

void LutSize::Check(const std::string& what) const {
  if (n_distance < 2 || n_elevation < 2 || n_radius < 2 || n_height < 2)
    throw Error(what + ": table size: expected at least 2 nodes along every axis");
  if (static_cast<double>(n_distance) * n_elevation > 1e8 ||
      static_cast<double>(n_radius) * n_height > 1e8)
    throw Error(what + ": table size: more than 1e8 nodes");
}

namespace {

// The lowest point of the map: the floor, or a corner below it. A measured
// or refined map may put a corner standing on the floor a hair below it
// (survey error, a refinement that frees the floor contacts); the table
// must still reach it.
double MapBottom(const Map& map) {
  double z = 0.0;
  for (const auto* rects : {&map.rectangles, &map.distractors})
    for (const MapRectangle& r : *rects) z = std::min(z, r.z0);
  for (const MapBox& b : map.boxes) z = std::min(z, b.min.z());
  return z;
}

}  // namespace

LutRanges RangesForMap(const Map& map, const Sensor& sensor) {
  // Farthest distance: the diagonal of the room (or of the landmarks' extent).
  Eigen::Vector2d lo, hi;
  double z_top;
  map.Extent(&lo, &hi, &z_top);
  z_top = std::max(z_top, map.sensor_height);
  LutRanges r;
  const double diag = (hi - lo).norm();
  // Nearest distance: one mirror distance (pinhole to the sphere's centre).
  // A robot can pass a wall closer than two of them (the paper's sensor:
  // 30 cm); the corners on that wall, whose horizontal edges' lines pass
  // that near, must stay predictable: they are the landmarks whose
  // bearings tell the position best.
  r.d_min = std::max(sensor.mirror_distance(), 1e-3 * diag);
  r.d_max = 1.5 * diag + r.d_min;
  r.z_min = MapBottom(map) - map.sensor_height - 1e-6;
  r.z_max = z_top - map.sensor_height + 1e-6;
  return r;
}

LutRanges DefaultRanges(const Sensor& sensor) {
  const double scale = sensor.params.vertex_distance + sensor.params.curvature_radius;
  LutRanges r;
  r.d_min = scale;
  r.d_max = 400.0 * scale;
  r.z_min = -0.5 * r.d_max;
  r.z_max = 0.5 * r.d_max;
  return r;
}

void RadiusTable::SetGeometry() {
  log_d_min_ = std::log(ranges_.d_min);
  log_d_step_ = (std::log(ranges_.d_max) - log_d_min_) / (size_.n_distance - 1);
  // Elevation range of the (D, Z) box, seen from the pinhole.
  const double e[4] = {std::atan2(ranges_.z_min, ranges_.d_min), std::atan2(ranges_.z_min, ranges_.d_max),
                       std::atan2(ranges_.z_max, ranges_.d_min), std::atan2(ranges_.z_max, ranges_.d_max)};
  elev_min_ = *std::min_element(e, e + 4);
  elev_step_ = (*std::max_element(e, e + 4) - elev_min_) / (size_.n_elevation - 1);
  r_max_ = sensor_.limb_radius();
  z_step_ = (ranges_.z_max - ranges_.z_min) / (size_.n_height - 1);
}

RadiusTable RadiusTable::Build(const Sensor& sensor, const LutRanges& ranges, const LutSize& size,
                               int num_threads) {
  sensor.Check("lookup table");
  ranges.Check("lookup table");
  size.Check("lookup table");
  CheckThreadCount(num_threads, "lookup table: num_threads");
  [[maybe_unused]] const int threads = ThreadCount(num_threads);
  RadiusTable t;
  t.sensor_ = sensor;
  t.ranges_ = ranges;
  t.size_ = size;
  t.SetGeometry();
  const int nd = size.n_distance, ne = size.n_elevation;
  t.forward_.assign(static_cast<size_t>(nd) * ne, kNaN);
#pragma omp parallel for schedule(dynamic, 8) num_threads(threads)
  for (int j = 0; j < ne; ++j) {
    const double elev = t.elev_min_ + j * t.elev_step_;
    const double tan_e = std::tan(elev);
    for (int i = 0; i < nd; ++i) {
      const double D = std::exp(t.log_d_min_ + i * t.log_d_step_);
      double R;
      if (sensor.image_radius(D, D * tan_e, &R))
        t.forward_[static_cast<size_t>(j) * nd + i] = static_cast<float>(R);
    }
  }
  const int nr = size.n_radius, nz = size.n_height;
  t.inverse_.assign(static_cast<size_t>(nr) * nz, kNaN);
  // Radius nodes are spaced evenly in sqrt(1 - R / R_limb): near the limb
  // D(R) behaves like sqrt(R_limb - R) (grazing rays), which this makes smooth.
  // The inverse is stored as inverse distance 1/D, which stays smooth where
  // the ray runs parallel to the plane z = Z (D -> infinity) and turns
  // negative beyond: bilinear interpolation of D itself would fail there.
  const SensorParams<double>& p = sensor.params;
  const double m_limb = MaxNormalizedRadius(p) * (1.0 - 1e-12);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int j = 0; j < nz; ++j) {
    const double Z = ranges.z_min + j * t.z_step_;
    for (int i = 0; i < nr; ++i) {
      double m, ps, pz, ds, dz;
      const double x = 1.0 - static_cast<double>(i) / (nr - 1);
      if (!UndistortRadius(p, t.r_max_ * (1.0 - x * x) / p.focal_px, &m)) continue;
      m = std::min(m, m_limb);  // the last node sits on the limb
      if (!ReflectMeridian(p, m, &ps, &pz, &ds, &dz)) continue;
      // 1 / D with D = ps + (Z - pz) ds / dz.
      const double den = ps * dz + (Z - pz) * ds;
      if (den == 0.0) continue;
      t.inverse_[static_cast<size_t>(j) * nr + i] = static_cast<float>(dz / den);
    }
  }
  return t;
}

bool RadiusTable::radius(double D, double Z, double* R) const {
  if (!(D > 0.0)) return false;
  const double fx = (std::log(D) - log_d_min_) / log_d_step_;
  const double fy = (FastAtan2(Z, D) - elev_min_) / elev_step_;
  return Bilinear(forward_, size_.n_distance, size_.n_elevation, fx, fy, R);
}

bool RadiusTable::distance(double R, double Z, double* D) const {
  if (!(R >= 0.0) || R > r_max_) return false;
  const double fx = (1.0 - std::sqrt(1.0 - R / r_max_)) * (size_.n_radius - 1);
  const double fy = (Z - ranges_.z_min) / z_step_;
  double inv_d;
  if (!Bilinear(inverse_, size_.n_radius, size_.n_height, fx, fy, &inv_d) || !(inv_d > 0.0))
    return false;
  *D = 1.0 / inv_d;
  return true;
}

bool RadiusTable::Covers(const LutRanges& r) const {
  return !empty() && ranges_.d_min <= r.d_min && ranges_.d_max >= r.d_max &&
         ranges_.z_min <= r.z_min && ranges_.z_max >= r.z_max;
}

bool RadiusTable::Matches(const Sensor& s) const {
  if (s.model != sensor_.model) return false;
  double a[11], b[11];
  PackParams(s, a);
  PackParams(sensor_, b);
  for (int i = 0; i < 11; ++i)
    if (std::abs(a[i] - b[i]) > 1e-9 * (1.0 + std::abs(a[i]))) return false;
  const double ta[kNumAsphereTerms] = {s.params.asphere_a4, s.params.asphere_a6};
  const double tb[kNumAsphereTerms] = {sensor_.params.asphere_a4, sensor_.params.asphere_a6};
  for (int i = 0; i < kNumAsphereTerms; ++i)
    if (std::abs(ta[i] - tb[i]) > 1e-9 * (1.0 + std::abs(ta[i]))) return false;
  return true;
}

void RadiusTable::Save(const std::string& path) const {
  if (empty()) throw Error(path + ": cannot save an empty lookup table");
  Header h{};
  std::memcpy(h.magic, kMagic, 8);
  h.version = kVersion;
  h.model = static_cast<uint32_t>(sensor_.model);
  h.image_width = sensor_.image_width;
  h.image_height = sensor_.image_height;
  PackParams(sensor_, h.params);
  h.ranges[0] = ranges_.d_min;
  h.ranges[1] = ranges_.d_max;
  h.ranges[2] = ranges_.z_min;
  h.ranges[3] = ranges_.z_max;
  h.n_distance = size_.n_distance;
  h.n_elevation = size_.n_elevation;
  h.n_radius = size_.n_radius;
  h.n_height = size_.n_height;
  std::string blob(reinterpret_cast<const char*>(&h), sizeof h);
  if (HasAsphereTail(h.model)) {
    const double tail[kNumAsphereTerms] = {sensor_.params.asphere_a4, sensor_.params.asphere_a6};
    blob.append(reinterpret_cast<const char*>(tail), sizeof tail);
  }
  blob.append(reinterpret_cast<const char*>(forward_.data()), forward_.size() * sizeof(float));
  blob.append(reinterpret_cast<const char*>(inverse_.data()), inverse_.size() * sizeof(float));
  const uint64_t sum = Fnv1a64(reinterpret_cast<const uint8_t*>(blob.data()), blob.size());
  blob.append(reinterpret_cast<const char*>(&sum), sizeof sum);
  WriteFileAtomic(path, blob);
}

namespace {

// Checks what a header declares before anything is allocated for it.
void CheckHeader(const std::string& path, const Header& h) {
  if (std::memcmp(h.magic, kMagic, 8) != 0) throw Error(path + ": not a panotrack lookup table (bad magic)");
  if (h.version != kVersion)
    throw Error(path + ": lookup table version " + std::to_string(h.version) + ", expected " +
                std::to_string(kVersion) + " (rebuild it with panocalib lut)");
  const int sizes[4] = {h.n_distance, h.n_elevation, h.n_radius, h.n_height};
  LutSize size{h.n_distance, h.n_elevation, h.n_radius, h.n_height};
  bool ok = true;
  for (int n : sizes) ok = ok && n >= 2 && n <= kMaxAxisNodes;
  try {
    size.Check(path);
  } catch (const Error&) {
    ok = false;
  }
  if (!ok)
    throw Error(path + ": corrupt lookup table header (table sizes " + std::to_string(h.n_distance) + " x " +
                std::to_string(h.n_elevation) + " and " + std::to_string(h.n_radius) + " x " +
                std::to_string(h.n_height) + ")");
  if (h.model > static_cast<uint32_t>(MirrorModel::kUnified))
    throw Error(path + ": corrupt lookup table header (model)");
  if (h.image_width < 1 || h.image_width > kMaxImageSide || h.image_height < 1 ||
      h.image_height > kMaxImageSide ||
      static_cast<long long>(h.image_width) * h.image_height > kMaxImagePixels)
    throw Error(path + ": corrupt lookup table header (image size " + std::to_string(h.image_width) + " x " +
                std::to_string(h.image_height) + ")");
}

// Reads `n` floats into `out`, or fails naming the table's expected size.
void ReadFloats(InputFile& in, size_t n, std::vector<float>* out, size_t* read_so_far, size_t want) {
  out->resize(n);
  const size_t got = in.Read(out->data(), n * sizeof(float));
  *read_so_far += got;
  if (got != n * sizeof(float))
    throw Error(in.path() + ": truncated lookup table (" + std::to_string(*read_so_far) +
                " bytes, expected " + std::to_string(want) + ")");
}

}  // namespace

RadiusTable RadiusTable::Load(const std::string& path, const Sensor* expected) {
  InputFile in(path);
  Header h;
  size_t read_so_far = in.Read(&h, sizeof h);
  if (read_so_far < sizeof h)
    throw Error(path + ": truncated lookup table (" + std::to_string(read_so_far) +
                " bytes, shorter than its header)");
  CheckHeader(path, h);
  const size_t n_fwd = static_cast<size_t>(h.n_distance) * h.n_elevation;
  const size_t n_inv = static_cast<size_t>(h.n_radius) * h.n_height;
  const size_t n_tail = HasAsphereTail(h.model) ? kNumAsphereTerms : 0;
  const size_t want = sizeof(Header) + n_tail * sizeof(double) + (n_fwd + n_inv) * sizeof(float) + sizeof(uint64_t);
  if (in.size() >= 0 && static_cast<size_t>(in.size()) != want)
    throw Error(path + ": truncated or padded lookup table (" + std::to_string(in.size()) +
                " bytes, expected " + std::to_string(want) + ")");
  RadiusTable t;
  double tail[kNumAsphereTerms] = {0.0, 0.0};
  if (n_tail > 0) {
    const size_t got = in.Read(tail, sizeof tail);
    read_so_far += got;
    if (got != sizeof tail)
      throw Error(path + ": truncated lookup table (" + std::to_string(read_so_far) + " bytes, expected " +
                  std::to_string(want) + ")");
  }
  ReadFloats(in, n_fwd, &t.forward_, &read_so_far, want);
  ReadFloats(in, n_inv, &t.inverse_, &read_so_far, want);
  uint64_t stored = 0;
  if (in.Read(&stored, sizeof stored) != sizeof stored)
    throw Error(path + ": truncated lookup table (expected " + std::to_string(want) + " bytes)");
  char extra;
  if (in.Read(&extra, 1) != 0)
    throw Error(path + ": padded lookup table (more than the " + std::to_string(want) +
                " bytes its header declares)");
  uint64_t sum = Fnv1a64(&h, sizeof h);
  if (n_tail > 0) sum = Fnv1a64(tail, sizeof tail, sum);
  sum = Fnv1a64(t.forward_.data(), n_fwd * sizeof(float), sum);
  sum = Fnv1a64(t.inverse_.data(), n_inv * sizeof(float), sum);
  if (sum != stored) throw Error(path + ": corrupt lookup table (checksum mismatch)");
  t.size_ = {h.n_distance, h.n_elevation, h.n_radius, h.n_height};
  t.sensor_.model = static_cast<MirrorModel>(h.model);
  t.sensor_.image_width = h.image_width;
  t.sensor_.image_height = h.image_height;
  SensorParams<double>& p = t.sensor_.params;
  double* fields[11] = {&p.focal_px, &p.cx, &p.cy, &p.aspect, &p.azimuth_offset, &p.k1, &p.k2,
                        &p.curvature_radius, &p.conic_constant, &p.vertex_distance, &p.rim_radius};
  for (int i = 0; i < 11; ++i) *fields[i] = h.params[i];
  if (t.sensor_.model == MirrorModel::kUnified) {
    p.unified = true;
    p.xi = p.conic_constant;
    p.conic_constant = 0.0;
  }
  p.asphere_a4 = tail[0];
  p.asphere_a6 = tail[1];
  t.sensor_.Check(path);
  t.ranges_ = {h.ranges[0], h.ranges[1], h.ranges[2], h.ranges[3]};
  t.ranges_.Check(path);
  if (expected && !t.Matches(*expected))
    throw Error(path + ": lookup table was built for other sensor parameters than the calibration "
                       "(rebuild it with panocalib lut)");
  t.SetGeometry();
  return t;
}

}  // namespace pano

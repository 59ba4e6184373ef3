#include "panotrack/render/render.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <type_traits>

#include "panotrack/core/error.h"
#include "panotrack/render/split_mix.h"
#include "panotrack/core/parallel.h"

namespace pano {

namespace {

std::string Num(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

double SegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double l2 = ab.squaredNorm();
  double t = l2 > 0.0 ? (p - a).dot(ab) / l2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (a + t * ab - p).norm();
}

double BoxDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& mn, const Eigen::Vector2d& mx) {
  const double dx = std::max({mn.x() - p.x(), 0.0, p.x() - mx.x()});
  const double dy = std::max({mn.y() - p.y(), 0.0, p.y() - mx.y()});
  return std::hypot(dx, dy);
}


constexpr int kBins = 4096;  // azimuth bins of the per-frame candidate lists

}  // namespace

void RenderOptions::Check(const std::string& what) const {
  auto fail = [&](const std::string& key, const std::string& problem) {
    throw Error(what + ": " + key + ": " + problem);
  };
  if (supersample < 1 || supersample > 8) fail("supersample", "expected 1..8 rays per pixel side, got " + std::to_string(supersample));
  if (!(noise_sigma >= 0.0 && noise_sigma <= 255.0))
    fail("noise", "expected a noise sigma of 0..255 grey levels, got " + std::to_string(noise_sigma));
  if (!(illumination > 0.0) || !std::isfinite(illumination)) fail("illumination", "expected a positive gain");
  if (!(gradient >= 0.0 && gradient < 1.0)) fail("gradient", "expected 0 <= gradient < 1 (relative change across the scene)");
  if (!std::isfinite(gradient_angle)) fail("gradient-angle", "expected a finite angle in radians");
  if (!(background >= 0.0 && background <= 1.0)) fail("background", "expected a shade between 0 and 1");
  if (!(camera_radius_px >= 0.0) || !std::isfinite(camera_radius_px)) fail("camera-radius", "expected a non-negative radius in pixels");
  if (!(exposure >= 0.0 && exposure <= 1.0)) fail("exposure", "expected a fraction of the frame interval, 0..1");
  if (blur_samples < 0 || blur_samples > 64) fail("blur-samples", "expected 0 (automatic) or 1..64 sub-frames, got " + std::to_string(blur_samples));
  if (!(auto_exposure >= 0.0 && auto_exposure <= 0.9)) fail("auto-exposure", "expected a gain amplitude 0..0.9");
  if (!(texture >= 0.0 && texture <= 1.0)) fail("texture", "expected a texture amplitude 0..1");
  if (people < 0 || people > 50) fail("people", "expected 0..50 people, got " + std::to_string(people));
  if (covered_frames < 0) fail("covered-frames", "expected a non-negative number of frames");
  if (dropped_frames < 0) fail("dropped-frames", "expected a non-negative number of frames");
  CheckThreadCount(num_threads, what + ": num_threads");
}

double SurfaceTexture(const Eigen::Vector3d& p, double wavelength) {
  // Three oblique directions (none in a coordinate plane), so that every wall,
  // floor and box face shows a two-dimensional pattern; weights sum to 1.
  const double k = 2.0 * M_PI / wavelength;
  const double a = 0.62 * p.x() + 0.50 * p.y() + 0.60 * p.z();
  const double b = -0.71 * p.x() + 0.33 * p.y() + 0.62 * p.z();
  const double c = 0.27 * p.x() - 0.83 * p.y() + 0.49 * p.z();
  return 0.4 * std::sin(k * a + 1.3) + 0.35 * std::sin(1.37 * k * b + 0.4) + 0.25 * std::sin(2.3 * k * c + 2.1);
}

void CheckPose(const Map& map, const Pose2& pose, const std::string& what, double clearance) {
  const std::string at = "pose (" + Num(pose.x) + ", " + Num(pose.y) + ", " + Num(pose.theta) + ")";
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.theta))
    throw Error(what + ": " + at + " is not finite");
  if (map.room.present &&
      (pose.x <= map.room.min.x() || pose.y <= map.room.min.y() || pose.x >= map.room.max.x() ||
       pose.y >= map.room.max.y()))
    throw Error(what + ": " + at + " is outside the room [" + Num(map.room.min.x()) + ", " +
                Num(map.room.max.x()) + "] x [" + Num(map.room.min.y()) + ", " +
                Num(map.room.max.y()) + "]");
  const Eigen::Vector2d p(pose.x, pose.y);
  for (const MapBox& b : map.boxes) {
    const double d = BoxDistance(p, b.min.head<2>(), b.max.head<2>());
    if (d <= 0.0 && b.min.z() <= map.sensor_height && b.max.z() >= 0.0)
      throw Error(what + ": " + at + " is inside box '" + b.id + "'");
    if (d < clearance)
      throw Error(what + ": " + at + " is " + Num(d) + " from box '" + b.id + "' (closer than " + Num(clearance) + ")");
  }
  auto check_rects = [&](const std::vector<MapRectangle>& rects, const char* kind) {
    for (const MapRectangle& r : rects) {
      const double d = SegmentDistance(p, r.from, r.to);
      if (d < std::max(clearance, 1e-9))
        throw Error(what + ": " + at + " is " + Num(d) + " from " + kind + " '" + r.id +
                    "' (closer than " + Num(clearance) + ")");
    }
  };
  check_rects(map.rectangles, "rectangle");
  check_rects(map.distractors, "distractor");
}

// ---------------------------------------------------------------- RayTable

RayTable::RayTable(const Sensor& sensor, int supersample, double camera_radius_px, int num_threads)
    : sensor_(sensor), ss_(supersample) {
  CheckThreadCount(num_threads, "ray table: num_threads");
  const int W = sensor.image_width, H = sensor.image_height;
  const int s = supersample;
  const double limb = sensor.limb_radius();
  std::vector<std::vector<Ray>> rows(static_cast<size_t>(H));
  std::vector<int> counts(static_cast<size_t>(W) * H, 0);
  const SensorParams<double>& p = sensor.params;
  const bool aligned = sensor.aligned();
  const GeneralSensorParams<double> general = sensor.general();
  // Quick-reject radius: the aligned limb, or for a rig with faults the
  // mirror's edge found by bisection along 720 azimuths (it is no circle
  // about (cx, cy) then), plus a margin.
  double reject = limb;
  if (!aligned) {
    reject = 0.0;
    const double far = 2.0 * limb + std::hypot(W, H);
    for (int k = 0; k < 720; ++k) {
      const double az = 2.0 * M_PI * k / 720.0;
      double lo = 0.0, hi = far;
      for (int it = 0; it < 40 && hi - lo > 0.01; ++it) {
        const double mid = 0.5 * (lo + hi);
        double o[3], d[3];
        const Eigen::Vector2d px = sensor.from_polar(mid, az);
        if (pano::BackprojectGeneral(general, px.x(), px.y(), o, d)) lo = mid; else hi = mid;
      }
      reject = std::max(reject, hi);
    }
    reject += 2.0;  // the edge between sampled azimuths
  }
  std::vector<double> row_miss(static_cast<size_t>(H), 0.0);
  // Rows in parallel; an exception (memory) leaves the loop.
  ParallelFor(H, [&](int v) {
    std::vector<Ray>& row = rows[static_cast<size_t>(v)];
    for (int u = 0; u < W; ++u) {
      // Quick reject: the pixel's nearest point is beyond the mirror's edge.
      const double du = u - p.cx, dv = (v - p.cy) / p.aspect;
      if (std::hypot(du, dv) > reject + 2.0 / std::min(1.0, p.aspect)) continue;
      int n = 0;
      for (int j = 0; j < s; ++j) {
        for (int i = 0; i < s; ++i) {
          const double su = u + (i + 0.5) / s - 0.5, sv = v + (j + 0.5) / s - 0.5;
          const double r = std::hypot(su - p.cx, (sv - p.cy) / p.aspect);
          if (r < camera_radius_px) continue;
          double o[3], d[3];
          if (aligned ? !pano::backproject(p, su, sv, o, d) : !pano::BackprojectGeneral(general, su, sv, o, d))
            continue;
          const double hd = std::hypot(d[0], d[1]);
          const double phi = hd > 0.0 ? std::atan2(d[1], d[0]) : std::atan2(o[1], o[0]);
          const double c = std::cos(phi), sn = std::sin(phi);
          Ray ray;
          // Aligned: exactly 0 (the ray lies in its meridian plane).
          ray.e = aligned ? 0.0f : static_cast<float>(o[1] * c - o[0] * sn);
          row_miss[static_cast<size_t>(v)] = std::max(row_miss[static_cast<size_t>(v)], std::abs(static_cast<double>(ray.e)));
          ray.phi = static_cast<float>(phi);
          ray.c = static_cast<float>(c);
          ray.s = static_cast<float>(sn);
          ray.ps = static_cast<float>(o[0] * c + o[1] * sn);
          ray.pz = static_cast<float>(o[2]);
          ray.ds = static_cast<float>(std::max(0.0, d[0] * c + d[1] * sn));
          ray.dz = static_cast<float>(d[2]);
          row.push_back(ray);
          ++n;
        }
      }
      counts[static_cast<size_t>(v) * W + u] = n;
    }
  }, /*parallel=*/true, num_threads);
  for (double m : row_miss) max_axis_miss_ = std::max(max_axis_miss_, m);
  size_t total = 0;
  for (const auto& r : rows) total += r.size();
  rays_.reserve(total);
  for (const auto& r : rows) rays_.insert(rays_.end(), r.begin(), r.end());
  starts_.resize(static_cast<size_t>(W) * H + 1);
  int acc = 0;
  for (size_t i = 0; i < counts.size(); ++i) {
    starts_[i] = acc;
    acc += counts[i];
  }
  starts_.back() = acc;
}

// ---------------------------------------------------------------- Renderer

namespace {
const Sensor& Checked(const Sensor& sensor, const RenderOptions& options) {
  options.Check("render options");
  sensor.Check("sensor");
  return sensor;
}
}  // namespace

struct Renderer::Cand {
  int type;  // 0: vertical quad, 1: horizontal quad
  int id;
  double shade, bias;
  // vertical: a = A - P (2D), e = B - A, h = cross(a, e), z range relative to the pinhole
  // horizontal: a = corner - P (2D), (e0, e1) and (u0, u1) dual edge vectors, zlo = plane height
  double a0, a1, e0, e1, h, zlo, zhi, u0, u1;
};

struct Renderer::Frame {
  Pose2 pose;
  double ct = 1, st = 0, theta_off = 0;
  std::vector<Cand> cands;
  std::vector<int> bin_start;
  std::vector<int> bin_items;
  std::vector<int> generic;  // surfaces neither vertical nor horizontal: slow path
  // illumination: gain * (1 + k . (x - c))
  double gain = 1, gx = 0, gy = 0, cx = 0, cy = 0;
};

Renderer::Renderer(const Sensor& sensor, const Scene& scene, double sensor_height,
                   const RenderOptions& options)
    : scene_(scene),
      sensor_height_(sensor_height),
      options_(options),
      table_(Checked(sensor, options), options.supersample, options.camera_radius_px, options.num_threads),
      centre_table_(sensor, 1, options.camera_radius_px, options.num_threads) {
  axis_miss_ = std::max(table_.max_axis_miss(), centre_table_.max_axis_miss());
  const Eigen::Vector3d extent = scene.max() - scene.min();
  texture_wavelength_ = std::max(1e-6, 0.06 * std::max(extent.x(), extent.y()));
}

// The per-frame lists of candidate surfaces by azimuth bin (kBins): an item
// goes into every bin its angular interval touches, with a bin of margin.
struct Renderer::AzimuthBins {
  std::vector<std::vector<int>> bins = std::vector<std::vector<int>>(kBins);
  double axis_miss = 0.0;  // Renderer::axis_miss_

  void Mark(double a_start, double width, int item) {
    if (width >= 2.0 * M_PI - 1e-9) {
      for (auto& b : bins) b.push_back(item);
      return;
    }
    const double to_bin = kBins / (2.0 * M_PI);
    const double a0 = a_start + 4.0 * M_PI;
    const long first = static_cast<long>(std::floor(a0 * to_bin)) - 1;
    const long last = static_cast<long>(std::floor((a0 + width) * to_bin)) + 1;
    for (long b = first; b <= last && b - first < kBins; ++b)
      bins[static_cast<size_t>(((b % kBins) + kBins) % kBins)].push_back(item);
  }
  // Rays that miss the axis by up to axis_miss (a rig with faults) meet a
  // surface at least `distance` away within asin(axis_miss / distance) of
  // their own azimuth: its interval widened by that (all bins when too near).
  void MarkWidened(double a_start, double width, double distance, int item) {
    if (axis_miss <= 0.0) return Mark(a_start, width, item);
    if (!(distance > axis_miss * 1.01)) return Mark(0.0, 2.0 * M_PI, item);
    const double margin = std::asin(axis_miss / distance) + 1e-6;
    Mark(a_start - margin, width + 2.0 * margin, item);
  }
  // The lists one after the other: bin b's items at [start[b], start[b + 1]).
  void Flatten(std::vector<int>* start, std::vector<int>* items) const {
    start->assign(kBins + 1, 0);
    items->clear();
    for (int b = 0; b < kBins; ++b) {
      (*start)[static_cast<size_t>(b)] = static_cast<int>(items->size());
      items->insert(items->end(), bins[static_cast<size_t>(b)].begin(), bins[static_cast<size_t>(b)].end());
    }
    (*start)[kBins] = static_cast<int>(items->size());
  }
};

namespace {

// Angular interval [start, start + width] covering 2D points seen from P.
void AngularInterval(const Eigen::Vector2d& P, const std::vector<Eigen::Vector2d>& pts, double* start,
                     double* width) {
  Eigen::Vector2d mean(0, 0);
  for (const auto& q : pts) mean += q - P;
  const double ref = std::atan2(mean.y(), mean.x());
  double lo = 0, hi = 0;
  for (const auto& q : pts) {
    const double a = WrapAngle(std::atan2(q.y() - P.y(), q.x() - P.x()) - ref);
    lo = std::min(lo, a);
    hi = std::max(hi, a);
  }
  *start = ref + lo;
  *width = hi - lo;
}

}  // namespace

bool Renderer::AddCandidate(const Surface& s, int id, const Eigen::Vector2d& P, Frame* f, AzimuthBins* bins) const {
  const double H = sensor_height_;
  Cand c{};
  c.id = id;
  c.shade = s.shade;
  c.bias = s.background() ? 1e-4 : 0.0;
  const bool a_flat = s.edge_a.z() == 0.0, b_flat = s.edge_b.z() == 0.0;
  const bool a_vert = s.edge_a.head<2>().squaredNorm() == 0.0;
  const bool b_vert = s.edge_b.head<2>().squaredNorm() == 0.0;
  const Eigen::Vector2d corner = s.corner.head<2>();
  if ((a_flat && b_vert) || (b_flat && a_vert)) {
    const Eigen::Vector3d& eh = a_flat ? s.edge_a : s.edge_b;
    const Eigen::Vector3d& ev = a_flat ? s.edge_b : s.edge_a;
    c.type = 0;
    const Eigen::Vector2d a = corner - P, e = eh.head<2>();
    c.a0 = a.x();
    c.a1 = a.y();
    c.e0 = e.x();
    c.e1 = e.y();
    c.h = a.x() * e.y() - a.y() * e.x();
    const double z0 = s.corner.z() - H, z1 = s.corner.z() + ev.z() - H;
    c.zlo = std::min(z0, z1);
    c.zhi = std::max(z0, z1);
    double st, w;
    AngularInterval(P, {corner, corner + e}, &st, &w);
    f->cands.push_back(c);
    bins->MarkWidened(st, w, SegmentDistance(P, corner, corner + e), static_cast<int>(f->cands.size()) - 1);
    return true;
  }
  if (!(a_flat && b_flat)) return false;
  c.type = 1;
  const Eigen::Vector2d ea = s.edge_a.head<2>(), eb = s.edge_b.head<2>();
  const double aa = ea.squaredNorm(), bb = eb.squaredNorm(), ab = ea.dot(eb);
  const double det = aa * bb - ab * ab;
  const Eigen::Vector2d ua = (bb * ea - ab * eb) / det, ub = (aa * eb - ab * ea) / det;
  c.a0 = corner.x() - P.x();
  c.a1 = corner.y() - P.y();
  c.e0 = ua.x();
  c.e1 = ua.y();
  c.u0 = ub.x();
  c.u1 = ub.y();
  c.zlo = s.corner.z() - H;
  f->cands.push_back(c);
  const int item = static_cast<int>(f->cands.size()) - 1;
  const Eigen::Vector2d q = P - corner;
  const double al = ua.dot(q), be = ub.dot(q);
  if (al >= 0 && al <= 1 && be >= 0 && be <= 1) {
    bins->Mark(0.0, 2.0 * M_PI, item);
  } else {
    double st, w;
    AngularInterval(P, {corner, corner + ea, corner + eb, corner + ea + eb}, &st, &w);
    const double distance = std::min({SegmentDistance(P, corner, corner + ea), SegmentDistance(P, corner, corner + eb),
                                      SegmentDistance(P, corner + ea, corner + ea + eb),
                                      SegmentDistance(P, corner + eb, corner + ea + eb)});
    bins->MarkWidened(st, w, distance, item);
  }
  return true;
}

// Illumination: gain * (1 + k . (x - c)), k across the scene's extent in
// the gradient's direction.
void Renderer::SetIllumination(Frame* f) const {
  f->gain = options_.illumination;
  if (options_.gradient > 0.0) {
    const Eigen::Vector3d mn = scene_.min(), mx = scene_.max();
    const double ca = std::cos(options_.gradient_angle), sa = std::sin(options_.gradient_angle);
    const double half = 0.5 * (std::abs((mx.x() - mn.x()) * ca) + std::abs((mx.y() - mn.y()) * sa));
    if (half > 0.0) {
      f->gx = options_.gradient * ca / half;
      f->gy = options_.gradient * sa / half;
    }
    f->cx = 0.5 * (mn.x() + mx.x());
    f->cy = 0.5 * (mn.y() + mx.y());
  }
}

void Renderer::BuildFrame(const Pose2& pose, const std::vector<Surface>& extra, Frame* f) const {
  f->pose = pose;
  f->ct = std::cos(pose.theta);
  f->st = std::sin(pose.theta);
  f->theta_off = WrapAngle(pose.theta) + 4.0 * M_PI;
  const Eigen::Vector2d P(pose.x, pose.y);
  AzimuthBins bins;
  bins.axis_miss = axis_miss_;
  f->cands.clear();
  f->generic.clear();
  const auto& surfs = scene_.surfaces();
  const int n_scene = static_cast<int>(surfs.size());
  for (int i = 0; i < n_scene + static_cast<int>(extra.size()); ++i) {
    const Surface& s = i < n_scene ? surfs[static_cast<size_t>(i)] : extra[static_cast<size_t>(i - n_scene)];
    if (AddCandidate(s, i, P, f, &bins)) continue;
    if (i >= n_scene) throw Error("renderer: extra surface '" + s.name + "' is neither vertical nor horizontal");
    f->generic.push_back(i);
  }
  bins.Flatten(&f->bin_start, &f->bin_items);
  SetIllumination(f);
}

namespace {

struct TraceResult {
  double shade;
  int id;
  double r;  // horizontal distance of the hit from the axis
  double wx, wy;
  double z;  // height of the hit relative to the pinhole
};

// kMiss: the ray may miss the axis (ray.e != 0, a rig with faults); the
// aligned case compiles without those terms.
template <bool kMiss, typename Frame, typename Cand, typename Ray>
inline TraceResult TraceRay(const Frame& f, const std::vector<Cand>& cands, const Ray& ray,
                            double background) {
  const double c = ray.c, s = ray.s;
  const double wx = f.ct * c - f.st * s, wy = f.st * c + f.ct * s;
  const double to_bin = kBins / (2.0 * M_PI);
  const unsigned bin =
      static_cast<unsigned>((static_cast<double>(ray.phi) + f.theta_off) * to_bin) & (kBins - 1);
  const double ps = ray.ps, pz = ray.pz, ds = ray.ds, dz = ray.dz;
  const double kz = ds > 0.0 ? dz / ds : (dz >= 0 ? 1e300 : -1e300);
  double best = std::numeric_limits<double>::infinity();
  TraceResult res{background, -1, 0.0, wx, wy, 0.0};
  const int* it = f.bin_items.data() + f.bin_start[bin];
  const int* end = f.bin_items.data() + f.bin_start[bin + 1];
  for (; it != end; ++it) {
    const Cand& q = cands[static_cast<size_t>(*it)];
    if (q.type == 0) {
      const double cw = wx * q.e1 - wy * q.e0;
      // The ray P + e (-wy, wx) + r (wx, wy) meets the wall's line A + lam E.
      const double r = kMiss ? (q.h + ray.e * (wx * q.e0 + wy * q.e1)) / cw : q.h / cw;
      const double key = r + q.bias;
      if (!(r > ps) || !(key < best)) continue;
      const double lam = kMiss ? (q.a0 * wy - q.a1 * wx + ray.e) / cw : (q.a0 * wy - q.a1 * wx) / cw;
      if (lam < 0.0 || lam > 1.0) continue;
      const double z = pz + (r - ps) * kz;
      if (!(z >= q.zlo && z <= q.zhi)) continue;
      best = key;
      res.shade = q.shade;
      res.id = q.id;
      res.r = r;
      res.z = z;
    } else {
      const double dzr = q.zlo - pz;
      if (!(dzr * dz > 0.0)) continue;
      const double r = ps + dzr * ds / dz;
      const double key = r + q.bias;
      if (!(key < best)) continue;
      double x = r * wx - q.a0, y = r * wy - q.a1;
      if (kMiss) {
        x -= ray.e * wy;
        y += ray.e * wx;
      }
      const double al = q.e0 * x + q.e1 * y, be = q.u0 * x + q.u1 * y;
      if (al < 0.0 || al > 1.0 || be < 0.0 || be > 1.0) continue;
      best = key;
      res.shade = q.shade;
      res.id = q.id;
      res.r = r;
      res.z = q.zlo;
    }
  }
  return res;
}

}  // namespace

cv::Mat Renderer::Render(const Pose2& pose, int frame_index) const {
  const Sensor& sensor = table_.sensor();
  cv::Mat img(sensor.image_height, sensor.image_width, CV_32FC1, cv::Scalar(0));
  Accumulate(pose, 1.0, {}, false, &img);
  return FinishImage(img, options_, frame_index, options_.noise_sigma > 0.0 ? MirrorMask() : cv::Mat());
}

cv::Mat Renderer::MirrorMask() const {
  const Sensor& sensor = table_.sensor();
  const int W = sensor.image_width, Hh = sensor.image_height;
  const auto& starts = table_.starts();
  cv::Mat mask(Hh, W, CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < Hh; ++v)
    for (int u = 0; u < W; ++u)
      if (starts[static_cast<size_t>(v) * W + u + 1] > starts[static_cast<size_t>(v) * W + u])
        mask.at<uint8_t>(v, u) = 255;
  return mask;
}

void Renderer::Accumulate(const Pose2& pose, double gain, const std::vector<Surface>& extra,
                          bool one_ray, cv::Mat* sum) const {
  Frame f;
  BuildFrame(pose, extra, &f);
  const RayTable& table = one_ray ? centre_table_ : table_;
  const Sensor& sensor = table.sensor();
  const int W = sensor.image_width, Hh = sensor.image_height;
  if (sum->rows != Hh || sum->cols != W || sum->type() != CV_32FC1)
    throw Error("renderer: the sum image must be CV_32FC1 of the sensor's size");
  f.gain *= gain;
  const auto& rays = table.rays();
  const auto& starts = table.starts();
  const float inv_n = 1.0f / static_cast<float>(table.supersample() * table.supersample());
  const bool gradient = options_.gradient > 0.0;
  const bool texture = options_.texture > 0.0;
  const bool generic = !f.generic.empty();
  const bool miss = table.max_axis_miss() > 0.0;
  const double H = sensor_height_;
  // The loop compiled twice, for rays that miss the axis (a rig with faults)
  // and for meridian rays, so that the aligned loop has no offset terms.
  auto trace_rows = [&](auto miss_tag) {
    constexpr bool kMiss = decltype(miss_tag)::value;
    // Rows in parallel; an exception leaves the loop.
    ParallelFor(Hh, [&](int v) {
      float* row = sum->ptr<float>(v);
      for (int u = 0; u < W; ++u) {
        const int b = starts[static_cast<size_t>(v) * W + u], e = starts[static_cast<size_t>(v) * W + u + 1];
        if (b == e) continue;
        float acc = 0.0f;
        for (int k = b; k < e; ++k) {
          const RayTable::Ray& ray = rays[static_cast<size_t>(k)];
          TraceResult t = TraceRay<kMiss>(f, f.cands, ray, options_.background);
          // The hit's horizontal offset across the ray's azimuth (0 when aligned).
          const double ex = kMiss ? -ray.e * t.wy : 0.0, ey = kMiss ? ray.e * t.wx : 0.0;
          if (generic) {
            const Eigen::Vector3d o(pose.x + ray.ps * t.wx + ex, pose.y + ray.ps * t.wy + ey, H + ray.pz);
            const Eigen::Vector3d d(ray.ds * t.wx, ray.ds * t.wy, ray.dz);
            const double max_t = t.id >= 0 && ray.ds > 0 ? (t.r - ray.ps) / ray.ds : std::numeric_limits<double>::infinity();
            const RayHit h = scene_.Intersect(o, d, max_t);
            if (h.hit()) {
              t.shade = h.shade;
              t.id = h.surface;
              t.r = ray.ps + h.t * ray.ds;
              t.z = ray.pz + h.t * ray.dz;
            }
          }
          double val = t.shade * f.gain;
          if (gradient && t.id >= 0) {
            const double x = pose.x + t.r * t.wx + ex, y = pose.y + t.r * t.wy + ey;
            val *= std::max(0.0, 1.0 + f.gx * (x - f.cx) + f.gy * (y - f.cy));
          }
          if (texture && t.id >= 0) {
            const Eigen::Vector3d w(pose.x + t.r * t.wx + ex, pose.y + t.r * t.wy + ey, H + t.z);
            val *= 1.0 + options_.texture * SurfaceTexture(w, texture_wavelength_);
          }
          acc += static_cast<float>(std::clamp(val, 0.0, 1.0));
        }
        row[u] += 255.0f * acc * inv_n;
      }
    }, /*parallel=*/true, options_.num_threads);
  };
  if (miss)
    trace_rows(std::true_type());
  else
    trace_rows(std::false_type());
}

cv::Mat Renderer::SurfaceIds(const Pose2& pose, const std::vector<Surface>& extra) const {
  Frame f;
  BuildFrame(pose, extra, &f);
  const Sensor& sensor = centre_table_.sensor();
  const int W = sensor.image_width, Hh = sensor.image_height;
  cv::Mat ids(Hh, W, CV_32SC1, cv::Scalar(-1));
  const auto& rays = centre_table_.rays();
  const auto& starts = centre_table_.starts();
  const bool miss = centre_table_.max_axis_miss() > 0.0;
  for (int v = 0; v < Hh; ++v) {
    for (int u = 0; u < W; ++u) {
      const int b = starts[static_cast<size_t>(v) * W + u], e = starts[static_cast<size_t>(v) * W + u + 1];
      if (b == e) continue;
      const RayTable::Ray& ray = rays[static_cast<size_t>(b)];
      TraceResult t = miss ? TraceRay<true>(f, f.cands, ray, options_.background)
                           : TraceRay<false>(f, f.cands, ray, options_.background);
      if (!f.generic.empty()) {
        const Eigen::Vector3d o(pose.x + ray.ps * t.wx - ray.e * t.wy, pose.y + ray.ps * t.wy + ray.e * t.wx,
                                sensor_height_ + ray.pz);
        const Eigen::Vector3d d(ray.ds * t.wx, ray.ds * t.wy, ray.dz);
        const double max_t = t.id >= 0 && ray.ds > 0 ? (t.r - ray.ps) / ray.ds : std::numeric_limits<double>::infinity();
        const RayHit h = scene_.Intersect(o, d, max_t);
        if (h.hit()) t.id = h.surface;
      }
      ids.at<int>(v, u) = t.id;
    }
  }
  return ids;
}

cv::Mat FinishImage(const cv::Mat& grey_float, const RenderOptions& options, int frame_index,
                    const cv::Mat& mask) {
  cv::Mat img = grey_float.clone();
  if (options.blur) cv::blur(img, img, cv::Size(3, 3), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  if (options.noise_sigma > 0.0) {
    SplitMix rng{options.seed * 0x9E3779B97F4A7C15ull ^
                 (static_cast<uint64_t>(frame_index) + 0x632BE59BD9B4E019ull) * 0xD1B54A32D192ED03ull};
    for (int i = 0; i < 4; ++i) rng.Next();
    for (int v = 0; v < img.rows; ++v) {
      float* row = img.ptr<float>(v);
      const uint8_t* m = mask.empty() ? nullptr : mask.ptr<uint8_t>(v);
      for (int u = 0; u < img.cols; u += 2) {
        // Box-Muller: two normal deviates per pair of pixels (drawn even when masked, so that
        // the noise at a pixel does not depend on the mask).
        const double r = std::sqrt(-2.0 * std::log(rng.Uniform()));
        const double a = 2.0 * M_PI * rng.Uniform();
        if (!m || m[u]) row[u] += static_cast<float>(options.noise_sigma * r * std::cos(a));
        if (u + 1 < img.cols && (!m || m[u + 1]))
          row[u + 1] += static_cast<float>(options.noise_sigma * r * std::sin(a));
      }
    }
  }
  cv::Mat out;
  img.convertTo(out, CV_8UC1);  // rounds and saturates
  return out;
}

cv::Mat RenderStill(const Sensor& sensor, const Map& map, const Pose2& pose,
                    const RenderOptions& options) {
  const Scene scene = Scene::FromMap(map, options.distractors);
  Renderer r(sensor, scene, map.sensor_height, options);
  return r.Render(pose, 0);
}

// ---------------------------------------------------------------- corners

std::vector<MapCorner> MapCorners(const Map& map) {
  std::vector<MapCorner> out;
  for (const MapRectangle& r : map.rectangles) {
    const Eigen::Vector3d c[4] = {{r.from.x(), r.from.y(), r.z0},
                                  {r.to.x(), r.to.y(), r.z0},
                                  {r.to.x(), r.to.y(), r.z1},
                                  {r.from.x(), r.from.y(), r.z1}};
    for (int i = 0; i < 4; ++i) out.push_back({r.id + ":" + std::to_string(i), c[i]});
  }
  for (const MapBox& b : map.boxes) {
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d c((i & 1) ? b.max.x() : b.min.x(), (i & 2) ? b.max.y() : b.min.y(),
                              (i & 4) ? b.max.z() : b.min.z());
      out.push_back({b.id + ":" + std::to_string(i), c});
    }
  }
  return out;
}

std::vector<CornerView> VisibleCorners(const Sensor& sensor, const Map& map, const Scene& scene,
                                       const Pose2& pose, double margin_px) {
  std::vector<CornerView> out;
  const double limb = sensor.limb_radius();
  for (const MapCorner& c : MapCorners(map)) {
    const Eigen::Vector3d ps = SensorFromWorld(pose, map.sensor_height, c.world);
    Eigen::Vector2d px;
    if (!sensor.project(ps, &px) || !sensor.inside_image(px, margin_px)) continue;
    double r, az;
    sensor.to_polar(px.x(), px.y(), &r, &az);
    Eigen::Vector3d o, d;
    if (sensor.aligned()) {
      if (r > limb - margin_px) continue;
    } else if (r > 0.0) {
      // The limb of a rig with faults is no circle: the pixel margin_px
      // further out must still see the mirror.
      const Eigen::Vector2d further = sensor.from_polar(r + margin_px, az);
      if (!sensor.backproject(further, &o, &d)) continue;
    }
    if (!sensor.backproject(px, &o, &d)) continue;
    const Eigen::Vector3d ow = WorldFromSensor(pose, map.sensor_height, o);
    if (scene.Occluded(ow, c.world, 1e-6 + 1e-9 * (c.world - ow).norm())) continue;
    out.push_back({c, px, std::atan2(ps.y(), ps.x())});
  }
  return out;
}

}  // namespace pano

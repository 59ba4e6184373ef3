#include "panotrack/scene/scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "panotrack/core/error.h"

namespace pano {

const char* SurfaceKindName(SurfaceKind k) {
  switch (k) {
    case SurfaceKind::kWall: return "wall";
    case SurfaceKind::kFloor: return "floor";
    case SurfaceKind::kCeiling: return "ceiling";
    case SurfaceKind::kRectangle: return "rectangle";
    case SurfaceKind::kBoxFace: return "box";
    case SurfaceKind::kDistractor: return "distractor";
  }
  return "?";
}

namespace {

// Tie rule: an object within this distance behind a background surface still
// wins (posters mounted flat on a wall).
constexpr double kBackgroundBias = 1e-4;

Surface VerticalRect(const Eigen::Vector2d& from, const Eigen::Vector2d& to, double z0, double z1,
                     double shade, SurfaceKind kind, const std::string& name) {
  Surface s;
  s.corner = {from.x(), from.y(), z0};
  s.edge_a = {to.x() - from.x(), to.y() - from.y(), 0.0};
  s.edge_b = {0.0, 0.0, z1 - z0};
  s.shade = shade;
  s.kind = kind;
  s.name = name;
  return s;
}

Surface HorizontalRect(const Eigen::Vector2d& mn, const Eigen::Vector2d& mx, double z,
                       double shade, SurfaceKind kind, const std::string& name) {
  Surface s;
  s.corner = {mn.x(), mn.y(), z};
  s.edge_a = {mx.x() - mn.x(), 0.0, 0.0};
  s.edge_b = {0.0, mx.y() - mn.y(), 0.0};
  s.shade = shade;
  s.kind = kind;
  s.name = name;
  return s;
}

}  // namespace

Scene Scene::FromMap(const Map& map, bool with_distractors) {
  Scene sc;
  if (map.room.present) {
    const MapRoom& r = map.room;
    const Eigen::Vector2d a = r.min, c = r.max;
    const Eigen::Vector2d b(c.x(), a.y()), d(a.x(), c.y());
    sc.Add(HorizontalRect(a, c, 0.0, r.floor_shade, SurfaceKind::kFloor, "room:floor"));
    sc.Add(HorizontalRect(a, c, r.height, r.ceiling_shade, SurfaceKind::kCeiling, "room:ceiling"));
    sc.Add(VerticalRect(a, b, 0.0, r.height, r.wall_shade, SurfaceKind::kWall, "room:wall-y-min"));
    sc.Add(VerticalRect(b, c, 0.0, r.height, r.wall_shade, SurfaceKind::kWall, "room:wall-x-max"));
    sc.Add(VerticalRect(c, d, 0.0, r.height, r.wall_shade, SurfaceKind::kWall, "room:wall-y-max"));
    sc.Add(VerticalRect(d, a, 0.0, r.height, r.wall_shade, SurfaceKind::kWall, "room:wall-x-min"));
  }
  for (const MapRectangle& r : map.rectangles)
    sc.Add(VerticalRect(r.from, r.to, r.z0, r.z1, r.shade, SurfaceKind::kRectangle, r.id));
  for (const MapBox& b : map.boxes) {
    const Eigen::Vector3d& lo = b.min;
    const Eigen::Vector3d& hi = b.max;
    const Eigen::Vector2d p00(lo.x(), lo.y()), p10(hi.x(), lo.y()), p11(hi.x(), hi.y()),
        p01(lo.x(), hi.y());
    const SurfaceKind k = SurfaceKind::kBoxFace;
    sc.Add(VerticalRect(p00, p10, lo.z(), hi.z(), b.shade, k, b.id + ":-y"));
    sc.Add(VerticalRect(p10, p11, lo.z(), hi.z(), b.shade, k, b.id + ":+x"));
    sc.Add(VerticalRect(p11, p01, lo.z(), hi.z(), b.shade, k, b.id + ":+y"));
    sc.Add(VerticalRect(p01, p00, lo.z(), hi.z(), b.shade, k, b.id + ":-x"));
    sc.Add(HorizontalRect(p00, p11, hi.z(), b.shade, k, b.id + ":+z"));
    if (lo.z() > 0.0) sc.Add(HorizontalRect(p00, p11, lo.z(), b.shade, k, b.id + ":-z"));
  }
  if (with_distractors)
    for (const MapRectangle& r : map.distractors)
      sc.Add(VerticalRect(r.from, r.to, r.z0, r.z1, r.shade, SurfaceKind::kDistractor, r.id));
  return sc;
}

int Scene::Add(const Surface& s) {
  const Eigen::Vector3d n = s.edge_a.cross(s.edge_b);
  const double len = n.norm();
  if (!(len > 1e-12) || !std::isfinite(len) || !s.corner.allFinite())
    throw Error("scene: surface '" + s.name + "' is degenerate (zero area or not finite)");
  Plane p;
  p.normal = n / len;
  p.offset = p.normal.dot(s.corner);
  // Dual basis of (edge_a, edge_b) in their plane: ua . edge_a = 1, ua . edge_b = 0.
  const double aa = s.edge_a.squaredNorm(), bb = s.edge_b.squaredNorm(), ab = s.edge_a.dot(s.edge_b);
  const double det = aa * bb - ab * ab;
  p.ua = (bb * s.edge_a - ab * s.edge_b) / det;
  p.ub = (aa * s.edge_b - ab * s.edge_a) / det;
  p.corner = s.corner;
  p.shade = s.shade;
  p.background = s.background();
  const Eigen::Vector3d pts[4] = {s.corner, s.corner + s.edge_a, s.corner + s.edge_b,
                                  s.corner + s.edge_a + s.edge_b};
  for (const Eigen::Vector3d& q : pts) {
    if (surfaces_.empty() && &q == &pts[0]) {
      min_ = max_ = q;
    } else {
      min_ = min_.cwiseMin(q);
      max_ = max_.cwiseMax(q);
    }
  }
  surfaces_.push_back(s);
  planes_.push_back(p);
  return static_cast<int>(surfaces_.size()) - 1;
}

// Inlined into the loops over the surfaces: a call per surface and ray
// costs about as much as the test.
[[gnu::always_inline]] inline bool Scene::HitSurface(int i, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                                     double limit, double* t) const {
  const Plane& p = planes_[static_cast<size_t>(i)];
  const double den = p.normal.dot(d);
  if (den == 0.0) return false;
  const double tt = (p.offset - p.normal.dot(o)) / den;
  // Beyond the limit the caller has no use for the hit: skip the bounds.
  if (!(tt > 0.0) || !(tt < limit)) return false;
  const Eigen::Vector3d q = o + tt * d - p.corner;
  const double a = p.ua.dot(q), b = p.ub.dot(q);
  if (a < 0.0 || a > 1.0 || b < 0.0 || b > 1.0) return false;
  *t = tt;
  return true;
}

RayHit Scene::Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                        double max_t) const {
  RayHit best;
  double best_key = max_t;
  const double bias = kBackgroundBias / std::max(direction.norm(), 1e-300);
  for (int i = 0; i < static_cast<int>(surfaces_.size()); ++i) {
    double t;
    // Only a hit nearer than the best so far can win (a background one
    // still needs its bias), and best_key starts at max_t.
    if (!HitSurface(i, origin, direction, best_key, &t)) continue;
    const Plane& p = planes_[static_cast<size_t>(i)];
    const double key = p.background ? t + bias : t;
    if (key < best_key) {
      best_key = key;
      best.t = t;
      best.surface = i;
      best.shade = p.shade;
    }
  }
  return best;
}

bool Scene::Occluded(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                     double tolerance, double plane_tolerance) const {
  const Eigen::Vector3d d = to - from;
  const double len = d.norm();
  if (!(len > tolerance)) return false;
  const Eigen::Vector3d u = d / len;
  const double max_t = len - tolerance - 1e-9 * len;
  for (int i = 0; i < static_cast<int>(surfaces_.size()); ++i) {
    double t;
    if (!HitSurface(i, from, u, max_t, &t)) continue;
    const Plane& p = planes_[static_cast<size_t>(i)];
    const bool on_it = std::abs(p.normal.dot(to) - p.offset) <= plane_tolerance * p.normal.norm() &&
                       len - t <= 10.0 * plane_tolerance;
    if (!on_it) return true;
  }
  return false;
}

}  // namespace pano

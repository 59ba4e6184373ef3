// Catadioptric sensor model: a pinhole camera on the axis of a convex mirror
// that is a quadric of revolution (sphere, ellipsoid, paraboloid, hyperboloid),
// optionally with even-asphere terms (a real mirror that is not exactly a conic).
//
// Everything here is templated on the scalar T so that ceres::Jet passes
// through (the calibrator differentiates projections by automatic
// differentiation, the reflection solve included).
//
// Frames (the file-format spec, sections 1-2): the sensor frame has
// its origin at the pinhole, z up along the mirror axis. The camera looks up;
//   u - cx = f * x / z,   v - cy = f * aspect * y / z
// so the image azimuth atan2((v-cy)/aspect, u-cx) equals the bearing
// atan2(y, x) (plus azimuth_offset for a camera turned about its axis).
//
// Work is done in the meridian plane through the axis and the point:
// s = horizontal distance from the axis, z = height above the pinhole. A camera
// ray is (s, z) = t (m, 1), where m = tan(angle from the axis) is the
// normalised image radius: image_radius = focal_px * distort(m).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace pano {

// Scalar value of a double, or of a ceres::Jet (anything with a member `a`),
// without making this header depend on Ceres.
inline double ScalarValue(double x) { return x; }
inline double ScalarValue(float x) { return x; }
template <typename T>
auto ScalarValue(const T& x) -> decltype(ScalarValue(x.a)) {
  return ScalarValue(x.a);
}

// Mirror: a quadric of revolution with its vertex (lowest point) on the axis.
// Its profile, with w the height above the vertex:
//   s^2 = 2 R w - (1 + k) w^2
// R = curvature_radius at the vertex, k = conic_constant (0 sphere,
// -1 paraboloid, < -1 hyperboloid, (-1,0) prolate and > 0 oblate ellipsoid).
// A sphere of radius r centred d above the pinhole is R = r, k = 0,
// vertex_distance = d - r.
//
// Even asphere: the conic's sag plus higher-order terms,
//   w(s) = s^2 / (R + sqrt(R^2 - (1+k) s^2)) + R (a4 rho^4 + a6 rho^6),  rho = s / R,
// a4 = asphere_a4, a6 = asphere_a6, dimensionless (a maker's A4 s^4 + A6 s^6
// in lengths is a4 = A4 R^3, a6 = A6 R^5). Relative to R they describe the
// shape alone, so they stay determined when the mirror's scale is not.
// Both zero: the conic, computed in closed form as before.
//
// Unified profile (unified = true): Mei's unified central model instead of a
// mirror, for cameras the pinhole-plus-mirror profiles reach only in a limit
// (a parabolic mirror behind a telecentric lens is xi = 1 with the focal
// length at infinity). A single viewpoint at the sensor frame's origin; a
// direction (x, y, z) with rho = |(x, y, z)| is seen at normalised radius
//   m = D / (xi rho - z),  D = |(x, y)|,
// visible while xi rho > z (xi = 1: the upper half space's horizon at m = 1).
// xi = 0 is a pinhole looking down, 0 < xi < 1 a hyperboloid seen from its
// far focus. The mirror terms (curvature_radius, conic_constant,
// vertex_distance, asphere_a4/a6) are unused and zero; rim_radius, when
// positive, is the rim as a normalised radius m (the edge of the image disc).
template <typename T>
struct SensorParams {
  T focal_px = T(0);
  T cx = T(0);
  T cy = T(0);
  T aspect = T(1);
  T azimuth_offset = T(0);  // image azimuth = bearing + azimuth_offset
  T k1 = T(0);              // lens radial distortion on m: m_d = m (1 + k1 m^2 + k2 m^4)
  T k2 = T(0);
  T curvature_radius = T(0);
  T conic_constant = T(0);
  T vertex_distance = T(0);  // height of the mirror's vertex above the pinhole
  T rim_radius = T(0);       // mirror's physical radius (s at its rim); 0: up to the limb
  T asphere_a4 = T(0);       // even-asphere terms (see above); 0: a conic
  T asphere_a6 = T(0);
  T xi = T(0);           // unified profile: the viewing sphere's offset (see above)
  bool unified = false;  // the unified (central) profile instead of a mirror

  template <typename U>
  SensorParams<U> cast() const {
    SensorParams<U> p;
    p.focal_px = U(ScalarValue(focal_px));
    p.cx = U(ScalarValue(cx));
    p.cy = U(ScalarValue(cy));
    p.aspect = U(ScalarValue(aspect));
    p.azimuth_offset = U(ScalarValue(azimuth_offset));
    p.k1 = U(ScalarValue(k1));
    p.k2 = U(ScalarValue(k2));
    p.curvature_radius = U(ScalarValue(curvature_radius));
    p.conic_constant = U(ScalarValue(conic_constant));
    p.vertex_distance = U(ScalarValue(vertex_distance));
    p.rim_radius = U(ScalarValue(rim_radius));
    p.asphere_a4 = U(ScalarValue(asphere_a4));
    p.asphere_a6 = U(ScalarValue(asphere_a6));
    p.xi = U(ScalarValue(xi));
    p.unified = unified;
    return p;
  }
};

// Sphere of radius r whose centre is d above the pinhole (README, "Files and conventions").
template <typename T>
void SetSphereMirror(SensorParams<T>* p, const T& mirror_radius, const T& mirror_distance) {
  p->curvature_radius = mirror_radius;
  p->conic_constant = T(0);
  p->vertex_distance = mirror_distance - mirror_radius;
}

namespace detail {
// True when x is exactly zero and carries no derivative (a ceres::Jet's or a
// dual number's derivative part is zero too): such a term can be left out of
// the computation without losing derivatives with respect to it.
inline bool IsConstantZero(double x) { return x == 0.0; }
inline bool IsConstantZero(float x) { return x == 0.0f; }
template <typename V>
auto IsConstantZero(const V& v) -> decltype(bool((v.array() == 0).all())) {
  return bool((v.array() == 0).all());
}
template <typename T>
auto IsConstantZero(const T& x) -> decltype(IsConstantZero(x.a) && IsConstantZero(x.v)) {
  return IsConstantZero(x.a) && IsConstantZero(x.v);
}

// The even-asphere profile as a function of u = s^2 (every term is even in s,
// so no square root of s^2 appears and derivatives stay finite on the axis):
// the sag w and sigma = (dw/ds) / s. False outside the conic part's domain
// ((1+k) s^2 < R^2).
template <typename T>
bool AsphereSag(const SensorParams<T>& p, const T& u, T* w, T* sigma) {
  using std::sqrt;
  const T& R = p.curvature_radius;
  const T inner = R * R - (T(1) + p.conic_constant) * u;
  if (!(inner > T(0))) return false;
  const T q = sqrt(inner);
  const T r2 = u / (R * R);  // rho^2
  *w = u / (R + q) + R * r2 * r2 * (p.asphere_a4 + p.asphere_a6 * r2);
  if (sigma) *sigma = T(1) / q + (T(4) * p.asphere_a4 + T(6) * p.asphere_a6 * r2) * r2 / R;
  return true;
}

// d sigma / d u in double (the limb's Newton solve).
inline double AsphereDsigmaDu(const SensorParams<double>& p, double u) {
  const double R = p.curvature_radius;
  const double q = std::sqrt(R * R - (1.0 + p.conic_constant) * u);
  return (1.0 + p.conic_constant) / (2.0 * q * q * q) + (4.0 * p.asphere_a4 + 12.0 * p.asphere_a6 * u / (R * R)) / (R * R * R);
}

// Parameter t of the first hit of the camera ray t (a, b, 1) from the pinhole
// with the even-asphere mirror whose axis passes through (dx, dy):
// H(t) = zv + w(u(t)) - t, u(t) = (t a - dx)^2 + (t b - dy)^2, is positive at
// the pinhole and falls through zero at the visible hit. Newton's method from
// the pinhole approaches that first root from below without overshooting it
// on a convex profile; a bracket and bisection guard the rest. False when the
// ray passes beyond the limb.
inline bool AsphereRayHit(const SensorParams<double>& p, double dx, double dy, double a, double b, double* t_out) {
  const double zv = p.vertex_distance;
  double lo = 0.0, hi = std::numeric_limits<double>::infinity();
  double t = 0.0;
  {
    // Start from the conic's hit (closed form), near when the terms are
    // small; the bracket below keeps the iteration safe from either side.
    const double A = a * a + b * b + 1.0 + p.conic_constant;
    const double q = p.curvature_radius - (a * a + b * b) * zv + a * dx + b * dy;
    const double ex = a * zv - dx, ey = b * zv - dy;
    const double C = ex * ex + ey * ey;
    const double disc = q * q - A * C;
    if (disc >= 0.0 && q + std::sqrt(disc) > 0.0) t = zv + C / (q + std::sqrt(disc));
    // Above the surface and rising: maybe past both roots near the limb;
    // start from the pinhole then.
    const double ex0 = t * a - dx, ey0 = t * b - dy;
    double w = 0.0, sigma = 0.0;
    if (!AsphereSag(p, ex0 * ex0 + ey0 * ey0, &w, &sigma) ||
        (zv + w - t > 0.0 && !(sigma * (ex0 * a + ey0 * b) - 1.0 < 0.0)))
      t = 0.0;
  }
  for (int it = 0; it < 200; ++it) {
    const double ex = t * a - dx, ey = t * b - dy;
    double w = 0.0, sigma = 0.0, t_next;
    if (!AsphereSag(p, ex * ex + ey * ey, &w, &sigma)) {
      hi = t;  // beyond the conic's domain: the root, if any, is nearer
      t_next = 0.5 * (lo + hi);
    } else {
      const double H = zv + w - t;
      const double dH = sigma * (ex * a + ey * b) - 1.0;
      if (H > 0.0) lo = t; else hi = t;
      if (H == 0.0) {
        *t_out = t;
        return true;
      }
      t_next = t - H / dH;
      if (!(dH < 0.0) || !(t_next > lo && t_next < hi)) {
        if (!std::isfinite(hi)) return false;  // still above the surface and rising no more: beyond the limb
        t_next = 0.5 * (lo + hi);
      }
    }
    if (std::abs(t_next - t) < 1e-15 * (1.0 + std::abs(t)) || hi - lo < 1e-15 * (1.0 + lo)) {
      *t_out = t_next;
      return true;
    }
    t = t_next;
  }
  return false;
}

// Largest normalised radius s / (zv + w(s)) that sees the even-asphere mirror
// (the limb: zv + w = s w', where L(u) = zv + w - u sigma changes sign) or its
// rim, whichever is nearer the axis; infinity when neither limits.
inline double AsphereMaxNormalizedRadius(const SensorParams<double>& p) {
  const double R = p.curvature_radius, zv = p.vertex_distance, one_k = 1.0 + p.conic_constant;
  auto L = [&](double u, double* val) {
    double w = 0.0, sigma = 0.0;
    if (!AsphereSag(p, u, &w, &sigma)) return false;
    *val = zv + w - u * sigma;
    return true;
  };
  auto phi = [&](double u) {
    double w = 0.0;
    AsphereSag(p, u, &w, static_cast<double*>(nullptr));
    return std::sqrt(u) / (zv + w);
  };
  // The visible part ends at the rim, or at the conic's domain edge (where
  // the slope is infinite), or nowhere (a hyperboloid without a rim).
  double u_end = one_k > 0.0 ? R * R / one_k * (1.0 - 1e-15) : std::numeric_limits<double>::infinity();
  if (p.rim_radius > 0.0) u_end = std::min(u_end, p.rim_radius * p.rim_radius);
  double lo = 0.0, hi = u_end, v = 0.0;
  if (std::isfinite(u_end)) {
    if (L(u_end, &v) && v >= 0.0) return phi(u_end);  // the rim comes before the limb
  } else {
    // Bracket the limb by quadrupling: L(lo) > 0 > L(hi).
    hi = R * R;
    while (L(hi, &v) && v > 0.0 && hi < 1e12 * R * R) {
      lo = hi;
      hi *= 4.0;
    }
    if (!L(hi, &v) || v > 0.0) return std::numeric_limits<double>::infinity();
  }
  // The limb: Newton's method on L(u), safeguarded by the bracket.
  double u = 0.5 * (lo + hi);
  for (int it = 0; it < 200; ++it) {
    if (!L(u, &v)) {
      hi = u;
      u = 0.5 * (lo + hi);
      continue;
    }
    if (v > 0.0) lo = u; else hi = u;
    double w = 0.0, sigma = 0.0;
    AsphereSag(p, u, &w, &sigma);
    const double dL = -0.5 * sigma - u * AsphereDsigmaDu(p, u);
    double u_next = u - v / dL;
    if (!(u_next > lo && u_next < hi)) u_next = 0.5 * (lo + hi);
    const bool done = std::abs(u_next - u) < 1e-16 * u || hi - lo < 1e-16 * hi;
    u = u_next;
    if (done) break;
  }
  const double m_max = phi(u);
  return m_max;
}
}  // namespace detail

// True when the mirror is a plain conic: no even-asphere term, nor any
// derivative with respect to one (a Jet whose asphere terms are free takes the
// asphere path even where they are zero).
template <typename T>
bool IsConicProfile(const SensorParams<T>& p) {
  return detail::IsConstantZero(p.asphere_a4) && detail::IsConstantZero(p.asphere_a6);
}

// Largest normalised image radius m that sees the mirror: the limb (where the
// camera ray grazes the mirror) or the rim, whichever is nearer the axis.
// Infinity when neither limits (a hyperboloid whose asymptotic cone holds the
// pinhole, with no rim given). With asphere terms it is computed in double
// (callers only compare against it).
template <typename T>
T MaxNormalizedRadius(const SensorParams<T>& p) {
  using std::sqrt;
  if (p.unified) {
    // Beyond xi > 1 the viewing sphere's silhouette: m^2 (xi^2 - 1) < 1.
    T m_max = T(std::numeric_limits<double>::infinity());
    if (p.xi > T(1)) m_max = T(1) / sqrt(p.xi * p.xi - T(1));
    if (p.rim_radius > T(0) && p.rim_radius < m_max) m_max = p.rim_radius;
    return m_max;
  }
  if (!IsConicProfile(p)) return T(detail::AsphereMaxNormalizedRadius(p.template cast<double>()));
  const T& R = p.curvature_radius;
  const T& zv = p.vertex_distance;
  const T one_k = T(1) + p.conic_constant;
  // disc(m) = R^2 - m^2 (2 R zv + (1+k) zv^2) of the ray/profile quadratic.
  const T denom = zv * (T(2) * R + one_k * zv);
  T m_max = T(std::numeric_limits<double>::infinity());
  if (denom > T(0)) m_max = R / sqrt(denom);
  if (p.rim_radius > T(0)) {
    const T& sr = p.rim_radius;
    const T inner = R * R - one_k * sr * sr;
    if (inner >= T(0)) {
      const T w_rim = sr * sr / (R + sqrt(inner));
      const T m_rim = sr / (zv + w_rim);
      if (m_rim < m_max) m_max = m_rim;
    }
  }
  return m_max;
}

namespace detail {
// Outward normal (not unit) of an even asphere at distance s from its axis:
// the gradient of w(s) - w, (s sigma, -1).
template <typename T>
bool AsphereNormal(const SensorParams<T>& p, const T& s, T* ns, T* nz) {
  T w, sigma;
  if (!AsphereSag(p, s * s, &w, &sigma)) return false;
  *ns = s * sigma;
  *nz = T(-1);
  return true;
}

// MirrorHit for an even asphere (kept out of the conic's inlined path).
template <typename T>
bool AsphereMirrorHit(const SensorParams<T>& p, const T& m, T* s, T* z) {
  // Even asphere: the hit in double, then one Newton step in T so that Jet
  // derivatives follow the implicit function theorem.
  const SensorParams<double> pd = p.template cast<double>();
  const double md = ScalarValue(m);
  double t0;
  if (!detail::AsphereRayHit(pd, 0.0, 0.0, md, 0.0, &t0)) return false;
  T t = T(t0);
  if constexpr (!std::is_same<T, double>::value) {
    double wd = 0.0, sigma_d = 0.0;
    if (!detail::AsphereSag(pd, t0 * t0 * md * md, &wd, &sigma_d)) return false;
    const double dH = sigma_d * t0 * md * md - 1.0;
    const T st = T(t0) * m;
    T w;
    if (!detail::AsphereSag(p, st * st, &w, static_cast<T*>(nullptr))) return false;
    t = T(t0) - (p.vertex_distance + w - T(t0)) / T(dH);
  }
  *s = t * m;
  *z = t;
  return true;
}
}  // namespace detail

// Unified profile: the lift of a point at squared normalised radius m2 onto
// the viewing sphere: the point (lambda m, xi - lambda) in the meridian plane
// is the unit direction it sees.
template <typename T>
bool UnifiedLift(const SensorParams<T>& p, const T& m2, T* lambda) {
  using std::sqrt;
  const T under = T(1) + (T(1) - p.xi * p.xi) * m2;
  if (!(under >= T(0))) return false;
  *lambda = (p.xi + sqrt(under)) / (T(1) + m2);
  return true;
}

// Unified profile: the unit direction (ds, dz) seen at normalised radius m
// (meridian plane).
template <typename T>
bool UnifiedDirection(const SensorParams<T>& p, const T& m, T* ds, T* dz) {
  T lambda;
  if (!UnifiedLift(p, m * m, &lambda)) return false;
  *ds = lambda * m;
  *dz = p.xi - lambda;
  return true;
}

// Unified profile: whether the point at horizontal distance D and height Z
// is seen, decided in double so that a Jet and a double agree at the edge of
// the view (a Jet divides through the reciprocal, an ulp away): in front of
// the lift (xi rho > Z), on the viewing sphere's near side beyond xi = 1
// (xi Z < rho; its silhouette is where m reaches 1 / sqrt(xi^2 - 1)) and
// within the rim.
inline bool UnifiedSees(const SensorParams<double>& p, double D, double Z) {
  const double rho = std::sqrt(D * D + Z * Z);
  const double den = p.xi * rho - Z;
  return den > 0.0 && p.xi * Z < rho && D / den < MaxNormalizedRadius(p);
}

// Unified profile: the normalised radius that sees the point at horizontal
// distance D and height Z; false where it is not visible.
template <typename T>
bool UnifiedRadius(const SensorParams<T>& p, const T& D, const T& Z, T* m) {
  using std::sqrt;
  if (!UnifiedSees(p.template cast<double>(), ScalarValue(D), ScalarValue(Z))) return false;
  *m = D / (p.xi * sqrt(D * D + Z * Z) - Z);
  return true;
}

// Camera ray t (m, 1) against the mirror: the first hit, from below.
// Returns false when the ray misses (beyond the limb).
template <typename T>
bool MirrorHit(const SensorParams<T>& p, const T& m, T* s, T* z) {
  using std::sqrt;
  if (p.unified) {  // the single viewpoint
    *s = T(0);
    *z = T(0);
    return m < MaxNormalizedRadius(p);
  }
  if (!IsConicProfile(p)) return detail::AsphereMirrorHit(p, m, s, z);
  const T& R = p.curvature_radius;
  const T& zv = p.vertex_distance;
  const T m2 = m * m;
  // With w = t - zv: (m^2 + 1 + k) w^2 - 2 (R - m^2 zv) w + m^2 zv^2 = 0.
  const T A = m2 + T(1) + p.conic_constant;
  const T q = R - m2 * zv;
  const T C = m2 * zv * zv;
  const T disc = q * q - A * C;
  if (disc < T(0)) return false;
  const T den = q + sqrt(disc);
  if (!(den > T(0))) return false;
  const T w = C / den;  // stable form of the smaller root
  const T t = zv + w;
  *s = t * m;
  *z = t;
  return true;
}

// Reflection in the meridian plane of the camera ray of normalised radius m:
// the point on the mirror (ps, pz) and the reflected unit direction (ds, dz).
template <typename T>
bool ReflectMeridian(const SensorParams<T>& p, const T& m, T* ps, T* pz, T* ds, T* dz) {
  using std::sqrt;
  if (p.unified) {
    // Every ray leaves the single viewpoint.
    *ps = T(0);
    *pz = T(0);
    return UnifiedDirection(p, m, ds, dz);
  }
  if (!MirrorHit(p, m, ps, pz)) return false;
  T ns, nz;
  if (IsConicProfile(p)) {
    const T w = *pz - p.vertex_distance;
    // Outward (downward-facing) normal: gradient of s^2 - 2 R w + (1+k) w^2.
    ns = *ps;
    nz = (T(1) + p.conic_constant) * w - p.curvature_radius;
  } else if (!detail::AsphereNormal(p, *ps, &ns, &nz)) {
    return false;
  }
  const T nn = sqrt(ns * ns + nz * nz);
  ns /= nn;
  nz /= nn;
  const T vn_len = sqrt(m * m + T(1));
  const T vs = m / vn_len, vz = T(1) / vn_len;
  const T dot = vs * ns + vz * nz;
  *ds = vs - T(2) * dot * ns;
  *dz = vz - T(2) * dot * nz;
  return true;
}

// Lens distortion on the normalised radius.
template <typename T>
T DistortRadius(const SensorParams<T>& p, const T& m) {
  const T m2 = m * m;
  return m * (T(1) + p.k1 * m2 + p.k2 * m2 * m2);
}

// Inverse of DistortRadius by Newton's method (monotone for sensible k1, k2).
template <typename T>
bool UndistortRadius(const SensorParams<T>& p, const T& md, T* m) {
  using std::abs;
  T x = md;
  for (int i = 0; i < 30; ++i) {
    const T x2 = x * x;
    const T f = x * (T(1) + p.k1 * x2 + p.k2 * x2 * x2) - md;
    const T df = T(1) + T(3) * p.k1 * x2 + T(5) * p.k2 * x2 * x2;
    if (!(df > T(0))) return false;
    const T step = f / df;
    x -= step;
    if (abs(ScalarValue(step)) < 1e-15 * (1.0 + abs(ScalarValue(x)))) {
      // One more step so that Jet derivatives are those of the converged root.
      const T x2b = x * x;
      x -= (x * (T(1) + p.k1 * x2b + p.k2 * x2b * x2b) - md) /
           (T(1) + T(3) * p.k1 * x2b + T(5) * p.k2 * x2b * x2b);
      *m = x;
      return true;
    }
  }
  return false;
}

namespace detail {
// Signed distance-like residual of the meridian solve: cross product of the
// reflected direction with the vector from the mirror point to the target.
// Positive while the target lies above the reflected ray; it falls through
// zero as m grows (the reflected ray turns upwards).
template <typename T>
bool MeridianResidual(const SensorParams<T>& p, const T& m, const T& D, const T& Z, T* g,
                      T* along) {
  T ps, pz, ds, dz;
  if (!ReflectMeridian(p, m, &ps, &pz, &ds, &dz)) return false;
  const T qs = D - ps, qz = Z - pz;
  *g = ds * qz - dz * qs;
  if (along) *along = ds * qs + dz * qz;
  return true;
}

// Forward-mode dual number (value a, derivative v): the meridian residual's
// exact slope in m for the Newton solve, without a finite difference that
// would step off the mirror near its limb.
struct Dual {
  double a = 0.0, v = 0.0;
  Dual() = default;
  Dual(double value, double slope = 0.0) : a(value), v(slope) {}
  Dual& operator/=(const Dual& o) { return *this = Dual(a / o.a, (v * o.a - a * o.v) / (o.a * o.a)); }
};
inline Dual operator+(const Dual& x, const Dual& y) { return {x.a + y.a, x.v + y.v}; }
inline Dual operator-(const Dual& x, const Dual& y) { return {x.a - y.a, x.v - y.v}; }
inline Dual operator-(const Dual& x) { return {-x.a, -x.v}; }
inline Dual operator*(const Dual& x, const Dual& y) { return {x.a * y.a, x.v * y.a + x.a * y.v}; }
inline Dual operator/(const Dual& x, const Dual& y) { return {x.a / y.a, (x.v * y.a - x.a * y.v) / (y.a * y.a)}; }
inline bool operator<(const Dual& x, const Dual& y) { return x.a < y.a; }
inline bool operator>(const Dual& x, const Dual& y) { return x.a > y.a; }
inline bool operator>=(const Dual& x, const Dual& y) { return x.a >= y.a; }
inline bool operator<=(const Dual& x, const Dual& y) { return x.a <= y.a; }
inline Dual sqrt(const Dual& x) {
  const double r = std::sqrt(x.a);
  return {r, x.v / (2.0 * r)};
}

// The meridian residual g(m) and its slope dg/dm. False where g is undefined.
inline bool MeridianResidualSlope(const SensorParams<Dual>& pd, double m, double D, double Z, double* g,
                                  double* slope) {
  Dual gd;
  if (!MeridianResidual(pd, Dual(m, 1.0), Dual(D), Dual(Z), &gd, static_cast<Dual*>(nullptr))) return false;
  *g = gd.a;
  *slope = gd.v;
  return std::isfinite(gd.v) && gd.v != 0.0;
}

// Root of the meridian residual in double precision: bracketing bisection
// safeguarding Newton steps (exact slope from a dual number).
// Returns false when the point is not visible.
inline bool SolveMeridianDouble(const SensorParams<double>& p, double D, double Z, double* m_out) {
  if (!(D > 0.0) || !std::isfinite(D) || !std::isfinite(Z)) return false;
  if (p.unified) return UnifiedRadius(p, D, Z, m_out);
  const double m_max = MaxNormalizedRadius(p);
  double lo = 0.0;
  double hi = std::isfinite(m_max) ? m_max * (1.0 - 1e-12) : 1e3;
  double g_lo, g_hi;
  if (!MeridianResidual(p, lo, D, Z, &g_lo, static_cast<double*>(nullptr))) return false;
  if (!MeridianResidual(p, hi, D, Z, &g_hi, static_cast<double*>(nullptr))) return false;
  if (!(g_lo > 0.0) || !(g_hi < 0.0)) return false;  // outside the visible cap
  double m = 0.5 * (lo + hi);
  const SensorParams<Dual> pd = p.cast<Dual>();
  for (int it = 0; it < 200; ++it) {
    double g, slope;
    double m_next;
    if (MeridianResidualSlope(pd, m, D, Z, &g, &slope)) {
      if (g > 0.0) lo = m; else hi = m;
      m_next = m - g / slope;
      // Converged: the Newton step may land on the bracket's end it just set.
      if (std::abs(m_next - m) < 1e-15 * (1.0 + m)) {
        m = m_next;
        break;
      }
      if (!(m_next > lo && m_next < hi)) m_next = 0.5 * (lo + hi);
    } else {
      if (!MeridianResidual(p, m, D, Z, &g, static_cast<double*>(nullptr))) return false;
      if (g > 0.0) lo = m; else hi = m;
      m_next = 0.5 * (lo + hi);
    }
    const double step = std::abs(m_next - m);
    m = m_next;
    if (step < 1e-15 * (1.0 + m) || hi - lo < 1e-16) break;
  }
  double along;
  double g;
  if (!MeridianResidual(p, m, D, Z, &g, &along)) return false;
  if (!(along > 0.0)) return false;  // the point is behind the reflected ray
  *m_out = m;
  return true;
}
}  // namespace detail

// Normalised radius m of the camera ray that sees the point at horizontal
// distance D and height Z (sensor frame) in the mirror. Solves the 1-D
// reflection problem (Alhazen's problem for the sphere) in double, then takes
// one Newton step in T so that Jet derivatives follow the implicit function
// theorem exactly.
template <typename T>
bool SolveMeridian(const SensorParams<T>& p, const T& D, const T& Z, T* m) {
  if (p.unified) return UnifiedRadius(p, D, Z, m);
  const SensorParams<double> pd = p.template cast<double>();
  double m0;
  if (!detail::SolveMeridianDouble(pd, ScalarValue(D), ScalarValue(Z), &m0)) return false;
  if constexpr (std::is_same<T, double>::value) {
    *m = m0;
  } else {
    double g0, dg_dm;
    if (!detail::MeridianResidualSlope(pd.template cast<detail::Dual>(), m0, ScalarValue(D), ScalarValue(Z),
                                       &g0, &dg_dm))
      return false;
    T g;
    if (!detail::MeridianResidual(p, T(m0), D, Z, &g, static_cast<T*>(nullptr))) return false;
    *m = T(m0) - g / T(dg_dm);
  }
  return true;
}

// E(D, Z): image radius (in u pixels, aspect removed) of a point at
// horizontal distance D from the axis and height Z above the pinhole.
template <typename T>
bool ImageRadius(const SensorParams<T>& p, const T& D, const T& Z, T* radius) {
  T m;
  if (!SolveMeridian(p, D, Z, &m)) return false;
  *radius = p.focal_px * DistortRadius(p, m);
  return true;
}

// Inverse of E at fixed height: the horizontal distance D at which a point of
// height Z appears at image radius `radius`. Closed form: back-project the
// pixel ray and cut it with the plane z = Z.
template <typename T>
bool InverseImageRadius(const SensorParams<T>& p, const T& radius, const T& Z, T* D) {
  T m;
  if (!UndistortRadius(p, radius / p.focal_px, &m)) return false;
  if (!(m >= T(0)) || !(m < MaxNormalizedRadius(p))) return false;
  T ps, pz, ds, dz;
  if (!ReflectMeridian(p, m, &ps, &pz, &ds, &dz)) return false;
  if (dz == T(0)) return false;
  const T t = (Z - pz) / dz;
  if (!(t > T(0))) return false;
  *D = ps + t * ds;
  return *D > T(0);
}

// Projects a point given in the sensor frame to pixel (u, v).
template <typename T>
bool project(const SensorParams<T>& p, const T* point_sensor, T* u, T* v) {
  using std::atan2;
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T& x = point_sensor[0];
  const T& y = point_sensor[1];
  const T& z = point_sensor[2];
  const T D2 = x * x + y * y;
  if (!(D2 > T(0))) return false;  // on the axis: hidden by the camera or the mirror
  const T D = sqrt(D2);
  T radius;
  if (!ImageRadius(p, D, z, &radius)) return false;
  // cos/sin of the image azimuth, bearing + azimuth_offset, without atan2 at
  // the common zero offset.
  const T cb = x / D, sb = y / D;
  const T co = cos(p.azimuth_offset), so = sin(p.azimuth_offset);
  const T ca = cb * co - sb * so;
  const T sa = sb * co + cb * so;
  *u = p.cx + radius * ca;
  *v = p.cy + p.aspect * radius * sa;
  return true;
}

// Back-projects pixel (u, v) to the reflected ray: its origin on the mirror
// and unit direction, both in the sensor frame. Closed form.
template <typename T>
bool backproject(const SensorParams<T>& p, const T& u, const T& v, T* origin, T* direction) {
  using std::atan2;
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T du = u - p.cx;
  const T dv = (v - p.cy) / p.aspect;
  const T radius = sqrt(du * du + dv * dv);
  T m;
  if (!UndistortRadius(p, radius / p.focal_px, &m)) return false;
  if (!(m < MaxNormalizedRadius(p))) return false;
  T ps, pz, ds, dz;
  if (!ReflectMeridian(p, m, &ps, &pz, &ds, &dz)) return false;
  // On the axis the azimuth is undefined; any will do (ps = ds_horizontal = 0).
  T ca = T(1), sa = T(0);
  if (radius > T(0)) {
    ca = du / radius;
    sa = dv / radius;
  }
  const T co = cos(p.azimuth_offset), so = sin(p.azimuth_offset);
  const T cb = ca * co + sa * so;  // bearing = image azimuth - azimuth_offset
  const T sb = sa * co - ca * so;
  origin[0] = ps * cb;
  origin[1] = ps * sb;
  origin[2] = pz;
  direction[0] = ds * cb;
  direction[1] = ds * sb;
  direction[2] = dz;
  return true;
}

// Image radius of the mirror's visible edge (limb or rim) in pixels.
template <typename T>
T LimbRadiusPx(const SensorParams<T>& p) {
  return p.focal_px * DistortRadius(p, MaxNormalizedRadius(p));
}

}  // namespace pano

// General catadioptric model for real, imperfect rigs: the aligned model of
// catadioptric.h (SensorParams) plus the faults of a real build:
//   - the mirror's axis (a sphere's centre) off the pinhole: mirror_offset;
//   - the camera turned relative to the mirror: camera_tilt;
//   - tangential and third-order radial lens distortion: p1, p2, k3 (k1, k2
//     are the aligned model's own);
//   - the pixel grid's shear: skew (cv::omnidir's K(0, 1), pixels);
//   - the mirror's axis tilted from the robot's vertical: sensor_tilt.
// Templated on the scalar T so that ceres::Jet passes through.
//
// Frames, all with their origin at the pinhole:
//   robot frame R: the frame every caller uses (catadioptric.h's "sensor
//     frame"): z up (the robot's vertical), x along bearing 0;
//   mirror frame M: p_R = Rt(sensor_tilt) p_M. z is parallel to the mirror's
//     axis, which passes through (mirror_offset[0], mirror_offset[1], z);
//   camera frame C: p_M = Rt(camera_tilt) p_C; the pinhole model of
//     catadioptric.h holds in C.
// Rt(a) = Ry(a[1]) Rx(a[0]): a rotation about x by a[0], then about y by
// a[1] (radians).
//
// Pixel of a camera-frame direction (x, y, z):
//   (xi, yi) = rotate((x / z, y / z), azimuth_offset)
//   r2 = xi^2 + yi^2,  radial = 1 + k1 r2 + k2 r2^2 + k3 r2^3
//   xd = xi radial + 2 p1 xi yi + p2 (r2 + 2 xi^2)
//   yd = yi radial + p1 (r2 + 2 yi^2) + 2 p2 xi yi
//   u = cx + focal_px xd + skew yd,  v = cy + focal_px aspect yd
// With every fault zero this is catadioptric.h's model exactly.
//
// Projection solves the law of reflection in 3-D: the camera ray direction
// (a, b, 1) in M such that the ray reflected where it meets the mirror passes
// through the point (Gauss-Newton on the 2 unknowns, started from the aligned
// meridian solution about the decentred axis). Back-projection is closed form
// apart from the lens undistortion (Newton).
#pragma once

#include <algorithm>
#include <cmath>
#include <type_traits>

#include "panotrack/sensor/catadioptric.h"

namespace pano {

template <typename T>
struct RigFaults {
  T mirror_offset[2] = {T(0), T(0)};  // mirror axis (sphere centre) off the pinhole, in M (map units)
  T camera_tilt[2] = {T(0), T(0)};    // C relative to M, radians (about x, then y)
  T p1 = T(0);                        // Brown tangential distortion
  T p2 = T(0);
  T k3 = T(0);                        // Brown radial, r^6 term
  T sensor_tilt[2] = {T(0), T(0)};    // M relative to the robot frame, radians (about x, then y)
  T skew = T(0);                      // pixel grid shear: u gains skew * yd (pixels)

  // True when every fault is exactly zero (compared on the scalar value).
  bool IsZero() const {
    const T* v[] = {&mirror_offset[0], &mirror_offset[1], &camera_tilt[0], &camera_tilt[1], &p1, &p2, &k3,
                    &sensor_tilt[0], &sensor_tilt[1], &skew};
    for (const T* x : v)
      if (ScalarValue(*x) != 0.0) return false;
    return true;
  }

  template <typename U>
  RigFaults<U> cast() const {
    RigFaults<U> f;
    for (int i = 0; i < 2; ++i) {
      f.mirror_offset[i] = U(ScalarValue(mirror_offset[i]));
      f.camera_tilt[i] = U(ScalarValue(camera_tilt[i]));
      f.sensor_tilt[i] = U(ScalarValue(sensor_tilt[i]));
    }
    f.p1 = U(ScalarValue(p1));
    f.p2 = U(ScalarValue(p2));
    f.k3 = U(ScalarValue(k3));
    f.skew = U(ScalarValue(skew));
    return f;
  }
};

template <typename T>
struct GeneralSensorParams {
  SensorParams<T> aligned;
  RigFaults<T> faults;

  // All faults zero: catadioptric.h's functions give the same results, faster.
  bool IsAligned() const { return faults.IsZero(); }

  template <typename U>
  GeneralSensorParams<U> cast() const {
    GeneralSensorParams<U> g;
    g.aligned = aligned.template cast<U>();
    g.faults = faults.template cast<U>();
    return g;
  }
};

namespace detail {

// Row-major 3 x 3 rotation Ry(a[1]) Rx(a[0]).
template <typename T>
void TiltRotation(const T* a, T* R) {
  using std::cos;
  using std::sin;
  const T cx = cos(a[0]), sx = sin(a[0]), cy = cos(a[1]), sy = sin(a[1]);
  // Rx = [1 0 0; 0 cx -sx; 0 sx cx], Ry = [cy 0 sy; 0 1 0; -sy 0 cy].
  R[0] = cy;  R[1] = sy * sx;  R[2] = sy * cx;
  R[3] = T(0); R[4] = cx;      R[5] = -sx;
  R[6] = -sy; R[7] = cy * sx;  R[8] = cy * cx;
}

template <typename T>
void rotate(const T* R, const T* x, T* y) {
  for (int i = 0; i < 3; ++i) y[i] = R[3 * i] * x[0] + R[3 * i + 1] * x[1] + R[3 * i + 2] * x[2];
}

template <typename T>
void RotateTransposed(const T* R, const T* x, T* y) {
  for (int i = 0; i < 3; ++i) y[i] = R[i] * x[0] + R[3 + i] * x[1] + R[6 + i] * x[2];
}

// Camera ray t (a, b, 1) from the pinhole (M frame) against the decentred
// mirror: the first hit Q. False when it misses (beyond the limb) or meets the
// mirror outside its rim.
template <typename T>
bool GeneralMirrorHit(const SensorParams<T>& p, const T& dx, const T& dy, const T& a, const T& b, T* Q) {
  using std::sqrt;
  // The hit at ray parameter t, if it lies within the mirror's rim.
  const auto hit_at = [&](const T& t) {
    Q[0] = t * a;
    Q[1] = t * b;
    Q[2] = t;
    if (!(p.rim_radius > T(0))) return true;
    const T sx = Q[0] - dx, sy = Q[1] - dy;
    return !(sx * sx + sy * sy > p.rim_radius * p.rim_radius);
  };
  if (!IsConicProfile(p)) {
    // Even asphere: the hit in double, then one Newton step in T on
    // H(t) = zv + w(u(t)) - t (Jet derivatives by the implicit function theorem).
    const SensorParams<double> pd = p.template cast<double>();
    const double ad = ScalarValue(a), bd = ScalarValue(b), dxd = ScalarValue(dx), dyd = ScalarValue(dy);
    double t0;
    if (!AsphereRayHit(pd, dxd, dyd, ad, bd, &t0)) return false;
    T t = T(t0);
    if constexpr (!std::is_same<T, double>::value) {
      const double exd = t0 * ad - dxd, eyd = t0 * bd - dyd;
      double wd = 0.0, sigma_d = 0.0;
      if (!AsphereSag(pd, exd * exd + eyd * eyd, &wd, &sigma_d)) return false;
      const double dH = sigma_d * (exd * ad + eyd * bd) - 1.0;
      const T ex = T(t0) * a - dx, ey = T(t0) * b - dy;
      T w;
      if (!AsphereSag(p, ex * ex + ey * ey, &w, static_cast<T*>(nullptr))) return false;
      t = T(t0) - (p.vertex_distance + w - T(t0)) / T(dH);
    }
    return hit_at(t);
  }
  const T& R = p.curvature_radius;
  const T& zv = p.vertex_distance;
  const T m2 = a * a + b * b;
  // With w = t - zv: A w^2 - 2 q w + C = 0 (C: squared distance of the ray
  // from the axis at the vertex's height).
  const T A = m2 + T(1) + p.conic_constant;
  const T q = R - m2 * zv + a * dx + b * dy;
  const T ex = a * zv - dx, ey = b * zv - dy;
  const T C = ex * ex + ey * ey;
  const T disc = q * q - A * C;
  if (disc < T(0)) return false;
  const T den = q + sqrt(disc);
  if (!(den > T(0))) return false;
  return hit_at(zv + C / den);  // stable form of the smaller root
}

// Hit and reflected unit direction r of the camera ray (a, b, 1), M frame.
template <typename T>
bool GeneralReflect(const SensorParams<T>& p, const T& dx, const T& dy, const T& a, const T& b, T* Q, T* r) {
  using std::sqrt;
  if (!GeneralMirrorHit(p, dx, dy, a, b, Q)) return false;
  // Outward (downward-facing) normal: gradient of s^2 - 2 R w + (1+k) w^2,
  // or of w(s) - w for an even asphere.
  T n[3] = {Q[0] - dx, Q[1] - dy, (T(1) + p.conic_constant) * (Q[2] - p.vertex_distance) - p.curvature_radius};
  if (!IsConicProfile(p)) {
    T w, sigma;
    if (!AsphereSag(p, n[0] * n[0] + n[1] * n[1], &w, &sigma)) return false;
    n[0] = n[0] * sigma;
    n[1] = n[1] * sigma;
    n[2] = T(-1);
  }
  const T nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  const T vl = sqrt(a * a + b * b + T(1));
  const T v[3] = {a / vl, b / vl, T(1) / vl};
  const T dot = (v[0] * n[0] + v[1] * n[1] + v[2] * n[2]) / nn;
  for (int i = 0; i < 3; ++i) r[i] = v[i] - T(2) * dot * n[i] / nn;
  return true;
}

// Residual of the reflection solve: r x (X - Q) / |X - Q| (zero when the
// reflected ray passes through X) and the point's distance along the ray.
template <typename T>
bool ReflectionResidual(const SensorParams<T>& p, const T& dx, const T& dy, const T& a, const T& b, const T* X,
                        T* res, T* along) {
  using std::sqrt;
  T Q[3], r[3];
  if (!GeneralReflect(p, dx, dy, a, b, Q, r)) return false;
  const T q[3] = {X[0] - Q[0], X[1] - Q[1], X[2] - Q[2]};
  const T ql = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
  res[0] = (r[1] * q[2] - r[2] * q[1]) / ql;
  res[1] = (r[2] * q[0] - r[0] * q[2]) / ql;
  res[2] = (r[0] * q[1] - r[1] * q[0]) / ql;
  if (along) *along = r[0] * q[0] + r[1] * q[1] + r[2] * q[2];
  return true;
}

// Residual and its 3 x 2 Jacobian in (a, b) (exact, by dual numbers).
inline bool ReflectionResidualJacobian(const SensorParams<Dual>& pd, double dx, double dy, double a, double b,
                                       const double* X, double* res, double* J) {
  const Dual Xd[3] = {Dual(X[0]), Dual(X[1]), Dual(X[2])};
  Dual ra[3], rb[3];
  if (!ReflectionResidual(pd, Dual(dx), Dual(dy), Dual(a, 1.0), Dual(b), Xd, ra, static_cast<Dual*>(nullptr)))
    return false;
  if (!ReflectionResidual(pd, Dual(dx), Dual(dy), Dual(a), Dual(b, 1.0), Xd, rb, static_cast<Dual*>(nullptr)))
    return false;
  for (int i = 0; i < 3; ++i) {
    res[i] = ra[i].a;
    J[2 * i] = ra[i].v;
    J[2 * i + 1] = rb[i].v;
    if (!std::isfinite(J[2 * i]) || !std::isfinite(J[2 * i + 1])) return false;
  }
  return true;
}

// Pseudo-inverse (J^T J)^-1 J^T of a 3 x 2 Jacobian, row-major 2 x 3.
inline bool PseudoInverse3x2(const double* J, double* P) {
  double a = 0, b = 0, c = 0;  // J^T J = [a b; b c]
  for (int i = 0; i < 3; ++i) {
    a += J[2 * i] * J[2 * i];
    b += J[2 * i] * J[2 * i + 1];
    c += J[2 * i + 1] * J[2 * i + 1];
  }
  const double det = a * c - b * b;
  if (!(det > 1e-300) || !std::isfinite(det)) return false;
  for (int i = 0; i < 3; ++i) {
    P[i] = (c * J[2 * i] - b * J[2 * i + 1]) / det;
    P[3 + i] = (-b * J[2 * i] + a * J[2 * i + 1]) / det;
  }
  return true;
}

// The camera ray (a, b, 1), M frame, that sees the M-frame point X: double
// precision. False when the point is not visible.
inline bool SolveReflectionDouble(const SensorParams<double>& p, double dx, double dy, const double* X,
                                  double* a_out, double* b_out) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(X[i])) return false;
  // Start: the aligned solution about the decentred axis, seen from the pinhole.
  const double rx = X[0] - dx, ry = X[1] - dy;
  const double D = std::hypot(rx, ry);
  if (!(D > 0.0)) return false;
  double m0;
  if (!SolveMeridianDouble(p, D, X[2], &m0)) return false;
  double ps, pz;
  if (!MirrorHit(p, m0, &ps, &pz)) return false;
  double a = (ps * rx / D + dx) / pz, b = (ps * ry / D + dy) / pz;
  const SensorParams<Dual> pd = p.cast<Dual>();
  double res[3], J[6];
  if (!ReflectionResidualJacobian(pd, dx, dy, a, b, X, res, J)) return false;
  double cost = res[0] * res[0] + res[1] * res[1] + res[2] * res[2];
  bool converged = false;
  for (int it = 0; it < 60 && !converged; ++it) {
    double P[6];
    if (!PseudoInverse3x2(J, P)) return false;
    const double sa = -(P[0] * res[0] + P[1] * res[1] + P[2] * res[2]);
    const double sb = -(P[3] * res[0] + P[4] * res[1] + P[5] * res[2]);
    // Step halving keeps the iterate on the mirror and the cost falling.
    double scale = 1.0;
    bool moved = false;
    for (int h = 0; h < 40; ++h, scale *= 0.5) {
      const double an = a + scale * sa, bn = b + scale * sb;
      double rn[3], Jn[6];
      if (!ReflectionResidualJacobian(pd, dx, dy, an, bn, X, rn, Jn)) continue;
      const double cn = rn[0] * rn[0] + rn[1] * rn[1] + rn[2] * rn[2];
      if (cn > cost && cn > 1e-28) continue;
      a = an;
      b = bn;
      std::copy(rn, rn + 3, res);
      std::copy(Jn, Jn + 6, J);
      cost = cn;
      moved = true;
      break;
    }
    if (!moved) break;
    if (std::abs(scale * sa) + std::abs(scale * sb) < 1e-15 * (1.0 + std::abs(a) + std::abs(b))) converged = true;
  }
  double along;
  if (!ReflectionResidual(p, dx, dy, a, b, X, res, &along)) return false;
  if (!(along > 0.0)) return false;  // the point is behind the reflected ray
  if (!(res[0] * res[0] + res[1] * res[1] + res[2] * res[2] < 1e-20)) return false;
  *a_out = a;
  *b_out = b;
  return true;
}

// Brown distortion of normalised image coordinates (after the azimuth turn).
template <typename T>
void BrownDistort(const SensorParams<T>& p, const RigFaults<T>& f, const T& x, const T& y, T* xd, T* yd) {
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (p.k1 + r2 * (p.k2 + r2 * f.k3));
  *xd = x * radial + T(2) * f.p1 * x * y + f.p2 * (r2 + T(2) * x * x);
  *yd = y * radial + f.p1 * (r2 + T(2) * y * y) + T(2) * f.p2 * x * y;
}

// Pixel of distorted normalised image coordinates (xd, yd), and back.
template <typename T>
void PixelOfDistorted(const SensorParams<T>& p, const RigFaults<T>& f, const T& xd, const T& yd, T* u, T* v) {
  *u = p.cx + p.focal_px * xd + f.skew * yd;
  *v = p.cy + p.focal_px * p.aspect * yd;
}

template <typename T>
void DistortedOfPixel(const SensorParams<T>& p, const RigFaults<T>& f, const T& u, const T& v, T* xd, T* yd) {
  *yd = (v - p.cy) / (p.focal_px * p.aspect);
  *xd = (u - p.cx - f.skew * *yd) / p.focal_px;
}

// Inverse of BrownDistort by Newton's method in T (one extra step after
// convergence so that Jet derivatives are those of the root).
template <typename T>
bool BrownUndistort(const SensorParams<T>& p, const RigFaults<T>& f, const T& xd, const T& yd, T* x_out,
                    T* y_out) {
  using std::abs;
  T x = xd, y = yd;
  bool converged = false;
  for (int i = 0; i < 40; ++i) {
    const T r2 = x * x + y * y;
    const T radial = T(1) + r2 * (p.k1 + r2 * (p.k2 + r2 * f.k3));
    const T dradial = p.k1 + r2 * (T(2) * p.k2 + T(3) * r2 * f.k3);  // d radial / d r2
    T ex, ey;
    BrownDistort(p, f, x, y, &ex, &ey);
    ex -= xd;
    ey -= yd;
    const T jxx = radial + T(2) * x * x * dradial + T(2) * f.p1 * y + T(6) * f.p2 * x;
    const T jxy = T(2) * x * y * dradial + T(2) * f.p1 * x + T(2) * f.p2 * y;
    const T jyy = radial + T(2) * y * y * dradial + T(6) * f.p1 * y + T(2) * f.p2 * x;
    const T det = jxx * jyy - jxy * jxy;  // the Jacobian is symmetric
    if (!(det > T(0))) return false;
    const T sx = (jyy * ex - jxy * ey) / det, sy = (jxx * ey - jxy * ex) / det;
    x -= sx;
    y -= sy;
    if (converged) {  // the extra step taken after convergence
      *x_out = x;
      *y_out = y;
      return true;
    }
    const double step = abs(ScalarValue(sx)) + abs(ScalarValue(sy));
    converged = step < 1e-15 * (1.0 + abs(ScalarValue(x)) + abs(ScalarValue(y)));
  }
  return false;
}

// The camera ray (a, b, 1), M frame, that sees the M-frame point X through the
// mirror (the 3-D reflection solve in double, then one Gauss-Newton step in
// T: the value stays, Jet derivatives follow the implicit function theorem).
template <typename T>
bool MirrorCameraRay(const SensorParams<T>& p, const RigFaults<T>& f, const T* X, T* ray) {
  const SensorParams<double> pd = p.template cast<double>();
  const double dx = ScalarValue(f.mirror_offset[0]), dy = ScalarValue(f.mirror_offset[1]);
  const double Xd[3] = {ScalarValue(X[0]), ScalarValue(X[1]), ScalarValue(X[2])};
  double a0, b0;
  if (!detail::SolveReflectionDouble(pd, dx, dy, Xd, &a0, &b0)) return false;
  ray[0] = T(a0);
  ray[1] = T(b0);
  ray[2] = T(1);
  if constexpr (!std::is_same<T, double>::value) {
    double res[3], J[6], P[6];
    if (!detail::ReflectionResidualJacobian(pd.template cast<detail::Dual>(), dx, dy, a0, b0, Xd, res, J))
      return false;
    if (!detail::PseudoInverse3x2(J, P)) return false;
    T rt[3];
    if (!detail::ReflectionResidual(p, f.mirror_offset[0], f.mirror_offset[1], T(a0), T(b0), X, rt,
                                    static_cast<T*>(nullptr)))
      return false;
    ray[0] = T(a0) - (T(P[0]) * rt[0] + T(P[1]) * rt[1] + T(P[2]) * rt[2]);
    ray[1] = T(b0) - (T(P[3]) * rt[0] + T(P[4]) * rt[1] + T(P[5]) * rt[2]);
  }
  return true;
}

// The same for the unified profile, closed form: the viewpoint sits at
// mirror_offset (in the mirror frame's z = 0 plane).
template <typename T>
bool UnifiedCameraRay(const SensorParams<T>& p, const RigFaults<T>& f, const T* X, T* ray) {
  using std::sqrt;
  const T x = X[0] - f.mirror_offset[0], y = X[1] - f.mirror_offset[1], z = X[2];
  const double xd = ScalarValue(x), yd = ScalarValue(y);
  if (!UnifiedSees(p.template cast<double>(), std::sqrt(xd * xd + yd * yd), ScalarValue(z))) return false;
  const T den = p.xi * sqrt(x * x + y * y + z * z) - z;
  ray[0] = x / den;
  ray[1] = y / den;
  ray[2] = T(1);
  return true;
}

// Unified profile: the ray of the camera ray (a, b, 1), M frame: its origin
// (the viewpoint, at mirror_offset) and unit direction.
template <typename T>
bool UnifiedBackproject(const SensorParams<T>& p, const RigFaults<T>& f, const T& a, const T& b, T* Q, T* r) {
  const T m2 = a * a + b * b;
  const double m_max = MaxNormalizedRadius(p.template cast<double>());  // in double, as UnifiedSees
  if (!(ScalarValue(m2) < m_max * m_max)) return false;
  T lambda;
  if (!UnifiedLift(p, m2, &lambda)) return false;
  Q[0] = f.mirror_offset[0];
  Q[1] = f.mirror_offset[1];
  Q[2] = T(0);
  r[0] = lambda * a;
  r[1] = lambda * b;
  r[2] = p.xi - lambda;
  return true;
}

}  // namespace detail

// Projects a robot-frame point to pixel (u, v) with the 3-D reflection solve
// (the unified profile: its closed form about the offset viewpoint),
// whatever the faults (use it when faults are free parameters of a fit: the
// derivatives with respect to them exist at zero too).
template <typename T>
bool ProjectGeneral(const GeneralSensorParams<T>& g, const T* point_robot, T* u, T* v) {
  using std::cos;
  using std::sin;
  const SensorParams<T>& p = g.aligned;
  const RigFaults<T>& f = g.faults;
  T Rs[9], Rc[9], X[3];
  detail::TiltRotation(f.sensor_tilt, Rs);
  detail::RotateTransposed(Rs, point_robot, X);
  T ray[3];
  if (p.unified) {
    if (!detail::UnifiedCameraRay(p, f, X, ray)) return false;
  } else if (!detail::MirrorCameraRay(p, f, X, ray)) {
    return false;
  }
  detail::TiltRotation(f.camera_tilt, Rc);
  T c[3];
  detail::RotateTransposed(Rc, ray, c);
  if (!(c[2] > T(0))) return false;
  const T xn = c[0] / c[2], yn = c[1] / c[2];
  const T co = cos(p.azimuth_offset), so = sin(p.azimuth_offset);
  const T xi = xn * co - yn * so, yi = xn * so + yn * co;
  T xd, yd;
  detail::BrownDistort(p, f, xi, yi, &xd, &yd);
  detail::PixelOfDistorted(p, f, xd, yd, u, v);
  return true;
}

// Back-projects pixel (u, v) to the reflected ray, origin on the mirror and
// unit direction, in the robot frame, whatever the faults.
template <typename T>
bool BackprojectGeneral(const GeneralSensorParams<T>& g, const T& u, const T& v, T* origin, T* direction) {
  using std::cos;
  using std::sin;
  const SensorParams<T>& p = g.aligned;
  const RigFaults<T>& f = g.faults;
  T xd, yd, xi, yi;
  detail::DistortedOfPixel(p, f, u, v, &xd, &yd);
  if (!detail::BrownUndistort(p, f, xd, yd, &xi, &yi)) return false;
  const T co = cos(p.azimuth_offset), so = sin(p.azimuth_offset);
  const T c[3] = {xi * co + yi * so, -xi * so + yi * co, T(1)};
  T Rc[9], m[3];
  detail::TiltRotation(f.camera_tilt, Rc);
  detail::rotate(Rc, c, m);
  if (!(m[2] > T(0))) return false;
  T Q[3], r[3];
  if (p.unified) {
    if (!detail::UnifiedBackproject(p, f, m[0] / m[2], m[1] / m[2], Q, r)) return false;
  } else if (!detail::GeneralReflect(p, f.mirror_offset[0], f.mirror_offset[1], m[0] / m[2], m[1] / m[2], Q,
                                     r)) {
    return false;
  }
  T Rs[9];
  detail::TiltRotation(f.sensor_tilt, Rs);
  detail::rotate(Rs, Q, origin);
  detail::rotate(Rs, r, direction);
  return true;
}

// The fast path for aligned rigs, the general one otherwise. Values are equal
// either way; with Jets, derivatives with respect to faults that are zero
// exist only through ProjectGeneral.
template <typename T>
bool ProjectRig(const GeneralSensorParams<T>& g, const T* point_robot, T* u, T* v) {
  if (g.IsAligned()) return project(g.aligned, point_robot, u, v);
  return ProjectGeneral(g, point_robot, u, v);
}

template <typename T>
bool BackprojectRig(const GeneralSensorParams<T>& g, const T& u, const T& v, T* origin, T* direction) {
  if (g.IsAligned()) return backproject(g.aligned, u, v, origin, direction);
  return BackprojectGeneral(g, u, v, origin, direction);
}

}  // namespace pano

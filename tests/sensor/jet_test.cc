// The model is templated on the scalar: instantiate it with ceres::Jet and
// check the automatic derivatives (through the reflection solve) against
// central finite differences.
#include <catch2/catch.hpp>
#include <ceres/jet.h>

#include <cmath>
#include <limits>

#include "sensor_models.h"

namespace pano {
namespace {

constexpr int kN = 11 + 3;  // 11 sensor parameters + the point
using JetT = ceres::Jet<double, kN>;

SensorParams<JetT> ToJets(const SensorParams<double>& p) {
  SensorParams<JetT> j;
  const double vals[11] = {p.focal_px, p.cx, p.cy, p.aspect, p.azimuth_offset, p.k1, p.k2,
                           p.curvature_radius, p.conic_constant, p.vertex_distance, p.rim_radius};
  JetT* dst[11] = {&j.focal_px, &j.cx, &j.cy, &j.aspect, &j.azimuth_offset, &j.k1, &j.k2,
                   &j.curvature_radius, &j.conic_constant, &j.vertex_distance, &j.rim_radius};
  for (int i = 0; i < 11; ++i) *dst[i] = JetT(vals[i], i);
  return j;
}

// Projection as a function of a flat vector (11 params + 3 point coords).
bool ProjectFlat(const double* x, double* uv) {
  SensorParams<double> p;
  double* dst[11] = {&p.focal_px, &p.cx, &p.cy, &p.aspect, &p.azimuth_offset, &p.k1, &p.k2,
                     &p.curvature_radius, &p.conic_constant, &p.vertex_distance, &p.rim_radius};
  for (int i = 0; i < 11; ++i) *dst[i] = x[i];
  return project(p, x + 11, &uv[0], &uv[1]);
}

TEST_CASE("project with ceres::Jet matches finite differences", "[jet]") {
  for (const auto& ns : test::AllSensorModels()) {
    const SensorParams<double>& p = ns.sensor.params;
    for (const Eigen::Vector3d& X : {Eigen::Vector3d(80.0, 30.0, 20.0), Eigen::Vector3d(-40.0, 55.0, -25.0),
                                    Eigen::Vector3d(10.0, -12.0, 3.0)}) {
      SensorParams<JetT> pj = ToJets(p);
      JetT Xj[3] = {JetT(X.x(), 11), JetT(X.y(), 12), JetT(X.z(), 13)};
      JetT u, v;
      double uv0[2];
      double flat[kN] = {p.focal_px, p.cx, p.cy, p.aspect, p.azimuth_offset, p.k1, p.k2,
                         p.curvature_radius, p.conic_constant, p.vertex_distance, p.rim_radius,
                         X.x(), X.y(), X.z()};
      const bool ok_d = ProjectFlat(flat, uv0);
      const bool ok_j = project(pj, Xj, &u, &v);
      INFO(ns.name << " point " << X.transpose());
      REQUIRE(ok_d == ok_j);
      if (!ok_d) continue;
      CHECK(u.a == Approx(uv0[0]).epsilon(1e-14));
      CHECK(v.a == Approx(uv0[1]).epsilon(1e-14));
      for (int i = 0; i < kN; ++i) {
        if (i == 10) continue;  // the rim only limits visibility
        const double h = 1e-6 * std::max(1.0, std::abs(flat[i]));
        double xp[kN], xm[kN];
        std::copy(flat, flat + kN, xp);
        std::copy(flat, flat + kN, xm);
        xp[i] += h;
        xm[i] -= h;
        double uvp[2], uvm[2];
        REQUIRE(ProjectFlat(xp, uvp));
        REQUIRE(ProjectFlat(xm, uvm));
        const double du = (uvp[0] - uvm[0]) / (2 * h), dv = (uvp[1] - uvm[1]) / (2 * h);
        INFO("parameter " << i);
        CHECK(u.v[i] == Approx(du).margin(1e-7 * (1.0 + std::abs(du))));
        CHECK(v.v[i] == Approx(dv).margin(1e-7 * (1.0 + std::abs(dv))));
      }
    }
  }
}

TEST_CASE("project with ceres::Jet at the limb (no room for a central difference)", "[jet]") {
  // A calibration step can put a board corner within 1e-9 of the mirror's
  // edge; the derivative of the reflection solve must not fail there.
  for (const auto& ns : test::AllSensorModels()) {
    const SensorParams<double>& p = ns.sensor.params;
    const double m_max = MaxNormalizedRadius(p);
    if (!std::isfinite(m_max)) continue;
    double ps, pz, ds, dz;
    REQUIRE(ReflectMeridian(p, m_max * (1.0 - 1e-10), &ps, &pz, &ds, &dz));
    const double t = 50.0 * p.vertex_distance;
    const Eigen::Vector3d X((ps + t * ds) * 0.6, (ps + t * ds) * 0.8, pz + t * dz);
    double ud, vd;
    INFO(ns.name);
    REQUIRE(project(p, X.data(), &ud, &vd));
    SensorParams<JetT> pj = ToJets(p);
    JetT Xj[3] = {JetT(X.x(), 11), JetT(X.y(), 12), JetT(X.z(), 13)};
    JetT u, v;
    REQUIRE(project(pj, Xj, &u, &v));
    // The Jet path's implicit-function Newton step may move the value by the
    // solve's own tolerance: measured at rounding level (5.7e-14 px).
    const double value_tol = 100 * std::numeric_limits<double>::epsilon() * 752;
    CHECK(u.a == Approx(ud).margin(value_tol));
    CHECK(v.a == Approx(vd).margin(value_tol));
    CHECK(u.v.allFinite());
    CHECK(v.v.allFinite());
    // Against a one-sided difference, stepping to whichever side keeps the
    // point in view (a central one would step off the mirror); its error,
    // h f'' / 2 with h = 1e-7, stays far below the margin.
    double flat[kN] = {p.focal_px, p.cx, p.cy, p.aspect, p.azimuth_offset, p.k1, p.k2,
                       p.curvature_radius, p.conic_constant, p.vertex_distance, p.rim_radius,
                       X.x(), X.y(), X.z()};
    const double uv0[2] = {ud, vd};
    for (int i = 0; i < kN; ++i) {
      if (i == 10) continue;  // the rim only limits visibility
      const double h = 1e-7 * std::max(1.0, std::abs(flat[i]));
      double uv[2];
      bool found = false;
      double slope_u = 0, slope_v = 0;
      for (const double side : {1.0, -1.0}) {
        double x[kN];
        std::copy(flat, flat + kN, x);
        x[i] += side * h;
        if (ProjectFlat(x, uv)) {
          slope_u = (uv[0] - uv0[0]) / (side * h);
          slope_v = (uv[1] - uv0[1]) / (side * h);
          found = true;
          break;
        }
      }
      INFO("parameter " << i);
      REQUIRE(found);
      CHECK(u.v[i] == Approx(slope_u).margin(1e-6 * (1.0 + std::abs(slope_u))));
      CHECK(v.v[i] == Approx(slope_v).margin(1e-6 * (1.0 + std::abs(slope_v))));
    }
  }
}

TEST_CASE("backproject with ceres::Jet compiles and keeps values", "[jet]") {
  // A copy: the models' vector is a temporary that ends with this statement.
  const SensorParams<double> p = test::AllSensorModels()[0].sensor.params;
  SensorParams<JetT> pj = ToJets(p);
  JetT o[3], d[3];
  REQUIRE(backproject(pj, JetT(400.0), JetT(300.0), o, d));
  double od[3], dd[3];
  REQUIRE(backproject(p, 400.0, 300.0, od, dd));
  for (int i = 0; i < 3; ++i) {
    CHECK(o[i].a == Approx(od[i]).epsilon(1e-14));
    CHECK(d[i].a == Approx(dd[i]).epsilon(1e-14));
  }
}

}  // namespace
}  // namespace pano

// The even-asphere mirror profile (catadioptric.h): the conic's closed form
// recovered by the iterative path, exact reflection by an independent
// construction, round trips and Jet derivatives over a grid of coefficients.
#include <catch2/catch.hpp>
#include <ceres/jet.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "sensor_models.h"
#include "test_rng.h"

namespace pano {
namespace {

// Base mirrors and the coefficients tried on each (within the convex range
// that Sensor::Check accepts).
struct AsphereCase {
  std::string name;
  Sensor sensor;
};

Sensor BaseSphere() { return MakeSphereSensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1); }
Sensor BaseHyperboloid() {
  Sensor s = MakeSphereSensor(752, 480, 300, 376, 240, 1.0, 1, 1);
  s.model = MirrorModel::kConic;
  s.params.curvature_radius = 2.0;
  s.params.conic_constant = -2.2;
  s.params.vertex_distance = 6.0;
  s.params.rim_radius = 3.0;
  s.params.k1 = -0.05;
  s.params.k2 = 0.01;
  return s;
}
Sensor BaseEllipsoid() {
  Sensor s = MakeSphereSensor(640, 640, 500, 320, 320, 1.0, 1, 1);
  s.model = MirrorModel::kConic;
  s.params.curvature_radius = 3.0;
  s.params.conic_constant = -0.4;
  s.params.vertex_distance = 9.0;
  return s;
}

std::vector<AsphereCase> AsphereGrid() {
  std::vector<AsphereCase> out;
  struct Base {
    const char* name;
    Sensor sensor;
    std::vector<double> a4, a6;
  };
  const Base bases[] = {{"sphere", BaseSphere(), {-0.04, 0.03, 0.1}, {-0.01, 0.0, 0.02}},
                        {"hyperboloid", BaseHyperboloid(), {-0.003, 0.01, 0.03}, {-0.0002, 0.0, 0.002}},
                        {"ellipsoid", BaseEllipsoid(), {-0.03, 0.02, 0.08}, {-0.01, 0.0, 0.02}}};
  for (const Base& b : bases)
    for (double a4 : b.a4)
      for (double a6 : b.a6) {
        Sensor s = b.sensor;
        s.model = MirrorModel::kAsphere;
        s.params.asphere_a4 = a4;
        s.params.asphere_a6 = a6;
        s.Check("test sensor");
        out.push_back({std::string(b.name) + " a4 " + std::to_string(a4) + " a6 " + std::to_string(a6), s});
      }
  return out;
}

// The sag w(s) straight from its definition (no shared code with the model).
double SagByHand(const SensorParams<double>& p, double s) {
  const double R = p.curvature_radius, rho = s / R;
  return s * s / (R + std::sqrt(R * R - (1.0 + p.conic_constant) * s * s)) +
         R * (p.asphere_a4 * std::pow(rho, 4) + p.asphere_a6 * std::pow(rho, 6));
}

TEST_CASE("asphere terms of 1e-300 take the iterative path and give the conic's closed form", "[asphere_conic]") {
  for (const auto& ns : test::AllSensorModels()) {
    if (ns.sensor.model == MirrorModel::kSphere) continue;
    const Sensor& conic = ns.sensor;
    Sensor tiny = conic;
    tiny.model = MirrorModel::kAsphere;
    tiny.params.asphere_a4 = 1e-300;  // numerically nothing, but not a constant zero
    REQUIRE(IsConicProfile(conic.params));
    REQUIRE_FALSE(IsConicProfile(tiny.params));
    INFO(ns.name);
    const double m_conic = MaxNormalizedRadius(conic.params), m_tiny = MaxNormalizedRadius(tiny.params);
    CHECK(m_tiny == Approx(m_conic).epsilon(1e-13));
    double worst = 0.0;
    int n = 0;
    PANO_SEEDED_RNG(17);
    const double scale = conic.params.vertex_distance + conic.params.curvature_radius;
    std::uniform_real_distribution<double> uni(-30.0 * scale, 30.0 * scale);
    for (int i = 0; i < 3000; ++i) {
      const double z = uni(rng), y = uni(rng), x = uni(rng);  // (drawn in a set order: a call's argument order is the compiler's)
      const Eigen::Vector3d X(x, y, z);
      Eigen::Vector2d a, b;
      const bool ok_a = conic.project(X, &a);
      const bool ok_b = tiny.project(X, &b);
      REQUIRE(ok_a == ok_b);
      if (!ok_a) continue;
      worst = std::max(worst, (a - b).norm());
      ++n;
    }
    CHECK(n > 300);
    CHECK(worst < 1e-9);
    WARN(ns.name << ": conic closed form vs asphere path, worst " << worst << " px over " << n << " points");
  }
}

TEST_CASE("asphere reflection matches a hand construction on the profile", "[asphere_hand]") {
  // Pick a mirror point, reflect the camera ray there by hand (normal from a
  // central difference of the sag), put a point on the reflected ray, and
  // project it: the image radius must be f m with m = s / (zv + w(s)).
  for (const AsphereCase& c : AsphereGrid()) {
    const SensorParams<double>& p = c.sensor.params;
    const double m_max = MaxNormalizedRadius(p);
    double s_edge, z_edge;
    REQUIRE(MirrorHit(p, 0.98 * m_max, &s_edge, &z_edge));
    for (double frac : {0.1, 0.5, 0.9}) {
      const double s = frac * s_edge;
      const double w = SagByHand(p, s);
      const double h = 1e-5 * s;
      const double slope = (SagByHand(p, s + h) - SagByHand(p, s - h)) / (2 * h);
      const Eigen::Vector2d P(s, p.vertex_distance + w);
      const Eigen::Vector2d n = Eigen::Vector2d(slope, -1.0).normalized();
      const Eigen::Vector2d v = P.normalized();
      const Eigen::Vector2d d = v - 2.0 * v.dot(n) * n;
      const Eigen::Vector2d Xm = P + 25.0 * d;  // meridian point (D, Z)
      const double m = s / (p.vertex_distance + w);
      double radius;
      INFO(c.name << " s " << s);
      REQUIRE(ImageRadius(p, Xm.x(), Xm.y(), &radius));
      CHECK(radius == Approx(p.focal_px * DistortRadius(p, m)).epsilon(1e-9));
    }
  }
}

TEST_CASE("asphere limb: rays just inside meet the mirror, just outside miss", "[asphere_limb]") {
  for (const AsphereCase& c : AsphereGrid()) {
    SensorParams<double> p = c.sensor.params;
    p.rim_radius = 0.0;
    const double m_max = MaxNormalizedRadius(p);
    INFO(c.name << " m_max " << m_max);
    if (!std::isfinite(m_max)) continue;
    double s, z;
    REQUIRE(MirrorHit(p, m_max * (1.0 - 1e-9), &s, &z));
    CHECK_FALSE(MirrorHit(p, m_max * (1.0 + 1e-9), &s, &z));
    // At the limb the ray is tangent: slope of the profile = z / s... in the
    // sense (zv + w) = s w'.
    REQUIRE(MirrorHit(p, m_max * (1.0 - 1e-12), &s, &z));
    const double h = 1e-6 * s;
    const double slope = (SagByHand(p, s + h) - SagByHand(p, s - h)) / (2 * h);
    CHECK(z == Approx(s * slope).epsilon(1e-4));
  }
}

TEST_CASE("asphere round trips over a grid of coefficients", "[asphere_round_trip]") {
  PANO_SEEDED_RNG(5);
  for (const AsphereCase& c : AsphereGrid()) {
    const Sensor& s = c.sensor;
    const double scale = s.params.vertex_distance + s.params.curvature_radius;
    // Pixel -> ray -> point -> pixel.
    double worst_px = 0.0;
    const double limb = s.limb_radius();
    for (int ir = 0; ir < 40; ++ir) {
      const double radius = (0.02 + 0.97 * ir / 39.0) * limb;
      for (int ia = 0; ia < 12; ++ia) {
        const Eigen::Vector2d px = s.from_polar(radius, -M_PI + 2.0 * M_PI * (ia + 0.3) / 12.0);
        Eigen::Vector3d o, d;
        INFO(c.name << " radius " << radius);
        REQUIRE(s.backproject(px, &o, &d));
        for (double t : {0.7 * scale, 10.0 * scale}) {
          Eigen::Vector2d back;
          REQUIRE(s.project(o + t * d, &back));
          worst_px = std::max(worst_px, (back - px).norm());
        }
      }
    }
    INFO(c.name);
    CHECK(worst_px < 1e-9);
    // Point -> pixel -> ray through the point.
    std::uniform_real_distribution<double> uni(-30.0 * scale, 30.0 * scale);
    double worst_rel = 0.0;
    int visible = 0;
    for (int i = 0; i < 2000; ++i) {
      const double z = uni(rng), y = uni(rng), x = uni(rng);  // (drawn in a set order: a call's argument order is the compiler's)
      const Eigen::Vector3d X(x, y, z);
      Eigen::Vector2d px;
      if (!s.project(X, &px)) continue;
      ++visible;
      Eigen::Vector3d o, d;
      REQUIRE(s.backproject(px, &o, &d));
      const Eigen::Vector3d ox = X - o;
      worst_rel = std::max(worst_rel, (ox - ox.dot(d) * d).norm() / ox.norm());
    }
    CHECK(visible > 200);
    CHECK(worst_rel < 2e-10);
  }
}

TEST_CASE("asphere with rig faults: ProjectGeneral and BackprojectGeneral agree", "[asphere_round_trip]") {
  PANO_SEEDED_RNG(9);
  for (const AsphereCase& c : AsphereGrid()) {
    Sensor s = c.sensor;
    s.faults.mirror_offset[0] = 0.02 * s.params.curvature_radius;
    s.faults.mirror_offset[1] = -0.01 * s.params.curvature_radius;
    s.faults.camera_tilt[0] = 0.01;
    s.faults.sensor_tilt[1] = -0.008;
    s.Check("test sensor");
    const double scale = s.params.vertex_distance + s.params.curvature_radius;
    std::uniform_real_distribution<double> uni(-30.0 * scale, 30.0 * scale);
    double worst_rel = 0.0;
    int visible = 0;
    for (int i = 0; i < 1500; ++i) {
      const double z = uni(rng), y = uni(rng), x = uni(rng);  // (drawn in a set order: a call's argument order is the compiler's)
      const Eigen::Vector3d X(x, y, z);
      Eigen::Vector2d px;
      if (!s.project(X, &px)) continue;
      ++visible;
      Eigen::Vector3d o, d;
      REQUIRE(s.backproject(px, &o, &d));
      const Eigen::Vector3d ox = X - o;
      worst_rel = std::max(worst_rel, (ox - ox.dot(d) * d).norm() / ox.norm());
    }
    INFO(c.name);
    CHECK(visible > 150);
    CHECK(worst_rel < 2e-10);
    // The faulty rig's image differs from the aligned one (the faults act).
    Eigen::Vector2d a, b;
    const Eigen::Vector3d X(20.0 * scale, 5.0 * scale, 2.0 * scale);
    Sensor aligned = c.sensor;
    if (s.project(X, &a) && aligned.project(X, &b)) CHECK((a - b).norm() > 0.1);
  }
}

// Derivatives through the asphere path: every sensor parameter (the asphere
// terms included), the faults' offset and the point, against central
// differences.
constexpr int kP = 12;  // focal, cx, cy, aspect, azimuth, k1, k2, R, k, zv, a4, a6
constexpr int kN = kP + 2 + 3;
using JetT = ceres::Jet<double, kN>;

template <typename T>
void Unflatten(const T* x, GeneralSensorParams<T>* g, double rim) {
  SensorParams<T>& p = g->aligned;
  T* dst[kP] = {&p.focal_px, &p.cx, &p.cy, &p.aspect, &p.azimuth_offset, &p.k1, &p.k2,
                &p.curvature_radius, &p.conic_constant, &p.vertex_distance, &p.asphere_a4, &p.asphere_a6};
  for (int i = 0; i < kP; ++i) *dst[i] = x[i];
  p.rim_radius = T(rim);
  g->faults.mirror_offset[0] = x[kP];
  g->faults.mirror_offset[1] = x[kP + 1];
}

template <typename T>
bool ProjectFlat(const T* x, double rim, bool general, T* u, T* v) {
  GeneralSensorParams<T> g;
  Unflatten(x, &g, rim);
  if (general) return ProjectGeneral(g, x + kP + 2, u, v);
  return project(g.aligned, x + kP + 2, u, v);
}

void CheckJet(const Sensor& s, bool general, const std::string& name) {
  const SensorParams<double>& p = s.params;
  const double scale = p.vertex_distance + p.curvature_radius;
  const double off = general ? 0.01 * p.curvature_radius : 0.0;
  for (const Eigen::Vector3d& Xu : {Eigen::Vector3d(15.0, 6.0, 4.0), Eigen::Vector3d(-8.0, 11.0, -2.0),
                                    Eigen::Vector3d(2.0, -2.4, 0.6)}) {
    const Eigen::Vector3d X = Xu * scale;
    double flat[kN] = {p.focal_px, p.cx, p.cy, p.aspect, p.azimuth_offset, p.k1, p.k2, p.curvature_radius,
                       p.conic_constant, p.vertex_distance, p.asphere_a4, p.asphere_a6, off, -off,
                       X.x(), X.y(), X.z()};
    JetT xj[kN];
    for (int i = 0; i < kN; ++i) xj[i] = JetT(flat[i], i);
    JetT u, v;
    double u0, v0;
    const bool ok_d = ProjectFlat(flat, p.rim_radius, general, &u0, &v0);
    const bool ok_j = ProjectFlat(xj, p.rim_radius, general, &u, &v);
    INFO(name << (general ? " general" : " aligned") << " point " << X.transpose());
    REQUIRE(ok_d == ok_j);
    if (!ok_d) continue;
    CHECK(u.a == Approx(u0).epsilon(1e-13));
    CHECK(v.a == Approx(v0).epsilon(1e-13));
    for (int i = 0; i < kN; ++i) {
      if (!general && (i == kP || i == kP + 1)) continue;  // no faults in the aligned model
      const double h = 1e-6 * std::max(1.0, std::abs(flat[i]));
      double xp[kN], xm[kN];
      std::copy(flat, flat + kN, xp);
      std::copy(flat, flat + kN, xm);
      xp[i] += h;
      xm[i] -= h;
      double up, vp, um, vm;
      REQUIRE(ProjectFlat(xp, p.rim_radius, general, &up, &vp));
      REQUIRE(ProjectFlat(xm, p.rim_radius, general, &um, &vm));
      const double du = (up - um) / (2 * h), dv = (vp - vm) / (2 * h);
      INFO("parameter " << i);
      CHECK(u.v[i] == Approx(du).margin(2e-7 * (1.0 + std::abs(du))));
      CHECK(v.v[i] == Approx(dv).margin(2e-7 * (1.0 + std::abs(dv))));
    }
  }
}

TEST_CASE("asphere projection with ceres::Jet matches finite differences", "[asphere_jet]") {
  for (const AsphereCase& c : AsphereGrid()) {
    CheckJet(c.sensor, false, c.name);
    CheckJet(c.sensor, true, c.name);
  }
  // Terms free at zero: the Jets carry their derivatives (the asphere path is
  // taken although the values are those of the conic).
  Sensor conic = BaseEllipsoid();
  conic.model = MirrorModel::kAsphere;
  CheckJet(conic, false, "ellipsoid a4 0 a6 0");
  CheckJet(conic, true, "ellipsoid a4 0 a6 0");
}

TEST_CASE("asphere terms need model asphere and a convex visible profile", "[asphere_check]") {
  Sensor s = BaseSphere();
  s.params.asphere_a4 = 0.05;
  CHECK_THROWS_WITH(s.Check("x"), Catch::Contains("asphere_a4/asphere_a6: even-asphere terms need model asphere"));
  s.model = MirrorModel::kAsphere;
  CHECK_NOTHROW(s.Check("x"));
  s.params.asphere_a4 = -0.6;  // the profile turns back before the limb
  CHECK_THROWS_WITH(s.Check("x"), Catch::Contains("not convex"));
  CHECK(std::string(MirrorModelName(MirrorModel::kAsphere)) == "asphere");
}

}  // namespace
}  // namespace pano

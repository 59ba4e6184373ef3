// The general model of imperfect rigs (general_model.h): equal to the aligned
// model when every fault is zero, exact round trips over a grid of faults for
// a sphere and a conic, and Jet derivatives against finite differences.
#include <catch2/catch.hpp>
#include <ceres/jet.h>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "panotrack/sensor/general_model.h"
#include "sensor_models.h"
#include "test_rng.h"

namespace pano {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The two rigs: the paper's real sphere (r 4.9 cm at 15.1 cm, f 590 px) and
// the distorted hyperboloid with a rim of 3 cm. `size`: the mirror's radius,
// to scale the 1.4 mm decentre of the sphere to the conic.
struct Rig {
  const char* name;
  SensorParams<double> params;
  double size;
};

std::vector<Rig> Rigs() {
  std::vector<Rig> out;
  for (const auto& ns : test::AllSensorModels()) {
    if (ns.name == "sphere/paper-real") out.push_back({"sphere", ns.sensor.params, 4.9});
    if (ns.name == "conic/hyperboloid-distorted") out.push_back({"conic", ns.sensor.params, 3.0});
  }
  return out;
}

// The grid of faults: decentre 0, +-1.4 mm-equivalent and twice; camera
// tilt 0, +-0.6 degrees and twice; lens k1 -0.03 k2 0.005 (with and without
// tangential terms); sensor tilt 0, 0.4 degrees and twice.
std::vector<GeneralSensorParams<double>> FaultGrid(const Rig& rig) {
  const double d = 0.14 * rig.size / 4.9;
  const double offsets[][2] = {{0, 0}, {d, 0}, {-d, 0}, {0, d}, {2 * d, -2 * d}};
  const double cam[][2] = {{0, 0}, {0.6, 0}, {-0.6, 0.6}, {1.2, -1.2}};
  const double sens[][2] = {{0, 0}, {0.4, 0}, {0.8, -0.8}};
  std::vector<GeneralSensorParams<double>> out;
  for (const auto& o : offsets)
    for (const auto& c : cam)
      for (int lens = 0; lens < 3; ++lens)
        for (const auto& s : sens) {
          GeneralSensorParams<double> g;
          g.aligned = rig.params;
          g.faults.mirror_offset[0] = o[0];
          g.faults.mirror_offset[1] = o[1];
          g.faults.camera_tilt[0] = c[0] * kDeg;
          g.faults.camera_tilt[1] = c[1] * kDeg;
          g.faults.sensor_tilt[0] = s[0] * kDeg;
          g.faults.sensor_tilt[1] = s[1] * kDeg;
          if (lens >= 1) {
            g.aligned.k1 = -0.03;
            g.aligned.k2 = 0.005;
          }
          if (lens == 2) {
            g.faults.p1 = 1e-3;
            g.faults.p2 = -5e-4;
            g.faults.k3 = 1e-3;
            g.faults.skew = -1.2;
          }
          out.push_back(g);
        }
  return out;
}

// Points around the sensor: 10..150 map units away, below and above the mirror.
std::vector<Eigen::Vector3d> ScenePoints(std::mt19937_64* rng, int n) {
  std::uniform_real_distribution<double> dist(10.0, 150.0), az(-M_PI, M_PI), height(-40.0, 60.0);
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < n; ++i) {
    const double D = dist(*rng), a = az(*rng);
    out.emplace_back(D * std::cos(a), D * std::sin(a), height(*rng));
  }
  return out;
}

// Distance of X from the ray (o, d), relative to its distance from o.
double RelativeMiss(const Eigen::Vector3d& X, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  const Eigen::Vector3d q = X - o;
  return q.cross(d.normalized()).norm() / q.norm();
}

TEST_CASE("all faults zero: the general path equals the aligned model", "[general_aligned]") {
  PANO_SEEDED_RNG(71);
  for (const auto& ns : test::AllSensorModels()) {
    GeneralSensorParams<double> g;
    g.aligned = ns.sensor.params;
    REQUIRE(g.IsAligned());
    double worst_px = 0.0, worst_ray = 0.0;
    int n = 0;
    for (const Eigen::Vector3d& X : ScenePoints(&rng, 400)) {
      double u0, v0, u1, v1;
      const bool ok0 = project(g.aligned, X.data(), &u0, &v0);
      const bool ok1 = ProjectGeneral(g, X.data(), &u1, &v1);
      INFO(ns.name << " point " << X.transpose());
      // Visibility agrees except within rounding of the limb.
      if (ok0 != ok1) continue;
      if (!ok0) continue;
      ++n;
      worst_px = std::max(worst_px, std::hypot(u1 - u0, v1 - v0));
      double o0[3], d0[3], o1[3], d1[3];
      REQUIRE(backproject(g.aligned, u0, v0, o0, d0));
      REQUIRE(BackprojectGeneral(g, u0, v0, o1, d1));
      for (int i = 0; i < 3; ++i)
        worst_ray = std::max({worst_ray, std::abs(o1[i] - o0[i]), std::abs(d1[i] - d0[i])});
    }
    INFO(ns.name << ": " << n << " points, worst " << worst_px << " px, ray " << worst_ray);
    CHECK(n > 200);
    CHECK(worst_px < 1e-9);
    CHECK(worst_ray < 1e-12);
    WARN(ns.name << ": general vs aligned, worst " << worst_px << " px, ray " << worst_ray);
  }
}

TEST_CASE("point -> pixel -> ray through the point over a grid of faults", "[general_round_trip]") {
  PANO_SEEDED_RNG(72);
  for (const Rig& rig : Rigs()) {
    const std::vector<Eigen::Vector3d> points = ScenePoints(&rng, 30);
    double worst = 0.0, worst_px = 0.0;
    long n = 0, tried = 0, aligned_seen = 0;
    for (const GeneralSensorParams<double>& g : FaultGrid(rig)) {
      for (const Eigen::Vector3d& X : points) {
        ++tried;
        double u, v;
        double ua, va;
        if (project(rig.params, X.data(), &ua, &va)) ++aligned_seen;
        if (!ProjectRig(g, X.data(), &u, &v)) continue;
        ++n;
        Eigen::Vector3d o, d;
        INFO(rig.name << " point " << X.transpose() << " pixel " << u << ", " << v);
        REQUIRE(BackprojectRig(g, u, v, o.data(), d.data()));
        CHECK(std::abs(d.norm() - 1.0) < 1e-12);
        CHECK((X - o).dot(d) > 0.0);
        worst = std::max(worst, RelativeMiss(X, o, d));
        // And back: the point on the ray at X's distance lands on the pixel.
        const Eigen::Vector3d Y = o + (X - o).norm() * d;
        double u2, v2;
        REQUIRE(ProjectRig(g, Y.data(), &u2, &v2));
        worst_px = std::max(worst_px, std::hypot(u2 - u, v2 - v));
      }
    }
    INFO(rig.name << ": " << n << " of " << tried << " projected, worst relative miss " << worst << ", worst "
                  << worst_px << " px");
    // Small faults move the view's edge a little: nearly the aligned rig's points.
    INFO("the aligned rig sees " << aligned_seen);
    CHECK(n > aligned_seen * 9 / 10);
    CHECK(n < aligned_seen * 11 / 10);
    CHECK(worst < 1e-9);
    CHECK(worst_px < 1e-7);
    WARN(rig.name << ": " << n << " round trips, worst relative miss " << worst << ", worst " << worst_px << " px");
  }
}

TEST_CASE("faults move the image: a decentred sphere is not the aligned one", "[general_round_trip]") {
  const Rig rig = Rigs().front();
  GeneralSensorParams<double> g;
  g.aligned = rig.params;
  g.faults.mirror_offset[0] = 0.14;
  REQUIRE_FALSE(g.IsAligned());
  const double X[3] = {100.0, 0.0, 10.0};
  double u0, v0, u1, v1;
  REQUIRE(project(g.aligned, X, &u0, &v0));
  REQUIRE(ProjectGeneral(g, X, &u1, &v1));
  // The sphere moved towards +x: the point at bearing 0 appears further out.
  CHECK(std::abs(v1 - v0) < 1e-9);
  CHECK(u1 - u0 > 1.0);
}

// ---------------------------------------------------------------- Jets

constexpr int kParams = 11 + 10;  // aligned parameters, faults
constexpr int kN = kParams + 3;  // and the point
using JetT = ceres::Jet<double, kN>;

template <typename T>
std::vector<T*> Fields(GeneralSensorParams<T>* g) {
  SensorParams<T>& p = g->aligned;
  RigFaults<T>& f = g->faults;
  return {&p.focal_px, &p.cx, &p.cy, &p.aspect, &p.azimuth_offset, &p.k1, &p.k2, &p.curvature_radius,
          &p.conic_constant, &p.vertex_distance, &p.rim_radius, &f.mirror_offset[0], &f.mirror_offset[1],
          &f.camera_tilt[0], &f.camera_tilt[1], &f.p1, &f.p2, &f.k3, &f.sensor_tilt[0], &f.sensor_tilt[1],
          &f.skew};
}

bool ProjectFlat(const double* x, double* uv) {
  GeneralSensorParams<double> g;
  std::vector<double*> f = Fields(&g);
  for (int i = 0; i < kParams; ++i) *f[static_cast<size_t>(i)] = x[i];
  return ProjectGeneral(g, x + kParams, &uv[0], &uv[1]);
}

bool BackprojectFlat(const double* x, double* od) {
  GeneralSensorParams<double> g;
  std::vector<double*> f = Fields(&g);
  for (int i = 0; i < kParams; ++i) *f[static_cast<size_t>(i)] = x[i];
  return BackprojectGeneral(g, x[kParams], x[kParams + 1], od, od + 3);
}

// Central differences with steps h_i = cbrt(eps) max(1, |x_i|): the error is
// O(h^2) truncation plus O(eps / h) rounding, about 1e-10 relative here.
template <int kOut, typename F>
void CheckAgainstDifferences(const double* flat, const JetT* out, F fn, double* worst_rel) {
  const double eps = std::numeric_limits<double>::epsilon();
  for (int i = 0; i < kN; ++i) {
    if (i == 10) continue;  // the rim only limits visibility
    const double h = std::cbrt(eps) * std::max(1.0, std::abs(flat[i]));
    double xp[kN], xm[kN], fp[kOut], fm[kOut];
    std::copy(flat, flat + kN, xp);
    std::copy(flat, flat + kN, xm);
    xp[i] += h;
    xm[i] -= h;
    REQUIRE(fn(xp, fp));
    REQUIRE(fn(xm, fm));
    for (int k = 0; k < kOut; ++k) {
      const double fd = (fp[k] - fm[k]) / (2.0 * h);
      const double ad = out[k].v[i];
      // Scale: the output's size over the input's step scale.
      const double scale = std::max(1.0, std::abs(out[k].a)) / std::max(1.0, std::abs(flat[i]));
      INFO("input " << i << " output " << k << ": jet " << ad << " fd " << fd);
      const double rel = std::abs(ad - fd) / (std::abs(fd) + scale);
      *worst_rel = std::max(*worst_rel, rel);
      CHECK(rel < 1e-7);
    }
  }
}

TEST_CASE("ProjectGeneral and BackprojectGeneral with ceres::Jet match finite differences", "[general_jet]") {
  double worst_project = 0.0, worst_back = 0.0;
  int checked = 0;
  for (const Rig& rig : Rigs()) {
    GeneralSensorParams<double> g;
    g.aligned = rig.params;
    g.aligned.k1 = -0.03;
    g.aligned.k2 = 0.005;
    g.faults.mirror_offset[0] = 0.14 * rig.size / 4.9;
    g.faults.mirror_offset[1] = -0.07 * rig.size / 4.9;
    g.faults.camera_tilt[0] = 0.6 * kDeg;
    g.faults.camera_tilt[1] = -0.3 * kDeg;
    g.faults.p1 = 1e-3;
    g.faults.p2 = -5e-4;
    g.faults.k3 = 1e-3;
    g.faults.sensor_tilt[0] = 0.4 * kDeg;
    g.faults.sensor_tilt[1] = 0.2 * kDeg;
    g.faults.skew = -1.2;
    for (const Eigen::Vector3d& X : {Eigen::Vector3d(80.0, 30.0, 20.0), Eigen::Vector3d(-40.0, 55.0, -25.0),
                                    Eigen::Vector3d(10.0, -12.0, 3.0), Eigen::Vector3d(60.0, -70.0, -30.0),
                                    Eigen::Vector3d(-90.0, -20.0, 5.0)}) {
      double u_aligned, v_aligned;
      if (!project(g.aligned, X.data(), &u_aligned, &v_aligned)) continue;  // not in the rig's view
      double flat[kN];
      std::vector<double*> f = Fields(&g);
      for (int i = 0; i < kParams; ++i) flat[i] = *f[static_cast<size_t>(i)];
      for (int i = 0; i < 3; ++i) flat[kParams + i] = X[i];
      GeneralSensorParams<JetT> gj;
      std::vector<JetT*> fj = Fields(&gj);
      for (int i = 0; i < kParams; ++i) *fj[static_cast<size_t>(i)] = JetT(flat[i], i);
      const JetT Xj[3] = {JetT(X.x(), kParams), JetT(X.y(), kParams + 1), JetT(X.z(), kParams + 2)};
      JetT uv[2];
      double uv0[2];
      INFO(rig.name << " point " << X.transpose());
      REQUIRE(ProjectFlat(flat, uv0));
      REQUIRE(ProjectGeneral(gj, Xj, &uv[0], &uv[1]));
      CHECK(uv[0].a == Approx(uv0[0]).epsilon(1e-14));
      CHECK(uv[1].a == Approx(uv0[1]).epsilon(1e-14));
      CheckAgainstDifferences<2>(flat, uv, ProjectFlat, &worst_project);
      // Back-projection of that pixel, differentiated in the parameters and
      // the pixel (the last input slot is unused there).
      double flat_b[kN];
      std::copy(flat, flat + kN, flat_b);
      flat_b[kParams] = uv0[0];
      flat_b[kParams + 1] = uv0[1];
      flat_b[kParams + 2] = 0.0;
      const JetT uj(uv0[0], kParams), vj(uv0[1], kParams + 1);
      JetT od[6];
      REQUIRE(BackprojectGeneral(gj, uj, vj, od, od + 3));
      CheckAgainstDifferences<6>(flat_b, od, BackprojectFlat, &worst_back);
      ++checked;
    }
  }
  INFO("worst relative derivative error: project " << worst_project << ", backproject " << worst_back);
  CHECK(checked >= 7);
  CHECK(worst_project < 1e-9);
  CHECK(worst_back < 1e-7);
  WARN("jet vs central differences, worst relative: project " << worst_project << ", backproject "
                                                              << worst_back);
}

TEST_CASE("ProjectRig keeps the aligned fast path and Jets through it", "[general_jet]") {
  const Rig rig = Rigs().front();
  GeneralSensorParams<JetT> gj;
  gj.aligned = rig.params.cast<JetT>();
  gj.aligned.focal_px.v[0] = 1.0;
  REQUIRE(gj.IsAligned());
  const JetT X[3] = {JetT(90.0), JetT(20.0), JetT(5.0)};
  JetT u1, v1, u2, v2;
  REQUIRE(ProjectRig(gj, X, &u1, &v1));
  REQUIRE(project(gj.aligned, X, &u2, &v2));
  CHECK(u1.a == u2.a);
  CHECK(u1.v[0] == u2.v[0]);
  CHECK(v1.v[0] == v2.v[0]);
}

}  // namespace
}  // namespace pano

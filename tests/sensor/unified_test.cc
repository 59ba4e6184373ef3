// The unified (central) profile, Mei's model: its closed forms by hand,
// point -> pixel -> ray through the point for the aligned and the general
// path, Jet derivatives against central finite differences (xi among them),
// and the checks a calibration file gets.
#include <catch2/catch.hpp>
#include <ceres/jet.h>

#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <random>

#include "expect_error.h"
#include "panotrack/sensor/sensor.h"
#include "sensor_models.h"

namespace pano {
namespace {

// The distance of `point` from the ray (origin, unit direction), and whether
// it lies ahead.
double RayDistance(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, const Eigen::Vector3d& point,
                   bool* ahead) {
  const Eigen::Vector3d q = point - origin;
  *ahead = q.dot(direction) > 0.0;
  return q.cross(direction).norm();
}

TEST_CASE("unified: closed forms by hand", "[unified_hand]") {
  Sensor s = test::MeiParabolic(1.0);
  s.params.k1 = s.params.k2 = 0.0;
  s.params.rim_radius = 5.0;
  // xi = 1 (parabolic): the horizon at m = 1, straight down at the centre.
  double r;
  REQUIRE(s.image_radius(100.0, 0.0, &r));
  CHECK(r == Approx(s.params.focal_px).epsilon(4 * std::numeric_limits<double>::epsilon()));
  // 45 degrees up: m = D / (rho - Z) = 1 / (sqrt(2) - 1).
  REQUIRE(s.image_radius(50.0, 50.0, &r));
  CHECK(r == Approx(s.params.focal_px / (std::sqrt(2.0) - 1.0)).epsilon(1e-14));
  // xi = 0.5: 30 degrees down is m = cos 30 / (0.5 + sin 30) = cos 30.
  s.params.xi = 0.5;
  REQUIRE(s.image_radius(std::cos(M_PI / 6), -std::sin(M_PI / 6), &r));
  CHECK(r == Approx(s.params.focal_px * std::cos(M_PI / 6)).epsilon(1e-14));
  // Straight up is never seen below xi = 1.
  CHECK_FALSE(s.image_radius(1e-9, 1.0, &r));
  // The inverse at a height: the same distance back.
  double D;
  REQUIRE(s.image_radius(120.0, 35.0, &r));
  REQUIRE(s.inverse_image_radius(r, 35.0, &D));
  CHECK(D == Approx(120.0).epsilon(1e-12));
}

TEST_CASE("unified: point -> pixel -> ray through the point, aligned and general", "[unified_round_trip]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (double xi : {0.0, 0.6, 1.0, 1.4}) {
    Sensor s = test::MeiParabolic(xi);
    INFO("xi " << xi);
    REQUIRE_NOTHROW(s.Check("sensor"));
    for (int faults = 0; faults < 2; ++faults) {
      if (faults) {
        s.faults.p1 = 0.002;
        s.faults.p2 = -0.001;
        s.faults.camera_tilt[0] = 0.01;
        s.faults.sensor_tilt[1] = -0.007;
        s.faults.mirror_offset[0] = 0.3;
      }
      int seen = 0;
      for (int k = 0; k < 400; ++k) {
        const double z = 200.0 * U(rng), y = 300.0 * U(rng), x = 300.0 * U(rng);  // (drawn in a set order: a call's argument order is the compiler's)
        const Eigen::Vector3d X(x, y, z);
        Eigen::Vector2d px;
        if (!s.project(X, &px)) continue;
        ++seen;
        Eigen::Vector3d o, d;
        REQUIRE(s.backproject(px, &o, &d));
        CHECK(d.norm() == Approx(1.0).epsilon(1e-12));
        bool ahead = false;
        CHECK(RayDistance(o, d, X, &ahead) < 1e-9 * X.norm());
        CHECK(ahead);
      }
      CHECK(seen > 40);  // xi 0, a pinhole looking down, sees the fewest
    }
  }
}

TEST_CASE("unified: ceres::Jet derivatives match finite differences", "[unified_jet]") {
  using JetT = ceres::Jet<double, 6>;  // focal, cx, xi, k1 and the point's x, z
  const Sensor s = test::MeiParabolic(0.9);
  auto project_at = [&](const double* x, double* uv) {
    GeneralSensorParams<double> g = s.general();
    g.aligned.focal_px = x[0];
    g.aligned.cx = x[1];
    g.aligned.xi = x[2];
    g.aligned.k1 = x[3];
    g.faults.p1 = 0.001;
    const double X[3] = {x[4], 40.0, x[5]};
    return ProjectGeneral(g, X, &uv[0], &uv[1]);
  };
  for (const Eigen::Vector2d& xz : {Eigen::Vector2d(120.0, 10.0), Eigen::Vector2d(-60.0, -45.0)}) {
    const double x0[6] = {s.params.focal_px, s.params.cx, s.params.xi, s.params.k1, xz.x(), xz.y()};
    GeneralSensorParams<JetT> gj = s.general().cast<JetT>();
    gj.aligned.focal_px = JetT(x0[0], 0);
    gj.aligned.cx = JetT(x0[1], 1);
    gj.aligned.xi = JetT(x0[2], 2);
    gj.aligned.k1 = JetT(x0[3], 3);
    gj.faults.p1 = JetT(0.001);
    const JetT Xj[3] = {JetT(x0[4], 4), JetT(40.0), JetT(x0[5], 5)};
    JetT u, v;
    REQUIRE(ProjectGeneral(gj, Xj, &u, &v));
    double uv0[2];
    REQUIRE(project_at(x0, uv0));
    CHECK(u.a == Approx(uv0[0]).epsilon(1e-14));
    CHECK(v.a == Approx(uv0[1]).epsilon(1e-14));
    for (int i = 0; i < 6; ++i) {
      const double h = 1e-6 * std::max(1.0, std::abs(x0[i]));
      double xp[6], xm[6], uvp[2], uvm[2];
      std::copy(x0, x0 + 6, xp);
      std::copy(x0, x0 + 6, xm);
      xp[i] += h;
      xm[i] -= h;
      REQUIRE(project_at(xp, uvp));
      REQUIRE(project_at(xm, uvm));
      INFO("parameter " << i);
      const double du = (uvp[0] - uvm[0]) / (2 * h), dv = (uvp[1] - uvm[1]) / (2 * h);
      CHECK(u.v[i] == Approx(du).margin(1e-7 * (1.0 + std::abs(du))));
      CHECK(v.v[i] == Approx(dv).margin(1e-7 * (1.0 + std::abs(dv))));
    }
  }
}

TEST_CASE("unified: what a calibration file may not say", "[unified_check]") {
  Sensor s = test::MeiParabolic(1.0);
  s.params.xi = -0.1;
  test::ExpectError([&] { s.Check("calib.yaml"); }, "calib.yaml: xi", {"0 <= xi <= 10"});
  s = test::MeiParabolic(1.0);
  s.params.rim_radius = 0.0;  // xi <= 1 sees to infinity
  test::ExpectError([&] { s.Check("calib.yaml"); }, "calib.yaml: rim_radius", {"give its rim_radius"});
  s = test::MeiParabolic(1.0);
  s.params.curvature_radius = 3.0;
  test::ExpectError([&] { s.Check("calib.yaml"); }, "calib.yaml", {"no mirror terms"});
  s = test::MeiParabolic(1.0);
  s.params.unified = false;  // the model and the parameters disagree
  test::ExpectError([&] { s.Check("calib.yaml"); }, "calib.yaml: model", {"does not match"});
  // Beyond xi = 1 the viewing sphere's silhouette bounds the image by itself.
  s = test::MeiParabolic(2.0);
  s.params.rim_radius = 0.0;
  REQUIRE_NOTHROW(s.Check("calib.yaml"));
  CHECK(MaxNormalizedRadius(s.params) == Approx(1.0 / std::sqrt(3.0)).epsilon(1e-15));
}

}  // namespace
}  // namespace pano

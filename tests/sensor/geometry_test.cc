// Values of the sphere model derived by hand, and the visibility rule.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "panotrack/pose/pose2.h"
#include "sensor_models.h"

namespace pano {
namespace {

TEST_CASE("limb radius is f r sin(phi) / (d - r cos(phi)) with cos(phi) = r / d", "[limb]") {
  // The paper's real sensor: f 590 px, r 4.9 cm, d 15.1 cm. The camera ray
  // grazing the sphere touches it where the radius is perpendicular to the
  // ray, i.e. cos(phi) = r / d (phi measured from the downward axis).
  const Sensor s = MakeSphereSensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1);
  const double c = 4.9 / 15.1, sn = std::sqrt(1.0 - c * c);
  const double expected = 590.0 * 4.9 * sn / (15.1 - 4.9 * c);
  CHECK(expected == Approx(202.4105).margin(1e-4));  // "about 202 px"
  CHECK(s.limb_radius() == Approx(expected).epsilon(1e-12));
  WARN("paper sensor limb radius " << s.limb_radius() << " px");
  // Second case by hand: r = 1, d = 2, f = 100 gives phi = 60 degrees, the
  // grazing ray at 30 degrees from the axis: limb = 100 tan(30 deg).
  const Sensor t = MakeSphereSensor(200, 200, 100, 99.5, 99.5, 1.0, 1.0, 2.0);
  CHECK(t.limb_radius() == Approx(100.0 / std::sqrt(3.0)).epsilon(1e-12));
  // Pixels beyond the limb see no mirror.
  Eigen::Vector3d o, d;
  CHECK_FALSE(t.backproject(t.from_polar(t.limb_radius() * 1.001, 0.3), &o, &d));
  CHECK(t.backproject(t.from_polar(t.limb_radius() * 0.999, 0.3), &o, &d));
}

TEST_CASE("E(D, Z) at a mirror point derived by hand", "[hand_value]") {
  // Sphere r = 1 centred d = 2 above the pinhole, f = 100 px. Take the mirror
  // point at phi = 30 degrees from the downward axis:
  //   P = (r sin phi, d - r cos phi) = (0.5, 2 - sqrt(3)/2)
  // The camera ray is v = P / |P|, the outward normal n = (sin phi, -cos phi),
  // the reflected ray d' = v - 2 (v.n) n. Following it to D = 10.5 gives
  //   Z = P_z + (D - P_s) d'_z / d'_s  (about 0.04656)
  // and the pixel radius is f P_s / P_z (about 44.0927 px).
  const double phi = M_PI / 6.0;
  const double ps = std::sin(phi), pz = 2.0 - std::cos(phi);
  const double len = std::hypot(ps, pz);
  const double vs = ps / len, vz = pz / len;
  const double ns = std::sin(phi), nz = -std::cos(phi);
  const double dot = vs * ns + vz * nz;
  const double ds = vs - 2 * dot * ns, dz = vz - 2 * dot * nz;
  const double D = 10.5;
  const double Z = pz + (D - ps) * dz / ds;
  const double expected_radius = 100.0 * ps / pz;
  CHECK(Z == Approx(0.0465633).margin(1e-6));
  CHECK(expected_radius == Approx(44.0927).margin(1e-4));

  const Sensor s = MakeSphereSensor(200, 200, 100, 99.5, 99.5, 1.0, 1.0, 2.0);
  double radius;
  REQUIRE(s.image_radius(D, Z, &radius));
  CHECK(radius == Approx(expected_radius).epsilon(500 * std::numeric_limits<double>::epsilon()));
  // The inverse at that height returns D.
  double D_back;
  REQUIRE(s.inverse_image_radius(expected_radius, Z, &D_back));
  CHECK(D_back == Approx(D).epsilon(500 * std::numeric_limits<double>::epsilon()));
  // In pixels, along the bearing of +y (image azimuth +90 degrees: v grows).
  Eigen::Vector2d px;
  REQUIRE(s.project(Eigen::Vector3d(0.0, D, Z), &px));
  CHECK(px.x() == Approx(99.5).margin(1e-9));
  CHECK(px.y() == Approx(99.5 + expected_radius).epsilon(500 * std::numeric_limits<double>::epsilon()));
}

TEST_CASE("points the mirror cannot show are reported as not visible", "[visibility]") {
  const Sensor s = MakeSphereSensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1);
  Eigen::Vector2d px;
  // On the axis: hidden by the camera or by the mirror.
  CHECK_FALSE(s.project({0.0, 0.0, -50.0}, &px));
  CHECK_FALSE(s.project({0.0, 0.0, 500.0}, &px));
  // Straight above the mirror, off the axis a little: behind the mirror.
  CHECK_FALSE(s.project({1.0, 0.0, 500.0}, &px));
  // Inside the mirror's sphere.
  CHECK_FALSE(s.project({0.5, 0.5, 15.1}, &px));
  // Above the grazing ray's elevation (about 71 degrees seen from the limb).
  CHECK_FALSE(s.project({30.0, 0.0, 300.0}, &px));
  // NaN or infinite input.
  CHECK_FALSE(s.project({std::nan(""), 0.0, 10.0}, &px));
  CHECK_FALSE(s.project({INFINITY, 0.0, 10.0}, &px));
  // Ordinary points around the robot are visible, and inside the limb.
  for (double z : {-30.0, 0.0, 60.0}) {
    REQUIRE(s.project({100.0, 40.0, z}, &px));
    double r, az;
    s.to_polar(px.x(), px.y(), &r, &az);
    CHECK(r < s.limb_radius());
    CHECK(az == Approx(std::atan2(40.0, 100.0)).margin(1e-12));
  }
  // Image radius grows with elevation: a higher point at the same distance
  // appears further out.
  double r_low, r_high;
  REQUIRE(s.image_radius(100.0, -30.0, &r_low));
  REQUIRE(s.image_radius(100.0, 60.0, &r_high));
  CHECK(r_high > r_low);
}

TEST_CASE("world and sensor frames, angles", "[frames]") {
  const Pose2 pose{100.0, 50.0, M_PI / 2};
  // The sensor's +x points along world +y.
  const Eigen::Vector3d ps = SensorFromWorld(pose, 30.0, {100.0, 80.0, 40.0});
  CHECK(ps.x() == Approx(30.0));
  CHECK(ps.y() == Approx(0.0).margin(1e-12));
  CHECK(ps.z() == Approx(10.0));
  const Eigen::Vector3d pw = WorldFromSensor(pose, 30.0, ps);
  CHECK((pw - Eigen::Vector3d(100.0, 80.0, 40.0)).norm() < 1e-12);
  CHECK(WrapAngle(3 * M_PI) == Approx(M_PI));
  CHECK(WrapAngle(-M_PI) == Approx(M_PI));
  CHECK(WrapAngle(-0.25) == Approx(-0.25));
  // azimuth_offset turns the image: image azimuth = bearing + offset.
  const Sensor s = MakeSphereSensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1, 0.3);
  Eigen::Vector2d px;
  REQUIRE(s.project({100.0, 0.0, 10.0}, &px));
  double r, az;
  s.to_polar(px.x(), px.y(), &r, &az);
  CHECK(az == Approx(0.3).margin(1e-12));
}

}  // namespace
}  // namespace pano

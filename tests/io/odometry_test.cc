// Wheel odometry: the CSV read back, each bad file rejected with its exact
// one-line message, and the increments between two times of known paths.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "expect_error.h"
#include "panotrack/io/odometry.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::ErrorOf;

std::string Write(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string p = dir + "/" + name;
  std::ofstream(p) << text;
  return p;
}

TEST_CASE("odometry CSV: read back; each bad file named with its line and problem", "[odometry]") {
  const std::string dir = test::ScratchDir("io_odometry");
  // CRLF line ends, a blank line and an unwrapped heading are accepted.
  const std::string good =
      Write(dir, "good.csv", "time,x,y,theta\r\n0.0,0,0,0\r\n\n0.5,1.25,-0.5,0.5\n1.0,1e0,1.0,7.0\n");
  const std::vector<OdometrySample> s = ReadOdometryCsv(good);
  REQUIRE(s.size() == 3);
  CHECK(s[0].time_s == 0.0);
  CHECK(s[1].time_s == 0.5);
  CHECK(s[1].pose.x == 1.25);
  CHECK(s[1].pose.y == -0.5);
  CHECK(s[1].pose.theta == 0.5);
  CHECK(s[2].pose.x == 1.0);
  CHECK(s[2].pose.theta == 7.0);

  const std::string h = "time,x,y,theta\n";
  auto message = [&](const std::string& name, const std::string& text) {
    const std::string p = Write(dir, name, text);
    return std::make_pair(p, ErrorOf([&] { ReadOdometryCsv(p); }));
  };
  auto check = [&](const std::string& name, const std::string& text, const std::string& expected) {
    const auto [path, got] = message(name, text);
    CHECK(got == path + ": " + expected);
  };
  CHECK(ErrorOf([&] { ReadOdometryCsv(dir + "/absent.csv"); }) == dir + "/absent.csv: cannot open the file");
  check("empty.csv", "", "empty file (expected the header 'time,x,y,theta')");
  check("header.csv", "time,x,y\n0,1,2\n", "line 1: expected the header 'time,x,y,theta', got 'time,x,y'");
  check("only_header.csv", h, "no samples after the header");
  check("columns.csv", h + "0,1,2\n", "line 2: expected 4 columns, got 3");
  check("extra.csv", h + "0,1,2,3\n\n0.1,1,2,3,4\n", "line 4: expected 4 columns, got 5");
  check("number.csv", h + "0,0,0,0\n0.1,abc,0,0\n", "line 3: column x: expected a finite number, got 'abc'");
  check("nan.csv", h + "0,0,0,nan\n", "line 2: column theta: expected a finite number, got 'nan'");
  check("blank.csv", h + ",0,0,0\n", "line 2: column time: expected a finite number, got ''");
  check("inf.csv", h + "0,0,1e999,0\n", "line 2: column y: expected a finite number, got '1e999'");
  // A binary file: its bytes quoted as \xNN, the message one line.
  check("binary.csv", std::string("ti\rme\x1b[2J,\x0c\xff\0,y\n", 16),
        "line 1: expected the header 'time,x,y,theta', got 'ti\\x0Dme\\x1B[2J,\\x0C\\xFF\\x00,y'");
  check("control.csv", h + "0,4\x0b" "2,0,0\n", "line 2: column x: expected a finite number, got '4\\x0B2'");
  check("long.csv", h + "0," + std::string(100, '7') + "x,0,0\n",
        "line 2: column x: expected a finite number, got '" + std::string(60, '7') + "...'");
  check("same.csv", h + "0.5,0,0,0\n0.5,1,0,0\n", "line 3: times must increase strictly (0.5 after 0.5)");
  check("back.csv", h + "0.5,0,0,0\n0.25,1,0,0\n", "line 3: times must increase strictly (0.25 after 0.5)");
}

// Driving round a circle of radius 2 at 0.25 rad/s, heading along it, one
// sample every 0.1 s for 30 s.
std::vector<OdometrySample> Circle() {
  std::vector<OdometrySample> s;
  for (int k = 0; k <= 300; ++k) {
    const double t = k / 10.0, a = 0.25 * t;
    s.push_back({t, {2 * std::cos(a), 2 * std::sin(a), WrapAngle(a + M_PI / 2)}});
  }
  return s;
}

TEST_CASE("odometry increments: known paths, unwrapped turns, noise that adds up", "[odometry]") {
  const std::vector<OdometrySample> circle = Circle();
  const OdometryOptions options;
  // From angle a to b on the circle, in the robot frame at a: R sin(b - a)
  // ahead, R (1 - cos(b - a)) to the left.
  const OdometryIncrement inc = Between(circle, 1.0, 3.0, options);
  CHECK(inc.dx == Approx(2 * std::sin(0.5)).epsilon(1e-14));
  CHECK(inc.dy == Approx(2 * (1 - std::cos(0.5))).epsilon(1e-13));
  CHECK(inc.dtheta == Approx(0.5).epsilon(1e-14));
  // Noise from the path: 20 chords of 2 * 2 sin(0.0125) and half a radian turned.
  const double distance = 20 * 4 * std::sin(0.0125);
  CHECK(inc.covariance(0, 0) == Approx(0.0025 * distance).epsilon(1e-13));
  CHECK(inc.covariance(1, 1) == inc.covariance(0, 0));
  CHECK(inc.covariance(2, 2) == Approx(0.0025 * 0.5 + 1e-4 * distance).epsilon(1e-13));
  CHECK(inc.covariance(0, 1) == 0.0);

  // Twenty seconds: five radians, across +-pi twice, kept whole.
  const OdometryIncrement long_way = Between(circle, 2.0, 22.0, options);
  CHECK(long_way.dtheta == Approx(5.0).epsilon(1e-13));
  CHECK(long_way.dx == Approx(2 * std::sin(5.0)).epsilon(1e-12));
  CHECK(long_way.dy == Approx(2 * (1 - std::cos(5.0))).epsilon(1e-12));

  // Variances add up over consecutive increments (a random walk).
  const OdometryIncrement a = Between(circle, 2.0, 12.0, options), b = Between(circle, 12.0, 22.0, options);
  CHECK((a.covariance + b.covariance - long_way.covariance).cwiseAbs().maxCoeff() < 1e-15);
  // Nothing between equal times.
  const OdometryIncrement none = Between(circle, 5.0, 5.0, options);
  CHECK(none.dx == 0.0);
  CHECK(none.dtheta == 0.0);
  CHECK(none.covariance.isZero());

  // Between samples: linear in position, the heading along the shorter arc.
  const std::vector<OdometrySample> line = {{0.0, {0, 0, 3.0}}, {1.0, {1, -2, -3.0}}, {2.0, {2, -4, -3.0}}};
  const Pose2 mid = OdometryPoseAt(line, 0.25);
  CHECK(mid.x == 0.25);
  CHECK(mid.y == -0.5);
  CHECK(mid.theta == Approx(WrapAngle(3.0 + 0.25 * (2 * M_PI - 6.0))).epsilon(1e-15));
  const OdometryIncrement across = Between(line, 0.5, 1.5, options);
  CHECK(across.dtheta == Approx(0.5 * (2 * M_PI - 6.0)).epsilon(1e-13));
  // (1, -2) seen from a robot heading at 3.0 + 0.1416 (about pi): behind it, to its left.
  const double h0 = WrapAngle(3.0 + 0.5 * (2 * M_PI - 6.0));
  CHECK(across.dx == Approx(std::cos(h0) * 1 + std::sin(h0) * -2).epsilon(1e-14));
  CHECK(across.dy == Approx(-std::sin(h0) * 1 + std::cos(h0) * -2).epsilon(1e-14));

  // A log in metres for a map in centimetres.
  OdometryOptions cm = options;
  cm.map_units_per_odometry_unit = 100;
  const OdometryIncrement scaled = Between(circle, 1.0, 3.0, cm);
  CHECK(scaled.dx == Approx(100 * inc.dx).epsilon(1e-14));
  CHECK(scaled.dy == Approx(100 * inc.dy).epsilon(1e-13));
  CHECK(scaled.dtheta == inc.dtheta);
  CHECK(scaled.covariance(0, 0) == Approx(100 * inc.covariance(0, 0)).epsilon(1e-13));
}

TEST_CASE("odometry increments: times outside the log, bad options", "[odometry]") {
  const std::vector<OdometrySample> circle = Circle();
  CHECK(ErrorOf([&] { Between(circle, 29.0, 31.0); }) ==
        "odometry: time 31 s is outside the samples' times [0, 30] s");
  CHECK(ErrorOf([&] { OdometryPoseAt(circle, -0.1); }) ==
        "odometry: time -0.1 s is outside the samples' times [0, 30] s");
  CHECK(ErrorOf([&] { Between(circle, 2.0, 1.5); }) == "odometry: increment from 2 s back to 1.5 s");
  CHECK(ErrorOf([&] { Between({}, 0.0, 0.0); }) == "odometry: no samples");
  OdometryOptions bad;
  bad.position_variance_per_distance = -1;
  CHECK(ErrorOf([&] { Between(circle, 1.0, 2.0, bad); }) ==
        "odometry options: position_variance_per_distance must be a finite number >= 0, got -1");
  bad = OdometryOptions();
  bad.map_units_per_odometry_unit = 0;
  CHECK(ErrorOf([&] { bad.Check(); }) ==
        "odometry options: map_units_per_odometry_unit must be a positive finite number, got 0");
}

}  // namespace
}  // namespace pano

// TUM trajectories: the exact text of ok rows (lost and init rows skipped,
// the yaw as a quaternion, map units scaled to metres), the staging of the
// streaming writer and the errors that name the file.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "panotrack/core/error.h"
#include "expect_error.h"
#include "panotrack/io/tum.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

PoseRow Row(int frame, double t, PoseStatus status, double x, double y, double theta) {
  PoseRow r;
  r.frame = frame;
  r.time_s = t;
  r.status = status;
  r.pose = {x, y, theta};
  r.n_landmarks = 5;
  r.residual = 0.25;
  return r;
}

// A map in centimetres with the sensor 150 cm above the floor.
const TumConversion kCentimetres{0.01, 1.5};

std::vector<PoseRow> Rows() {
  return {Row(0, 0.1, PoseStatus::kOk, 100, -50, M_PI / 2),
          Row(1, 0.2, PoseStatus::kLost, 0, 0, 0),
          Row(2, 0.3, PoseStatus::kOk, -12.3456, 7.25, -3.0),
          Row(3, 0.35, PoseStatus::kInit, 5, 5, 1),
          Row(4, 0.4, PoseStatus::kOk, 0, 0, 7.0)};  // wrapped to 7 - 2 pi first: qw >= 0
}

const char* const kExpected =
    "0.100000 1.000000000 -0.500000000 1.500000000 0.000000000 0.000000000 0.707106781 0.707106781\n"
    "0.300000 -0.123456000 0.072500000 1.500000000 0.000000000 0.000000000 -0.997494987 0.070737202\n"
    "0.400000 0.000000000 0.000000000 1.500000000 0.000000000 0.000000000 0.350783228 0.936456687\n";

TEST_CASE("TUM: ok rows only, metres, z the sensor height, the yaw as a quaternion", "[tum]") {
  const std::string dir = test::ScratchDir("io_tum");
  WriteTumTrajectory(dir + "/all.tum", Rows(), kCentimetres);
  CHECK(ReadAll(dir + "/all.tum") == kExpected);
  CHECK(!fs::exists(dir + "/all.tum.partial"));

  // The quaternion is the rotation by theta about z: qz = sin(theta/2), qw = cos(theta/2).
  for (double theta : {-3.1, -1.0, 0.0, 0.5, 3.1}) {
    const std::string line = FormatTumLine(Row(0, 0, PoseStatus::kOk, 0, 0, theta), {1.0, 0.0});
    double v[8];
    std::istringstream in(line);
    for (double& x : v) in >> x;
    REQUIRE(in);
    CHECK(2 * std::atan2(v[6], v[7]) == Approx(theta).margin(2e-9));
    CHECK(v[6] * v[6] + v[7] * v[7] == Approx(1.0).margin(2e-9));
  }
  // Metres in, metres out; the override of the map's units and z follow the map.
  Map map;
  map.units = "mm";
  map.sensor_height = 1200;
  const TumConversion mm = TumConversionForMap(map);
  CHECK(mm.metres_per_unit == Approx(0.001));
  CHECK(mm.z_metres == Approx(1.2));
  const TumConversion feet = TumConversionForMap(map, 0.3048);
  CHECK(feet.metres_per_unit == 0.3048);
  CHECK(feet.z_metres == Approx(1200 * 0.3048));
  CHECK(FormatTumLine(Row(7, 12.5, PoseStatus::kOk, 2.5, -1.25, 0), {1.0, 0.25}) ==
        "12.500000 2.500000000 -1.250000000 0.250000000 0.000000000 0.000000000 0.000000000 1.000000000");
}

TEST_CASE("TUM writer: staged as <path>.partial until Close, errors name the file", "[tum]") {
  const std::string dir = test::ScratchDir("io_tum_writer");
  const std::string path = dir + "/est.tum";
  {
    TumWriter w(path, kCentimetres, PoseCsvStaging::kPartial);
    CHECK(w.written_path() == path + ".partial");
    int written = 0;
    for (const PoseRow& r : Rows()) written += w.Write(r);
    CHECK(written == 3);
    // Each line is flushed as it comes; the file is not yet passed off as whole.
    CHECK(ReadAll(path + ".partial") == kExpected);
    CHECK(!fs::exists(path));
    w.Close();
    CHECK_THROWS_WITH(w.Write(Rows()[0]), path + ": write after close");
  }
  CHECK(ReadAll(path) == kExpected);
  CHECK(!fs::exists(path + ".partial"));
  {
    // A writer that never closes (a failed or killed run) leaves only the .partial.
    TumWriter w(dir + "/broken.tum", kCentimetres, PoseCsvStaging::kPartial);
    w.Write(Rows()[0]);
  }
  CHECK(!fs::exists(dir + "/broken.tum"));
  CHECK(fs::exists(dir + "/broken.tum.partial"));

  const std::string missing = dir + "/no_such_folder/est.tum";
  CHECK(test::ErrorOf([&] { TumWriter w(missing, kCentimetres, PoseCsvStaging::kPartial); }) ==
        missing + ".partial: cannot write: No such file or directory");
  test::ExpectError([&] { WriteTumTrajectory(missing, Rows(), kCentimetres); }, missing, {});
  CHECK(!fs::exists(dir + "/no_such_folder"));
  CHECK(test::ErrorOf([&] { TumWriter w(path, {0.0, 1.0}); }) ==
        path + ": metres_per_unit: expected a positive number");
  CHECK(test::ErrorOf([&] { TumWriter w(path, {1.0, std::nan("")}); }) ==
        path + ": z_metres: expected a finite number");
  CHECK(test::ErrorOf([&] { FormatTumLine(Rows()[1], kCentimetres); }) ==
        "TUM line of frame 1: only ok rows have a pose to write, not lost");
  // The file written before is untouched by the writers that failed.
  CHECK(ReadAll(path) == kExpected);
}

}  // namespace
}  // namespace pano

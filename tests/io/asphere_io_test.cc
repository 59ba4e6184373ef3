// Calibration files of an even-asphere mirror: model asphere with optional
// asphere_a4 / asphere_a6 keys, written only when non-zero; older models'
// files read and write as before.
#include <catch2/catch.hpp>

#include <fstream>

#include "panotrack/io/calibration.h"
#include "test_paths.h"

namespace pano {
namespace {

Calibration ConicCalibration() {
  Calibration c;
  Sensor& s = c.sensor;
  s = MakeSphereSensor(752, 480, 300, 376, 240, 1.0, 1, 1);
  s.model = MirrorModel::kConic;
  s.params.curvature_radius = 2.0;
  s.params.conic_constant = -2.2;
  s.params.vertex_distance = 6.0;
  s.params.rim_radius = 3.0;
  return c;
}

std::string WriteText(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST_CASE("asphere calibrations round-trip; terms are written only when non-zero", "[asphere_io]") {
  const std::string dir = test::ScratchDir("asphere_io");
  Calibration c = ConicCalibration();
  const std::string conic_yaml = CalibrationToYaml(c);
  CHECK(conic_yaml.find("asphere") == std::string::npos);
  c.sensor.model = MirrorModel::kAsphere;
  c.sensor.params.asphere_a4 = 0.0123456789012345;
  const std::string yaml = CalibrationToYaml(c);
  CHECK(yaml.find("model: asphere") != std::string::npos);
  CHECK(yaml.find("asphere_a4: 0.0123456789012345") != std::string::npos);
  CHECK(yaml.find("asphere_a6") == std::string::npos);
  const Calibration back = ReadCalibration(WriteText(dir, "a.yaml", yaml));
  CHECK(back.sensor.model == MirrorModel::kAsphere);
  CHECK(back.sensor.params.asphere_a4 == c.sensor.params.asphere_a4);
  CHECK(back.sensor.params.asphere_a6 == 0.0);
  CHECK(back.extras.empty());  // the terms are model keys, not extras
  c.sensor.params.asphere_a6 = -3.5e-4;
  const Calibration back2 = ReadCalibration(WriteText(dir, "b.yaml", CalibrationToYaml(c)));
  CHECK(back2.sensor.params.asphere_a6 == -3.5e-4);
  CHECK(CalibrationToYaml(back2) == CalibrationToYaml(c));
}

TEST_CASE("asphere keys need model asphere; an asphere file without them is a conic shape", "[asphere_io]") {
  const std::string dir = test::ScratchDir("asphere_io_bad");
  std::string yaml = CalibrationToYaml(ConicCalibration());
  const std::string with_term = yaml + "asphere_a4: 0.01\n";
  CHECK_THROWS_WITH(ReadCalibration(WriteText(dir, "c.yaml", with_term)),
                    Catch::Contains("asphere_a4") && Catch::Contains("only with model asphere"));
  const size_t at = yaml.find("model: conic");
  REQUIRE(at != std::string::npos);
  yaml.replace(at, 12, "model: asphere");
  const Calibration c = ReadCalibration(WriteText(dir, "d.yaml", yaml));
  CHECK(c.sensor.model == MirrorModel::kAsphere);
  CHECK(c.sensor.params.asphere_a4 == 0.0);
  CHECK(c.sensor.params.asphere_a6 == 0.0);
  // A non-convex profile is refused with the key named.
  CHECK_THROWS_WITH(ReadCalibration(WriteText(dir, "e.yaml", yaml + "asphere_a4: -0.5\n")),
                    Catch::Contains("asphere_a4/asphere_a6"));
}

}  // namespace
}  // namespace pano

// Rendering rigs with faults (decentred mirror, tilted camera and sensor,
// lens distortion): the tracer follows the general model's rays, the presets
// carry the stated faults, and the calibration file keeps them.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <unistd.h>

#include "panotrack/io/calibration.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/scene/scene.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = M_PI / 180.0;

TEST_CASE("faulty-rig presets: paper-real with the stated faults, doubled in -2x", "[faulty_rig]") {
  const SequenceCase one = MakePreset("faulty-rig");
  const SequenceCase two = MakePreset("faulty-rig-2x");
  const SequenceCase real = MakePreset("paper-real");
  CHECK(one.poses.size() == real.poses.size());
  const Sensor& s = one.calib.sensor;
  CHECK_FALSE(s.aligned());
  CHECK(s.faults.mirror_offset[0] == Approx(0.14));  // cm: 1.4 mm
  CHECK(s.faults.mirror_offset[1] == 0.0);
  CHECK(s.faults.camera_tilt[0] == Approx(0.6 * kDeg));
  CHECK(s.faults.sensor_tilt[0] == Approx(0.4 * kDeg));
  CHECK(s.params.k1 == Approx(-0.03));
  CHECK(s.params.k2 == Approx(0.005));
  const Sensor& t = two.calib.sensor;
  CHECK(t.faults.mirror_offset[0] == Approx(0.28));
  CHECK(t.faults.camera_tilt[0] == Approx(1.2 * kDeg));
  CHECK(t.faults.sensor_tilt[0] == Approx(0.8 * kDeg));
  CHECK(t.params.k1 == Approx(-0.06));
  CHECK(t.params.k2 == Approx(0.01));
  CHECK(real.calib.sensor.aligned());
}

TEST_CASE("the tracer of a rig with faults sees what the general model's rays meet", "[faulty_rig]") {
  // An exaggerated rig as well, whose rays miss the axis by centimetres.
  const char* name = GENERATE("paper-real", "faulty-rig-2x", "exaggerated");
  const bool exaggerated = std::string(name) == "exaggerated";
  SequenceCase c = MakePreset(exaggerated ? "faulty-rig-2x" : name);
  if (exaggerated) {
    c.calib.sensor.faults.mirror_offset[0] = 1.5;
    c.calib.sensor.faults.mirror_offset[1] = -1.0;
    c.calib.sensor.faults.camera_tilt[1] = 3.0 * kDeg;
    c.calib.sensor.faults.sensor_tilt[1] = -2.0 * kDeg;
  }
  const Scene scene = Scene::FromMap(c.map, true);
  RenderOptions options = c.options;
  options.supersample = 1;
  options.camera_radius_px = 0.0;  // the camera's own reflection hides the centre
  const Renderer r(c.calib.sensor, scene, c.map.sensor_height, options);
  const Sensor& s = c.calib.sensor;
  long compared = 0, differ = 0, seen = 0;
  for (const int frame : {0, 28, 56}) {
    const Pose2 pose = c.poses[static_cast<size_t>(frame)];
    const cv::Mat ids = r.SurfaceIds(pose);
    for (int v = 0; v < s.image_height; v += 3) {
      for (int u = 0; u < s.image_width; u += 3) {
        Eigen::Vector3d o, d;
        const bool on_mirror = s.backproject(Eigen::Vector2d(u, v), &o, &d);
        if (!on_mirror) {
          CHECK(ids.at<int>(v, u) == -1);
          continue;
        }
        const Eigen::Vector3d ow = WorldFromSensor(pose, c.map.sensor_height, o);
        const Eigen::Vector3d dw = WorldDirection(pose, d);
        const RayHit h = scene.Intersect(ow, dw);
        ++compared;
        if (h.surface >= 0) ++seen;
        if (h.surface != ids.at<int>(v, u)) ++differ;
      }
    }
  }
  INFO(name << ": " << compared << " pixels, " << differ << " differ");
  WARN(name << ": " << compared << " pixels, " << differ << " differ");
  CHECK(compared > 3 * 10000);
  CHECK(seen > compared * 9 / 10);
  // The table stores rays in single precision: a pixel on a surface's edge may differ.
  CHECK(differ <= 5);
}

TEST_CASE("zero faults render the aligned image bit for bit; faults move it", "[faulty_rig]") {
  const SequenceCase real = MakePreset("paper-real");
  SequenceCase faulty = MakePreset("faulty-rig");
  RenderOptions options = real.options;
  options.supersample = 1;
  options.noise_sigma = 0.0;
  const Pose2 pose = real.poses[20];
  const cv::Mat aligned = RenderStill(real.calib.sensor, real.map, pose, options);
  Sensor zero = faulty.calib.sensor;
  zero.faults = RigFaults<double>();
  zero.params.k1 = zero.params.k2 = 0.0;
  const cv::Mat again = RenderStill(zero, real.map, pose, options);
  CHECK(cv::countNonZero(aligned != again) == 0);
  const cv::Mat moved = RenderStill(faulty.calib.sensor, faulty.map, pose, options);
  CHECK(cv::countNonZero(aligned != moved) > 2000);
}

TEST_CASE("calibration files keep the faults; old files read as aligned", "[faulty_rig]") {
  const Calibration old = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  CHECK(old.sensor.aligned());
  Calibration c = MakePreset("faulty-rig").calib;
  c.sensor.faults.mirror_offset[1] = -0.031;
  c.sensor.faults.camera_tilt[1] = 0.2 * kDeg;
  c.sensor.faults.sensor_tilt[1] = -0.3 * kDeg;
  c.sensor.faults.p1 = 1e-3;
  c.sensor.faults.p2 = -2e-4;
  c.sensor.faults.k3 = 3e-4;
  const fs::path dir = fs::temp_directory_path() / ("pano_faulty_rig_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "calib.yaml").string();
  WriteCalibration(path, c);
  const Calibration back = ReadCalibration(path);
  fs::remove_all(dir);
  const RigFaults<double>& a = c.sensor.faults;
  const RigFaults<double>& b = back.sensor.faults;
  for (int i = 0; i < 2; ++i) {
    CHECK(b.mirror_offset[i] == a.mirror_offset[i]);
    CHECK(b.camera_tilt[i] == a.camera_tilt[i]);
    CHECK(b.sensor_tilt[i] == a.sensor_tilt[i]);
  }
  CHECK(b.p1 == a.p1);
  CHECK(b.p2 == a.p2);
  CHECK(b.k3 == a.k3);
  CHECK(back.sensor.params.k1 == c.sensor.params.k1);
  CHECK(back.sensor.params.k2 == c.sensor.params.k2);
  // An aligned rig's file has none of the new keys.
  CHECK(CalibrationToYaml(old).find("mirror_offset") == std::string::npos);
  CHECK(CalibrationToYaml(c).find("mirror_offset: [0.14, -0.031]") != std::string::npos);
}

}  // namespace
}  // namespace pano

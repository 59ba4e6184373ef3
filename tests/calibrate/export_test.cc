// panocalib export --opencv: the pinhole in OpenCV's terms exactly, and the
// cv::omnidir approximation of the whole sensor with its stated error.
#include <catch2/catch.hpp>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <filesystem>

#include "panotrack/calibrate/export_opencv.h"
#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

TEST_CASE("export: OpenCV camera matrix of the pinhole, omnidir approximation", "[export_opencv]") {
  const Calibration c = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const Sensor& s = c.sensor;
  const OmnidirApproximation om = FitOmnidirApproximation(s, OmnidirApproximationOptions());
  INFO("xi " << om.xi << " rms " << om.rms_px << " max " << om.max_px << " samples " << om.samples);
  CHECK(om.samples > 2000);
  // A spherical mirror is far from Mei's model's single viewpoint near the
  // limb: the approximation is stated, not hidden (measured 0.47 px RMS,
  // 1.60 px at most, xi 1.293).
  CHECK(om.rms_px < 0.52);
  CHECK(om.max_px < 1.75);
  CHECK(om.xi == Approx(1.293).margin(0.01));
  // The approximation at the distance it was fitted for, on a point the
  // samples did not contain.
  const Eigen::Vector3d far_point(0.3 * om.distance, 0.954 * om.distance, 0.05 * om.distance);
  Eigen::Vector2d exact, approx;
  REQUIRE(s.project(far_point, &exact));
  REQUIRE(ProjectOmnidir(om, far_point, &approx));
  CHECK((exact - approx).norm() < 3.0 * om.rms_px + 0.05);

  const std::string dir = test::ScratchDir("calib_export");
  const std::string path = dir + "/paper-real.yml";
  fs::remove(path);
  WriteOpenCvCalibration(path, c, om);
  cv::FileStorage in(path, cv::FileStorage::READ);
  REQUIRE(in.isOpened());
  cv::Mat K, dist;
  in["camera_matrix"] >> K;
  in["distortion_coefficients"] >> dist;
  CHECK(static_cast<int>(in["image_width"]) == s.image_width);
  // The pinhole in OpenCV's terms: a point on the mirror appears through
  // cv::projectPoints where the sensor model puts the rays it reflects.
  for (const Eigen::Vector2d& pixel : {Eigen::Vector2d(s.params.cx + 60, s.params.cy + 25),
                                      Eigen::Vector2d(s.params.cx - 10, s.params.cy - 90)}) {
    Eigen::Vector3d origin, direction;
    REQUIRE(s.backproject(pixel, &origin, &direction));
    std::vector<cv::Point3d> object = {cv::Point3d(origin.x(), origin.y(), origin.z())};
    std::vector<cv::Point2d> image;
    cv::projectPoints(object, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, image);
    CHECK(image[0].x == Approx(pixel.x()).margin(1e-6));
    CHECK(image[0].y == Approx(pixel.y()).margin(1e-6));
  }
  CHECK(static_cast<double>(in["omnidir_xi"]) == om.xi);
  CHECK(static_cast<double>(in["omnidir_rms_px"]) == om.rms_px);
  // Anything but a FileStorage name is refused.
  CHECK_THROWS_WITH(WriteOpenCvCalibration(dir + "/x.txt", c, om), Catch::Contains("x.txt"));
}

TEST_CASE("export: panocalib export refuses to replace a file without --force", "[export_opencv]") {
  const std::string dir = test::ScratchDir("calib_export_cli");
  const std::string out = dir + "/c.yml";
  fs::remove(out);
  const std::string calib = test::SourcePath("calib/paper-real.yaml");
  test::CommandRun r = test::RunProgram("panocalib export --opencv --calib " + calib + " -o " + out);
  CHECK(r.code == 0);
  CHECK(r.out.find("omnidir approximation") != std::string::npos);
  r = test::RunProgram("panocalib export --opencv --calib " + calib + " -o " + out);
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: " + out + " exists (use --force to replace it)\n");
  CHECK(test::RunProgram("panocalib export --opencv --force --calib " + calib + " -o " + out).code == 0);
}

}  // namespace
}  // namespace pano

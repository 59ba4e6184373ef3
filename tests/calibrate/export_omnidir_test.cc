// The exported omnidir model is OpenCV's own: cv::omnidir::projectPoints with
// the exported K, xi, D puts a point (in the omnidir frame) where the
// approximation does.
#include <catch2/catch.hpp>

#include <opencv2/ccalib/omnidir.hpp>

#include "panotrack/calibrate/export_opencv.h"
#include "panotrack/io/calibration.h"
#include "test_paths.h"

namespace pano {
namespace {

TEST_CASE("export: the omnidir approximation is cv::omnidir's projection", "[export_omnidir]") {
  for (const char* name : {"calib/paper-real.yaml", "calib/paper-synthetic.yaml"}) {
    const Calibration c = ReadCalibration(test::SourcePath(name));
    const OmnidirApproximation om = FitOmnidirApproximation(c.sensor, OmnidirApproximationOptions());
    const cv::Matx33d K(om.fx, 0, om.cx, 0, om.fy, om.cy, 0, 0, 1);
    const cv::Vec4d D(om.k1, om.k2, om.p1, om.p2);
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(300, 40, 10), Eigen::Vector3d(-120, 250, -60),
                                     Eigen::Vector3d(5, -400, 80)}) {
      Eigen::Vector2d ours;
      REQUIRE(ProjectOmnidir(om, p, &ours));
      const Eigen::Vector3d q = om.omnidir_from_sensor * p;
      std::vector<cv::Vec3d> object = {cv::Vec3d(q.x(), q.y(), q.z())};
      std::vector<cv::Vec2d> image;
      cv::omnidir::projectPoints(object, image, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, om.xi, D);
      CHECK(image[0][0] == Approx(ours.x()).margin(1e-9));
      CHECK(image[0][1] == Approx(ours.y()).margin(1e-9));
    }
  }
}

}  // namespace
}  // namespace pano

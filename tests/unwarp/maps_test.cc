// The remap tables are the sensor's exact projection of the points the view
// pixels stand for; the defaults follow from the mirror.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "panotrack/render/presets.h"
#include "panotrack/unwarp/unwarp.h"
#include "test_rng.h"

namespace pano {
namespace {

Sensor PaperSensor(double azimuth_offset) {
  Sensor s = PaperSyntheticCalibration().sensor;
  s.params.azimuth_offset = azimuth_offset;
  return s;
}

// A conic mirror seen through a distorting lens with non-square pixels.
Sensor ConicSensor() {
  Sensor s = MakeSphereSensor(752, 480, 400, 370.2, 242.7, 1.03, 3.0, 9.0, -2.0);
  s.model = MirrorModel::kConic;
  s.params.conic_constant = -0.4;
  s.params.k1 = 0.02;
  s.params.k2 = -0.003;
  s.Check("test sensor");
  return s;
}

TEST_CASE("map entries are the projections of the view pixels' points", "[round_trip]") {
  PANO_SEEDED_RNG(31);
  const Sensor sensor = GENERATE(as<int>{}, 0, 1) == 0 ? PaperSensor(-0.7) : ConicSensor();
  UnwarpOptions o;
  SECTION("panorama, infinitely far") {}
  SECTION("panorama, clockwise, cylinder of radius 40, 600 x 200") {
    o.clockwise = true;
    o.distance = 40;
    o.width = 600;
    o.height = 200;
  }
  SECTION("perspective, infinitely far") {
    o.kind = UnwarpKind::kPerspective;
    o.yaw_deg = 123;
    o.pitch_deg = 10;
    o.width = 320;
    o.height = 200;
  }
  SECTION("perspective, plane at depth 25, looking down") {
    o.kind = UnwarpKind::kPerspective;
    o.yaw_deg = -40;
    o.pitch_deg = -35;
    o.fov_deg = 100;
    o.distance = 25;
    o.width = 200;
    o.height = 200;
  }
  SECTION("panorama reaching above the limb and down to the camera") {
    o.min_elevation_deg = -89;
    o.max_elevation_deg = 89;
  }
  SECTION("perspective looking up past the limb") {
    o.kind = UnwarpKind::kPerspective;
    o.pitch_deg = 70;
    o.fov_deg = 120;
    o.distance = 30;
  }
  const UnwarpView view(sensor, o);
  cv::Mat mx, my;
  view.InitMaps(&mx, &my);
  REQUIRE(mx.type() == CV_32FC1);
  REQUIRE(mx.size() == cv::Size(view.width(), view.height()));
  std::uniform_int_distribution<int> col(0, view.width() - 1), row(0, view.height() - 1);
  int visible = 0, hidden = 0, mismatched_validity = 0;
  double worst = 0.0, worst_inverse = 0.0;
  for (int i = 0; i < 4000; ++i) {
    const int c = col(rng), r = row(rng);
    const Eigen::Vector3d p = view.PointOfPixel(c, r);
    Eigen::Vector2d px;
    const bool ok = sensor.project(p, &px);
    const float u = mx.at<float>(r, c), v = my.at<float>(r, c);
    if (ok != (u != kUnwarpOutside)) ++mismatched_validity;
    if (!ok) {
      ++hidden;
      CHECK(v == kUnwarpOutside);
      continue;
    }
    ++visible;
    worst = std::max({worst, std::abs(u - px.x()), std::abs(v - px.y())});
    if (o.kind == UnwarpKind::kPerspective) {  // the same computation: equal to the float
      CHECK(u == static_cast<float>(px.x()));
      CHECK(v == static_cast<float>(px.y()));
    }
    Eigen::Vector2d back;
    REQUIRE(view.PixelOfPoint(p, &back));
    worst_inverse = std::max({worst_inverse, std::abs(back.x() - c), std::abs(back.y() - r)});
  }
  INFO("visible " << visible << " hidden " << hidden << " worst " << worst << " px, inverse " << worst_inverse << " px");
  CHECK(mismatched_validity == 0);
  CHECK(visible > 1000);
  CHECK(worst < 3.1e-5);  // half a float's step below 1024: the rounding to float
  CHECK(worst_inverse < 1e-7);
}

TEST_CASE("defaults come from the mirror", "[defaults]") {
  const Sensor sensor = PaperSensor(0.0);
  // Where the horizon's reflected rays cross the axis, and the mirror's limb.
  CHECK(HorizonEyeHeight(sensor) == Approx(11.2149).margin(1e-3));
  CHECK(OuterImageRadius(sensor) == Approx(sensor.limb_radius()).epsilon(1e-12));
  double e;
  REQUIRE(RayElevationAtRadius(sensor, 157.0895, &e));
  CHECK(e == Approx(0.0).margin(1e-4));  // the horizon (E(inf, 0) = 157.089 px)
  CHECK(!RayElevationAtRadius(sensor, 203.0, &e));  // beyond the limb

  const UnwarpView pano(sensor, UnwarpOptions{});
  CHECK(pano.width() == 1272);  // 2 pi x 202.4 px
  CHECK(pano.max_elevation() * 180 / M_PI == Approx(49.67).margin(0.01));
  CHECK(pano.min_elevation() * 180 / M_PI == Approx(-48.28).margin(0.01));
  CHECK(pano.height() == 347);  // square pixels in angle
  CHECK(std::isinf(pano.distance()));

  UnwarpOptions po;
  po.kind = UnwarpKind::kPerspective;
  const UnwarpView persp(sensor, po);
  CHECK(persp.width() == 640);
  CHECK(persp.height() == 480);
  CHECK(persp.focal_px() == Approx(320.0 / std::tan(M_PI / 6)));
  // The optical axis's pixel sees straight ahead.
  const Eigen::Vector3d ahead = persp.PointOfPixel(319.5, 239.5);
  CHECK(ahead.y() == Approx(0.0).margin(1e-6 * ahead.norm()));
  CHECK(ahead.z() == Approx(HorizonEyeHeight(sensor)).margin(1e-6 * ahead.norm()));
  CHECK(ahead.x() > 0);
  // Right of the image centre is clockwise (bearing below yaw), up is up.
  CHECK(persp.PointOfPixel(600, 239.5).y() < 0);
  CHECK(persp.PointOfPixel(319.5, 10).z() > ahead.z());

  // A hyperbolic mirror with the pinhole at its outer focus has a single
  // viewpoint, its inner focus (2 a e above the pinhole): the eye lands there
  // and the views are exact at every distance.
  Sensor hyper = MakeSphereSensor(600, 600, 300, 299.5, 299.5, 1.0, 2.0, 2.0);
  hyper.model = MirrorModel::kConic;
  const double ecc = 1.5, a = 2.0 / (ecc * ecc - 1.0);
  hyper.params.conic_constant = -ecc * ecc;
  hyper.params.vertex_distance = a * (1.0 + ecc);
  hyper.params.rim_radius = 4.0;
  hyper.Check("hyperbolic test sensor");
  CHECK(HorizonEyeHeight(hyper) == Approx(2.0 * a * ecc).epsilon(1e-9));
  const UnwarpView far_view(hyper, UnwarpOptions{});
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(10, 3, 2), Eigen::Vector3d(-30, 70, -20), Eigen::Vector3d(3, -4, 5)}) {
    INFO("point " << p.transpose());
    Eigen::Vector2d at_view, direct, through_view;
    REQUIRE(far_view.PixelOfPoint(p, &at_view));
    REQUIRE(hyper.project(p, &direct));
    REQUIRE(hyper.project(far_view.PointOfPixel(at_view.x(), at_view.y()), &through_view));
    CHECK((direct - through_view).norm() < 1e-6);
  }

  // Unwarping a 3-channel 16-bit image keeps its type; off-mirror pixels get the border value.
  UnwarpOptions bo;
  bo.border_value = cv::Scalar(1, 2, 3);
  const cv::Mat raw(sensor.image_height, sensor.image_width, CV_16UC3, cv::Scalar(100, 200, 300));
  const cv::Mat out = UnwarpImage(raw, sensor, bo);
  CHECK(out.type() == CV_16UC3);
  CHECK(out.at<cv::Vec3w>(out.rows / 2, 10) == cv::Vec3w(100, 200, 300));
  bo.max_elevation_deg = 80;  // above the limb: off the mirror
  const cv::Mat top = UnwarpImage(raw, sensor, bo);
  CHECK(top.at<cv::Vec3w>(0, 10) == cv::Vec3w(1, 2, 3));
}

}  // namespace
}  // namespace pano

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <random>

#include "panotrack/core/error.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"
#include "test_paths.h"
#include "test_rng.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/track/vertex_tracker.h"

namespace pano {
namespace {

Sensor SyntheticSensor() { return PaperSyntheticCalibration().sensor; }

// Bilinear interpolation of a CV_32FC1 map at (x, y).
double Bilinear(const cv::Mat& m, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int yy, int xx) { return static_cast<double>(m.at<float>(yy, xx)); };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
}

// An image of `sensor`'s size, grey `background`, with the polar region
// radius in [r_lo, r_hi] x azimuth in [a_lo, a_hi] (wrapping; span below pi) of grey `face`,
// anti-aliased by 8 x 8 subsamples near the region.
cv::Mat PolarPatch(const Sensor& s, double r_lo, double r_hi, double a_lo, double a_hi, double face,
                   double background) {
  cv::Mat img(s.image_height, s.image_width, CV_8UC1, cv::Scalar(background));
  const int ss = 8;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u) {
      double r, a;
      s.to_polar(u, v, &r, &a);
      if (r < r_lo - 2 || r > r_hi + 2) continue;
      int inside = 0;
      for (int i = 0; i < ss; ++i)
        for (int j = 0; j < ss; ++j) {
          s.to_polar(u - 0.5 + (i + 0.5) / ss, v - 0.5 + (j + 0.5) / ss, &r, &a);
          const double da = WrapAngle(a - a_lo), span = WrapAngle(a_hi - a_lo);
          inside += r >= r_lo && r <= r_hi && da >= 0 && da <= span;
        }
      const double f = static_cast<double>(inside) / (ss * ss);
      img.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(f * face + (1 - f) * background);
    }
  return img;
}

TEST_CASE("the view's geometry: horizon width, maps, round trips, padding", "[warp]") {
  const Sensor s = SyntheticSensor();
  const double rad_h = HorizonRadius(s);
  CHECK(rad_h == Approx(157.2).margin(0.3));  // the paper's rad_h = 157 px
  const QuasiCylindricalView view(s, 30.0, s.limb_radius() + 10.0, 20);
  CHECK(view.width() == static_cast<int>(std::lround(2 * M_PI * rad_h)));
  CHECK(view.cols() == view.width() + 40);
  CHECK(view.rows() >= static_cast<int>(s.limb_radius() - 30.0));

  PANO_SEEDED_RNG(7);
  std::uniform_real_distribution<double> ur(35.0, s.limb_radius()), ua(-M_PI, M_PI);
  for (int k = 0; k < 500; ++k) {
    const double r = ur(rng), a = ua(rng);
    const Eigen::Vector2d px = s.from_polar(r, a);
    const double x = view.x_of_azimuth(a), y = view.y_of_radius(r);
    INFO("r " << r << " azimuth " << a << " -> x " << x << " y " << y);
    REQUIRE(x >= view.pad());
    REQUIRE(x < view.pad() + view.width());
    CHECK(std::abs(WrapAngle(view.azimuth_of_x(x) - a)) < 1e-12);
    CHECK(view.radius_of_y(y) == Approx(r).margin(1e-12));
    // The maps, interpolated at the view position, give the pixel back.
    CHECK(std::abs(Bilinear(view.map_u(), x, y) - px.x()) < 0.003);
    CHECK(std::abs(Bilinear(view.map_v(), x, y) - px.y()) < 0.003);
  }
  // Columns at whole azimuths: exact; padding repeats the other end.
  for (int y = 0; y < view.rows(); y += 17)
    for (int x = 0; x < view.cols(); x += 13) {
      const Eigen::Vector2d px = s.from_polar(view.radius_of_y(y), view.azimuth_of_x(x));
      CHECK(std::abs(view.map_u().at<float>(y, x) - px.x()) < 5e-5);
      CHECK(std::abs(view.map_v().at<float>(y, x) - px.y()) < 5e-5);
      if (x < view.pad()) {
        CHECK(view.map_u().at<float>(y, x) == view.map_u().at<float>(y, x + view.width()));
        CHECK(view.map_v().at<float>(y, x) == view.map_v().at<float>(y, x + view.width()));
      }
    }
}

TEST_CASE("the warp interpolates the frame bilinearly at the maps' points", "[warp]") {
  const Sensor s = SyntheticSensor();
  const QuasiCylindricalView view(s, 30.0, s.limb_radius() + 10.0, 20);
  // Frames linear in u (then v) up to 255: bilinear interpolation is exact there.
  for (int axis = 0; axis < 2; ++axis) {
    cv::Mat grey(s.image_height, s.image_width, CV_8UC1);
    for (int v = 0; v < grey.rows; ++v)
      for (int u = 0; u < grey.cols; ++u) grey.at<uint8_t>(v, u) = static_cast<uint8_t>(std::min(axis ? v : u, 255));
    cv::Mat warped;
    view.Warp(grey, &warped);
    REQUIRE(warped.type() == CV_32FC1);
    REQUIRE(warped.rows == view.rows());
    REQUIRE(warped.cols == view.cols());
    int checked = 0;
    for (int y = 0; y < view.rows(); ++y)
      for (int x = 0; x < view.cols(); ++x) {
        const double expect = (axis ? view.map_v() : view.map_u()).at<float>(y, x);
        const double other = (axis ? view.map_u() : view.map_v()).at<float>(y, x);
        if (expect < 0.0 || expect > 253.0 || other < 0.0 || other > s.image_width - 1.0) continue;
        ++checked;
        INFO("view (" << x << ", " << y << ")");
        CHECK(std::abs(warped.at<float>(y, x) - expect) < 5e-5);
      }
    CHECK(checked > 20000);
  }
  // A window warped on its own equals that part of the whole view.
  {
    const cv::Mat img = PolarPatch(s, 100.0, 150.0, 2.9, 3.3, 220.0, 30.0);
    cv::Mat whole, padded, part;
    view.Warp(img, &whole);
    view.PadFrame(img, &padded);
    for (int x0 : {0, 400, view.cols() - 37}) {
      view.WarpRegion(padded, x0, 60, 37, 25, &part);
      CHECK(cv::norm(part, whole(cv::Rect(x0, 60, 37, 25)), cv::NORM_INF) == 0.0);
    }
  }
  // Outside the frame: 0; a wrong frame is refused.
  cv::Mat white(s.image_height, s.image_width, CV_8UC1, cv::Scalar(255)), warped;
  view.Warp(white, &warped);
  CHECK(warped.at<float>(view.rows() / 2, view.cols() / 2) == Approx(255.0f));
  CHECK_THROWS_AS(view.Warp(cv::Mat(10, 10, CV_8UC1), &warped), Error);
}

TEST_CASE("each of the 8 corner types is found at its sub-pixel position", "[corner_types]") {
  const Sensor s = SyntheticSensor();
  VertexTracker tracker(s, VertexOptions());
  const double r_c = 118.37;
  int k = 0;
  for (int x_sign : {-1, 1})
    for (int y_sign : {-1, 1})
      for (int lighter : {0, 1}) {
        // Spread the corners round the image, one across the azimuth wrap.
        const double a_c = k == 5 ? M_PI - 0.05 : WrapAngle(-2.9 + 0.73 * k + 0.013);
        ++k;
        const double len = 40.0, span = 0.3;
        const double r_lo = y_sign > 0 ? r_c : r_c - len, r_hi = y_sign > 0 ? r_c + len : r_c;
        const double a_lo = x_sign > 0 ? a_c : a_c - span, a_hi = x_sign > 0 ? a_c + span : a_c;
        const cv::Mat img = PolarPatch(s, r_lo, r_hi, a_lo, a_hi, lighter ? 210.0 : 40.0, 120.0);
        tracker.BeginFrame(img);
        PredictedLandmark p;
        p.corner_radius = r_c + 1.6;             // predicted a little off
        p.azimuth = WrapAngle(a_c - 2.2 / r_c);  // ~2 px tangentially
        p.v_radius = r_c + y_sign * len;
        p.h_end_azimuth = WrapAngle(a_c + x_sign * span);
        p.inside_azimuth_sign = x_sign;
        p.inside_radius_sign = y_sign;
        p.v_polarity = p.h_polarity = lighter ? 1 : -1;
        INFO("type: face towards x " << x_sign << ", y " << y_sign << (lighter ? ", lighter" : ", darker")
                                     << "; corner azimuth " << a_c);
        const LandmarkMeasurement m = tracker.Measure(p, 5.0);
        REQUIRE(m.found);
        CHECK(std::abs(WrapAngle(m.azimuth - a_c)) * r_c < 0.3);
        CHECK(std::abs(m.radius - r_c) < 0.3);
        // The opposite shade is not this corner.
        p.v_polarity = p.h_polarity = lighter ? -1 : 1;
        CHECK_FALSE(tracker.Measure(p, 5.0).found);
      }
}

TEST_CASE("a straight edge or a flat patch is not a corner; a mixed corner is", "[corner_types]") {
  const Sensor s = SyntheticSensor();
  VertexTracker tracker(s, VertexOptions());
  PredictedLandmark p;
  p.corner_radius = 120.0;
  p.azimuth = 0.5;
  p.v_radius = 160.0;
  p.h_end_azimuth = 0.8;
  p.inside_azimuth_sign = p.inside_radius_sign = 1;
  p.v_polarity = p.h_polarity = 1;
  // A radial edge: brighter towards +azimuth over all radii.
  tracker.BeginFrame(PolarPatch(s, 0.0, 400.0, 0.5, 1.2, 200.0, 100.0));
  LandmarkMeasurement m = tracker.Measure(p, 6.0);
  CHECK_FALSE(m.found);
  tracker.BeginFrame(cv::Mat(s.image_height, s.image_width, CV_8UC1, cv::Scalar(90)));
  CHECK_FALSE(tracker.Measure(p, 6.0).found);
  // Face lighter than what lies across its vertical edge, darker than what
  // lies across its horizontal edge (the floor, say): a three-level corner.
  cv::Mat base, cover, img;
  PolarPatch(s, 0.0, 120.0, -1.0, 2.0, 230.0, 60.0).convertTo(base, CV_32F);  // below the corner
  PolarPatch(s, 120.0, 160.0, 0.5, 0.8, 255.0, 0.0).convertTo(cover, CV_32F, 1.0 / 255);  // the face
  cv::Mat blend = base.mul(1.0 - cover) + 150.0 * cover;
  blend.convertTo(img, CV_8U);
  p.v_polarity = 1;
  p.h_polarity = -1;
  tracker.BeginFrame(img);
  m = tracker.Measure(p, 4.0);
  REQUIRE(m.found);
  CHECK(std::abs(WrapAngle(m.azimuth - 0.5)) * 120.0 < 0.12);
}

TEST_CASE("two like corners in one window: the best wins unless a margin is asked", "[corner_types]") {
  const Sensor s = SyntheticSensor();
  cv::Mat a, b, img;
  PolarPatch(s, 120.0, 160.0, 0.50, 0.80, 200.0, 100.0).convertTo(a, CV_32F);
  PolarPatch(s, 120.0, 160.0, 0.58, 0.80, 200.0, 100.0).convertTo(b, CV_32F);
  // A second, fainter face beside the first: its corner 0.08 rad (~12 columns) on.
  cv::Mat both = a + 0.8 * (b - 100.0);
  both.convertTo(img, CV_8U);
  PredictedLandmark p;
  p.corner_radius = 120.0;
  p.azimuth = 0.54;
  p.v_radius = 160.0;
  p.h_end_azimuth = 0.8;
  p.inside_azimuth_sign = p.inside_radius_sign = 1;
  p.v_polarity = p.h_polarity = 1;
  VertexOptions paper;
  paper.min_peak_margin = 0.0;  // the paper's rule: the best response wins
  VertexTracker plain(s, paper);
  plain.BeginFrame(img);
  const LandmarkMeasurement m = plain.Measure(p, 10.0);
  REQUIRE(m.found);
  CHECK(std::abs(WrapAngle(m.azimuth - 0.50)) * 120.0 < 0.04);
  VertexOptions o;
  o.min_peak_margin = 0.3;
  VertexTracker strict(s, o);
  strict.BeginFrame(img);
  CHECK_FALSE(strict.Measure(p, 10.0).found);
}

TEST_CASE("vertex options are checked", "[options]") {
  VertexOptions o;
  CHECK_NOTHROW(o.Check());
  o.min_score = 1.5;
  CHECK_THROWS_AS(o.Check(), Error);
  o = VertexOptions();
  o.max_half_px = 1;
  CHECK_THROWS_AS(o.Check(), Error);
  o = VertexOptions();
  o.inner_radius_fraction = -0.1;
  CHECK_THROWS_AS(o.Check(), Error);
  LocalizerOptions lo;
  lo.vertex.max_search_warped_px = 0;
  CHECK_THROWS_AS(lo.Check(), Error);
  lo = LocalizerOptions();
  lo.method = TrackingMethod::kVertex;
  CHECK(std::string(TrackingMethodName(lo.method)) == "vertex");
  const Sensor s = SyntheticSensor();
  CHECK(dynamic_cast<VertexTracker*>(MakeTracker(lo.method, s, nullptr, lo).get()) != nullptr);
}

TEST_CASE("panoloc's runner with the vertex method on 14 frames of paper-synthetic", "[end_to_end]") {
  SequenceCase c = MakePreset("paper-synthetic");
  c.poses.resize(14);
  const std::string dir = test::ScratchDir("track_vertex_e2e") + "/case";
  SequenceWriteOptions wo;
  wo.frames = true;
  wo.video = false;
  WriteSequence(c, dir, wo);
  PanolocOptions o;
  o.inputs = {dir + "/frames"};
  o.output = dir + "/est.csv";
  o.calib_path = dir + "/calib.yaml";
  o.map_path = dir + "/map.yaml";
  o.gt = dir + "/gt.csv";
  o.quiet = true;
  o.localizer.method = TrackingMethod::kVertex;
  const std::vector<VideoSummary> out = RunPanoloc(o);
  REQUIRE(out.size() == 1);
  const VideoSummary& v = out[0];
  INFO(v.error);
  REQUIRE(v.ok);
  INFO(FormatAccuracy(v.accuracy, "units"));
  CHECK(v.frames == 14);
  CHECK(v.n_ok == 14);
  CHECK(v.n_lost == 0);
  REQUIRE(v.has_accuracy);
  CHECK(v.accuracy.compared == 14);
  CHECK(v.accuracy.std <= 0.01);  // measured 0.0050 (the paper reports 0.5)
  CHECK(v.accuracy.rms <= 0.01);  // measured 0.0051
  CHECK(v.accuracy.outliers == 0);
  const std::vector<PoseRow> rows = ReadPoseCsv(o.output);
  CHECK(rows.size() == 14);
  std::filesystem::remove_all(std::filesystem::path(dir).parent_path());
}

}  // namespace
}  // namespace pano

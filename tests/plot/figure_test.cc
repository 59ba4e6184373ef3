// The plotting helpers: 1-2-5 tick steps and values, limits, labels, the
// data-to-pixel transform with and without equal aspect, and label placement
// that never overlaps.
#include <catch2/catch.hpp>

#include <opencv2/imgproc.hpp>

#include "panotrack/plot/figure.h"

namespace pano {
namespace {

TEST_CASE("ticks: 1-2-5 steps, values on the step, decimals, labels", "[ticks]") {
  CHECK(NiceStep(10, 5) == 2);
  CHECK(NiceStep(7, 5) == 2);    // 1.4 -> 2
  CHECK(NiceStep(12, 5) == 5);   // 2.4 -> 5
  CHECK(NiceStep(30, 5) == 10);  // 6 -> 10
  CHECK(NiceStep(1, 5) == 0.2);
  CHECK(NiceStep(0.03, 6) == 0.005);
  CHECK(NiceStep(100, 4) == 50);  // 25 -> 50
  CHECK(NiceStep(0, 5) == 1);
  CHECK(NiceStep(std::nan(""), 5) == 1);

  const Ticks a = NiceTicks(0, 10, 5);
  CHECK(a.step == 2);
  CHECK(a.values == std::vector<double>{0, 2, 4, 6, 8, 10});
  CHECK(a.decimals == 0);
  const Ticks b = NiceTicks(-0.1, 0.1, 4);
  CHECK(b.step == 0.05);
  CHECK(b.values == std::vector<double>{-0.1, -0.05, 0, 0.05, 0.1});
  CHECK(b.decimals == 2);
  const Ticks c = NiceTicks(-3.7, 161.2, 8);  // 20.6 -> 50
  CHECK(c.values == std::vector<double>{0, 50, 100, 150});
  // An empty range is widened by 10 % about its value: [2.88, 3.52].
  const Ticks d = NiceTicks(3.2, 3.2, 5);
  CHECK(d.step == 0.2);
  CHECK(d.values == std::vector<double>{3.0, 3.2, 3.4});
  CHECK(d.decimals == 1);
  const Ticks z = NiceTicks(0, 0, 4);  // [-1, 1]
  CHECK(z.values == std::vector<double>{-1, -0.5, 0, 0.5, 1});

  double lo = 0.013, hi = 0.087;
  NiceLimits(&lo, &hi, 4);
  CHECK(lo == 0.0);
  CHECK(hi == 0.1);
  lo = -0.27;
  hi = 0.31;
  NiceLimits(&lo, &hi, 4);  // step 0.2
  CHECK(lo == -0.4);
  CHECK(hi == 0.4);

  CHECK(NiceFloor(37) == 20);
  CHECK(NiceFloor(5) == 5);
  CHECK(NiceFloor(0.7) == 0.5);
  CHECK(NiceFloor(1) == 1);
  CHECK(NiceFloor(9.99) == 5);
  CHECK(NiceFloor(0) == 0);
  CHECK(NiceFloor(-2) == 0);

  CHECK(FormatTick(0.05, 2) == "0.05");
  CHECK(FormatTick(-0.0001, 2) == "0.00");  // never "-0.00"
  CHECK(FormatTick(-0.5, 1) == "-0.5");
  CHECK(FormatTick(150, 0) == "150");
}

TEST_CASE("transform: data to pixels, y up, equal aspect widens the stretched axis", "[transform]") {
  const cv::Rect2d area(10, 20, 200, 100);
  const PlotTransform plain(area, 0, 10, 0, 10, false);
  CHECK(plain.px_per_unit_x() == 20);
  CHECK(plain.px_per_unit_y() == 10);
  CHECK(plain.ToPixel(0, 0) == cv::Point2d(10, 120));
  CHECK(plain.ToPixel(10, 10) == cv::Point2d(210, 20));
  CHECK(plain.ToPixel(5, 2.5) == cv::Point2d(110, 95));

  // 20 px/unit along x, 10 along y: x is widened to 20 units about 5.
  const PlotTransform equal(area, 0, 10, 0, 10, true);
  CHECK(equal.px_per_unit_x() == 10);
  CHECK(equal.px_per_unit_y() == 10);
  CHECK(equal.x_lo() == -5);
  CHECK(equal.x_hi() == 15);
  CHECK(equal.y_lo() == 0);
  CHECK(equal.y_hi() == 10);
  CHECK(equal.ToPixel(0, 0) == cv::Point2d(60, 120));
  CHECK(equal.ToPixel(10, 10) == cv::Point2d(160, 20));
  const Eigen::Vector2d back = equal.ToData(cv::Point2d(60, 120));
  CHECK(back.x() == 0);
  CHECK(back.y() == 0);
  CHECK(equal.ToData(cv::Point2d(135, 45)) == Eigen::Vector2d(7.5, 7.5));

  // A tall area: y is widened instead.
  const PlotTransform tall(cv::Rect2d(0, 0, 100, 300), 0, 10, 0, 10, true);
  CHECK(tall.y_lo() == -10);
  CHECK(tall.y_hi() == 20);
  CHECK(tall.ToPixel(0, 0) == cv::Point2d(0, 200));

  // An empty range is widened (by 10 % of the value) rather than dividing by zero.
  const PlotTransform flat(area, 3, 3, 0, 10, false);
  CHECK(flat.x_lo() == Approx(2.7).epsilon(1e-12));
  CHECK(flat.x_hi() == Approx(3.3).epsilon(1e-12));
  CHECK(flat.ToPixel(3, 0).x == Approx(110).epsilon(1e-12));
}

TEST_CASE("labels: placed without overlap, skipped when nothing fits, names shortened from the left", "[labels]") {
  const TextStyle style;
  cv::Mat canvas(100, 200, CV_8UC3, cv::Scalar(255, 255, 255));
  LabelPlacer placer(cv::Rect(0, 0, 200, 100));
  // The first choice is right of the point, vertically centred.
  const cv::Rect first = placer.Find("abc", {100, 50}, style, 4);
  CHECK(first == TextBox("abc", {104, 50}, Anchor::kLeft, style));
  std::vector<cv::Rect> boxes;
  int placed = 0;
  for (int i = 0; i < 40; ++i) {
    const cv::Rect box = placer.Find("label", {100, 50}, style, 4);
    if (box.area() == 0) break;
    CHECK(placer.Place(&canvas, "label", {100, 50}, style, 4));
    for (const cv::Rect& b : boxes) CHECK((b & box).area() == 0);
    CHECK((box & cv::Rect(0, 0, 200, 100)) == box);
    boxes.push_back(box);
    ++placed;
  }
  // Around one point there are a limited number of places, then labels are skipped.
  CHECK(placed >= 4);
  CHECK(placed < 40);
  CHECK_FALSE(placer.Place(&canvas, "label", {100, 50}, style, 4));
  // A label that fits nowhere in the bounds.
  LabelPlacer tiny(cv::Rect(0, 0, 20, 10));
  CHECK_FALSE(tiny.Place(&canvas, "too long to fit", {10, 5}, style, 2));
  // Something was drawn.
  cv::Mat grey;
  cv::cvtColor(canvas, grey, cv::COLOR_BGR2GRAY);
  CHECK(cv::countNonZero(grey < 128) > 0);

  CHECK(ShortenLeft("cal_001.png", 500, style) == "cal_001.png");
  const std::string s = ShortenLeft("a/very/long/folder/name/cal_001.png", 100, style);
  CHECK(s.substr(0, 3) == "...");
  CHECK(s.substr(s.size() - 11) == "cal_001.png");
  CHECK(TextBox(s, {0, 0}, Anchor::kTopLeft, style).width <= 100);
}

}  // namespace
}  // namespace pano

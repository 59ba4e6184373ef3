#include "panotrack/plot/figure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace pano {

namespace {

// A 1-2-5 step as mantissa x 10^exponent, so that multiples are computed as
// k * m / 10^-e (exact decimal values print and compare as expected).
struct Step {
  int mantissa = 1;
  int exponent = 0;
  double value() const { return Scaled(1.0); }
  double Scaled(double k) const {
    return exponent >= 0 ? k * mantissa * std::pow(10.0, exponent) : k * mantissa / std::pow(10.0, -exponent);
  }
};

Step NiceStepOf(double range, int target_count) {
  Step s;
  if (!(range > 0) || !std::isfinite(range) || target_count < 1) return s;
  const double raw = range / target_count;
  int e = static_cast<int>(std::floor(std::log10(raw)));
  const double f = raw / std::pow(10.0, e);
  const double tol = 1 + 1e-9;
  if (f <= 1 * tol) {
    s.mantissa = 1;
  } else if (f <= 2 * tol) {
    s.mantissa = 2;
  } else if (f <= 5 * tol) {
    s.mantissa = 5;
  } else {
    s.mantissa = 1;
    ++e;
  }
  s.exponent = e;
  return s;
}

void WidenEmpty(double* lo, double* hi) {
  if (!std::isfinite(*lo) || !std::isfinite(*hi)) {
    *lo = std::isfinite(*lo) ? *lo : (std::isfinite(*hi) ? *hi : 0.0);
    *hi = *lo;
  }
  if (*hi > *lo) return;
  const double c = 0.5 * (*lo + *hi);
  const double d = c == 0 ? 1.0 : 0.1 * std::abs(c);
  *lo = c - d;
  *hi = c + d;
}

cv::Point Fixed(const cv::Point2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x * 16)), static_cast<int>(std::lround(p.y * 16)));
}

}  // namespace

double NiceStep(double range, int target_count) { return NiceStepOf(range, target_count).value(); }

double NiceFloor(double x) {
  if (!(x > 0) || !std::isfinite(x)) return 0.0;
  int e = static_cast<int>(std::floor(std::log10(x)));
  const double f = x / std::pow(10.0, e);
  const double tol = 1 + 1e-9;
  Step s;
  s.exponent = e;
  s.mantissa = f * tol >= 5 ? 5 : (f * tol >= 2 ? 2 : 1);
  return s.value();
}

Ticks NiceTicks(double lo, double hi, int target_count) {
  WidenEmpty(&lo, &hi);
  const Step s = NiceStepOf(hi - lo, std::max(1, target_count));
  Ticks t;
  t.step = s.value();
  t.decimals = std::max(0, -s.exponent);
  const double first = std::ceil(lo / t.step - 1e-9), last = std::floor(hi / t.step + 1e-9);
  for (double k = first; k <= last; k += 1) t.values.push_back(s.Scaled(k));
  return t;
}

void NiceLimits(double* lo, double* hi, int target_count) {
  WidenEmpty(lo, hi);
  const Step s = NiceStepOf(*hi - *lo, std::max(1, target_count));
  const double step = s.value();
  *lo = s.Scaled(std::floor(*lo / step + 1e-9));
  *hi = s.Scaled(std::ceil(*hi / step - 1e-9));
}

std::string FormatTick(double value, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", std::max(0, decimals), value);
  std::string s = buf;
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

PlotTransform::PlotTransform(const cv::Rect2d& area, double x_lo, double x_hi, double y_lo, double y_hi,
                             bool equal_aspect)
    : area_(area) {
  WidenEmpty(&x_lo, &x_hi);
  WidenEmpty(&y_lo, &y_hi);
  const double w = std::max(1.0, area.width), h = std::max(1.0, area.height);
  sx_ = w / (x_hi - x_lo);
  sy_ = h / (y_hi - y_lo);
  if (equal_aspect) {
    const double s = std::min(sx_, sy_);
    const double xc = 0.5 * (x_lo + x_hi), yc = 0.5 * (y_lo + y_hi);
    const double xr = sx_ > s ? w / s : x_hi - x_lo, yr = sy_ > s ? h / s : y_hi - y_lo;
    if (sx_ > s) {
      x_lo = xc - 0.5 * xr;
      x_hi = xc + 0.5 * xr;
    }
    if (sy_ > s) {
      y_lo = yc - 0.5 * yr;
      y_hi = yc + 0.5 * yr;
    }
    sx_ = sy_ = s;
  }
  x_lo_ = x_lo;
  x_hi_ = x_hi;
  y_lo_ = y_lo;
  y_hi_ = y_hi;
}

cv::Point2d PlotTransform::ToPixel(double x, double y) const {
  return cv::Point2d(area_.x + (x - x_lo_) * sx_, area_.y + area_.height - (y - y_lo_) * sy_);
}

Eigen::Vector2d PlotTransform::ToData(const cv::Point2d& px) const {
  return Eigen::Vector2d(x_lo_ + (px.x - area_.x) / sx_, y_lo_ + (area_.y + area_.height - px.y) / sy_);
}

// ---- Text

cv::Rect TextBox(const std::string& text, const cv::Point2d& at, Anchor anchor, const TextStyle& style) {
  int baseline = 0;
  const cv::Size sz = cv::getTextSize(text, style.font, style.scale, style.thickness + 2 * style.halo, &baseline);
  const int w = sz.width, h = sz.height + baseline;
  double x = at.x, y = at.y;
  switch (anchor) {
    case Anchor::kTop:
    case Anchor::kCentre:
    case Anchor::kBottom:
      x -= 0.5 * w;
      break;
    case Anchor::kTopRight:
    case Anchor::kRight:
    case Anchor::kBottomRight:
      x -= w;
      break;
    default:
      break;
  }
  switch (anchor) {
    case Anchor::kLeft:
    case Anchor::kCentre:
    case Anchor::kRight:
      y -= 0.5 * h;
      break;
    case Anchor::kBottomLeft:
    case Anchor::kBottom:
    case Anchor::kBottomRight:
      y -= h;
      break;
    default:
      break;
  }
  return cv::Rect(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)), w, h);
}

cv::Rect DrawText(cv::Mat* canvas, const std::string& text, const cv::Point2d& at, Anchor anchor,
                  const TextStyle& style) {
  const cv::Rect box = TextBox(text, at, anchor, style);
  int baseline = 0;
  const cv::Size sz = cv::getTextSize(text, style.font, style.scale, style.thickness + 2 * style.halo, &baseline);
  const cv::Point origin(box.x + style.halo, box.y + sz.height);
  if (style.halo > 0)
    cv::putText(*canvas, text, origin, style.font, style.scale, style.halo_colour, style.thickness + 2 * style.halo,
                cv::LINE_AA);
  cv::putText(*canvas, text, origin, style.font, style.scale, style.colour, style.thickness, cv::LINE_AA);
  return box;
}

void DrawTextVertical(cv::Mat* canvas, const std::string& text, const cv::Point2d& centre, const TextStyle& style) {
  int baseline = 0;
  const cv::Size sz = cv::getTextSize(text, style.font, style.scale, style.thickness, &baseline);
  cv::Mat mask(sz.height + baseline + 2, sz.width + 2, CV_8UC1, cv::Scalar(0));
  cv::putText(mask, text, cv::Point(1, sz.height + 1), style.font, style.scale, cv::Scalar(255), style.thickness,
              cv::LINE_AA);
  cv::rotate(mask, mask, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int x0 = static_cast<int>(std::lround(centre.x - 0.5 * mask.cols));
  const int y0 = static_cast<int>(std::lround(centre.y - 0.5 * mask.rows));
  for (int r = 0; r < mask.rows; ++r)
    for (int c = 0; c < mask.cols; ++c) {
      const int x = x0 + c, y = y0 + r;
      const double a = mask.at<uchar>(r, c) / 255.0;
      if (a <= 0 || x < 0 || y < 0 || x >= canvas->cols || y >= canvas->rows) continue;
      cv::Vec3b& px = canvas->at<cv::Vec3b>(y, x);
      for (int k = 0; k < 3; ++k) px[k] = cv::saturate_cast<uchar>((1 - a) * px[k] + a * style.colour[k]);
    }
}

std::string ShortenLeft(const std::string& text, int max_width, const TextStyle& style) {
  auto width = [&](const std::string& s) {
    int b = 0;
    return cv::getTextSize(s, style.font, style.scale, style.thickness, &b).width;
  };
  if (width(text) <= max_width) return text;
  for (size_t cut = 1; cut < text.size(); ++cut) {
    const std::string s = "..." + text.substr(cut);
    if (width(s) <= max_width) return s;
  }
  return "...";
}

void LabelPlacer::ReservePoint(const cv::Point2d& p, int radius) {
  taken_.emplace_back(static_cast<int>(std::floor(p.x)) - radius, static_cast<int>(std::floor(p.y)) - radius,
                      2 * radius + 1, 2 * radius + 1);
}

bool LabelPlacer::Free(const cv::Rect& r) const {
  if ((r & bounds_) != r) return false;
  for (const cv::Rect& t : taken_)
    if ((r & t).area() > 0) return false;
  return true;
}

cv::Rect LabelPlacer::Find(const std::string& text, const cv::Point2d& p, const TextStyle& style, int gap) const {
  struct Try {
    double dx, dy;
    Anchor anchor;
  };
  for (const double g : {static_cast<double>(gap), 2.5 * gap + 4}) {
    const Try tries[] = {
        {g, 0, Anchor::kLeft},          {g, -g, Anchor::kBottomLeft}, {g, g, Anchor::kTopLeft}, {-g, 0, Anchor::kRight},
        {-g, -g, Anchor::kBottomRight}, {-g, g, Anchor::kTopRight},   {0, -g, Anchor::kBottom}, {0, g, Anchor::kTop}};
    for (const Try& t : tries) {
      const cv::Rect box = TextBox(text, p + cv::Point2d(t.dx, t.dy), t.anchor, style);
      if (Free(box)) return box;
    }
  }
  return cv::Rect();
}

bool LabelPlacer::Place(cv::Mat* canvas, const std::string& text, const cv::Point2d& point, const TextStyle& style,
                        int gap) {
  const cv::Rect box = Find(text, point, style, gap);
  if (box.area() == 0) return false;
  DrawText(canvas, text, box.tl(), Anchor::kTopLeft, style);
  taken_.push_back(box);
  return true;
}

// ---- Colours

cv::Scalar ColourMapValue(double t) {
  static const cv::Mat lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1), out;
    for (int i = 0; i < 256; ++i) ramp.at<uchar>(0, i) = static_cast<uchar>(i);
    cv::applyColorMap(ramp, out, cv::COLORMAP_VIRIDIS);
    return out;
  }();
  if (!std::isfinite(t)) return cv::Scalar(160, 160, 160);
  const int i = static_cast<int>(std::lround(std::clamp(t, 0.0, 1.0) * 0.9 * 255));
  const cv::Vec3b c = lut.at<cv::Vec3b>(0, i);
  return cv::Scalar(c[0], c[1], c[2]);
}

cv::Scalar CategoricalColour(int i) {
  static const cv::Scalar tab10[] = {{180, 119, 31}, {14, 127, 255},  {44, 160, 44},   {40, 39, 214},  {189, 103, 148},
                                     {75, 86, 140},  {194, 119, 227}, {127, 127, 127}, {34, 189, 188}, {207, 190, 23}};
  return tab10[((i % 10) + 10) % 10];
}

// ---- Axes

Axes::Axes(cv::Mat* canvas, const cv::Rect& outer, double x_lo, double x_hi, double y_lo, double y_hi,
           const AxesOptions& options)
    : canvas_(canvas), opt_(options) {
  if (opt_.nice_limits) {
    NiceLimits(&x_lo, &x_hi, opt_.x_ticks);
    NiceLimits(&y_lo, &y_hi, opt_.y_ticks);
  }
  // Margins from the labels of the ticks the range would get (the final
  // range, widened for equal aspect, has ticks of the same step or one
  // wider, so their labels are no longer by more than a digit).
  const Ticks yt = NiceTicks(y_lo, y_hi, opt_.y_ticks);
  int label_w = 0;
  for (double v : yt.values)
    label_w =
        std::max(label_w, TextBox(FormatTick(v, yt.decimals) + "0", {0, 0}, Anchor::kTopLeft, opt_.tick_style).width);
  const int tick_h = TextBox("0", {0, 0}, Anchor::kTopLeft, opt_.tick_style).height;
  const int label_h = TextBox("Ag", {0, 0}, Anchor::kTopLeft, opt_.label_style).height;
  const int left = std::max(opt_.min_left_margin, label_w + 10 + (opt_.y_label.empty() ? 0 : label_h + 10));
  const int bottom = (opt_.x_tick_labels ? tick_h + 10 : 6) + (opt_.x_label.empty() ? 0 : label_h + 10);
  const int top = 8, right = 16;
  const cv::Rect area(outer.x + left, outer.y + top, std::max(1, outer.width - left - right),
                      std::max(1, outer.height - top - bottom));
  transform_ = PlotTransform(cv::Rect2d(area), x_lo, x_hi, y_lo, y_hi, opt_.equal_aspect);
  xt_ = NiceTicks(transform_.x_lo(), transform_.x_hi(), opt_.x_ticks);
  yt_ = NiceTicks(transform_.y_lo(), transform_.y_hi(), opt_.y_ticks);
}

cv::Rect Axes::area() const {
  const cv::Rect2d& a = transform_.area();
  return cv::Rect(static_cast<int>(a.x), static_cast<int>(a.y), static_cast<int>(a.width), static_cast<int>(a.height));
}

cv::Point2d Axes::Px(double x, double y) const {
  const cv::Rect2d& a = transform_.area();
  return transform_.ToPixel(x, y) - cv::Point2d(a.x, a.y);
}

void Axes::DrawBackground() {
  const cv::Rect a = area();
  cv::rectangle(*canvas_, a, cv::Scalar(255, 255, 255), cv::FILLED);
  const cv::Scalar grid(232, 232, 232), tick(90, 90, 90);
  for (double v : xt_.values) {
    const double x = transform_.ToPixel(v, 0).x;
    if (opt_.grid) DrawLine(canvas_, {x, double(a.y)}, {x, double(a.y + a.height - 1)}, grid);
    DrawLine(canvas_, {x, double(a.y + a.height)}, {x, double(a.y + a.height + 5)}, tick);
    if (opt_.x_tick_labels)
      DrawText(canvas_, FormatTick(v, xt_.decimals), {x, double(a.y + a.height + 8)}, Anchor::kTop, opt_.tick_style);
  }
  for (double v : yt_.values) {
    const double y = transform_.ToPixel(0, v).y;
    if (opt_.grid) DrawLine(canvas_, {double(a.x), y}, {double(a.x + a.width - 1), y}, grid);
    DrawLine(canvas_, {double(a.x - 5), y}, {double(a.x - 1), y}, tick);
    DrawText(canvas_, FormatTick(v, yt_.decimals), {double(a.x - 8), y}, Anchor::kRight, opt_.tick_style);
  }
  const int tick_h = TextBox("0", {0, 0}, Anchor::kTopLeft, opt_.tick_style).height;
  if (!opt_.x_label.empty())
    DrawText(canvas_, opt_.x_label, {a.x + 0.5 * a.width, double(a.y + a.height + tick_h + 16)}, Anchor::kTop,
             opt_.label_style);
  if (!opt_.y_label.empty()) {
    int label_w = 0;
    for (double v : yt_.values)
      label_w =
          std::max(label_w, TextBox(FormatTick(v, yt_.decimals), {0, 0}, Anchor::kTopLeft, opt_.tick_style).width);
    const int label_h = TextBox("Ag", {0, 0}, Anchor::kTopLeft, opt_.label_style).height;
    DrawTextVertical(canvas_, opt_.y_label, {a.x - label_w - 14 - 0.5 * label_h, a.y + 0.5 * a.height},
                     opt_.label_style);
  }
  DrawFrame();
}

void Axes::DrawFrame() {
  const cv::Rect a = area();
  cv::rectangle(*canvas_, cv::Rect(a.x - 1, a.y - 1, a.width + 2, a.height + 2), cv::Scalar(90, 90, 90), 1);
}

// ---- Legend, colour bar, scale bar

namespace {
const int kSymbolWidth = 26, kPad = 6;
}

cv::Size LegendSize(const std::vector<LegendEntry>& entries, const TextStyle& style) {
  int w = 0, h = kPad;
  for (const LegendEntry& e : entries) {
    const cv::Rect b = TextBox(e.label, {0, 0}, Anchor::kTopLeft, style);
    w = std::max(w, b.width);
    h += std::max(b.height, 12) + 5;
  }
  return cv::Size(kPad + kSymbolWidth + 6 + w + kPad, h + kPad - 5);
}

void DrawLegendSymbol(cv::Mat* canvas, const LegendEntry& e, const cv::Point2d& c, int width) {
  switch (e.kind) {
    case LegendEntry::Kind::kLine:
      DrawLine(canvas, c - cv::Point2d(0.5 * width, 0), c + cv::Point2d(0.5 * width, 0), e.colour, e.thickness);
      break;
    case LegendEntry::Kind::kPatch:
      cv::rectangle(*canvas, cv::Rect(int(c.x - 0.5 * width), int(c.y - 5), width, 10), e.colour, cv::FILLED);
      break;
    case LegendEntry::Kind::kMarker:
      if (e.marker == -1)
        DrawDisc(canvas, c, 5, e.colour);
      else if (e.marker == -2)
        cv::rectangle(*canvas, cv::Rect(int(c.x) - 5, int(c.y) - 5, 11, 11), e.colour, cv::FILLED);
      else
        cv::drawMarker(*canvas, cv::Point(int(std::lround(c.x)), int(std::lround(c.y))), e.colour, e.marker, 11,
                       e.thickness, cv::LINE_AA);
      break;
  }
}

cv::Rect DrawLegend(cv::Mat* canvas, const std::vector<LegendEntry>& entries, const cv::Point& at, Anchor anchor,
                    const TextStyle& style) {
  const cv::Size sz = LegendSize(entries, style);
  // The box placed like a text box of that size.
  cv::Rect box(at, sz);
  switch (anchor) {
    case Anchor::kTop:
    case Anchor::kCentre:
    case Anchor::kBottom:
      box.x -= sz.width / 2;
      break;
    case Anchor::kTopRight:
    case Anchor::kRight:
    case Anchor::kBottomRight:
      box.x -= sz.width;
      break;
    default:
      break;
  }
  switch (anchor) {
    case Anchor::kLeft:
    case Anchor::kCentre:
    case Anchor::kRight:
      box.y -= sz.height / 2;
      break;
    case Anchor::kBottomLeft:
    case Anchor::kBottom:
    case Anchor::kBottomRight:
      box.y -= sz.height;
      break;
    default:
      break;
  }
  cv::rectangle(*canvas, box, cv::Scalar(255, 255, 255), cv::FILLED);
  cv::rectangle(*canvas, box, cv::Scalar(200, 200, 200), 1);
  int y = box.y + kPad;
  for (const LegendEntry& e : entries) {
    const cv::Rect b = TextBox(e.label, {0, 0}, Anchor::kTopLeft, style);
    const int row_h = std::max(b.height, 12);
    DrawLegendSymbol(canvas, e, {box.x + kPad + 0.5 * kSymbolWidth, y + 0.5 * row_h}, kSymbolWidth);
    DrawText(canvas, e.label, {double(box.x + kPad + kSymbolWidth + 6), y + 0.5 * row_h}, Anchor::kLeft, style);
    y += row_h + 5;
  }
  return box;
}

void DrawColourBar(cv::Mat* canvas, const cv::Rect& bar, double lo, double hi, const std::string& label,
                   const TextStyle& style) {
  WidenEmpty(&lo, &hi);
  for (int r = 0; r < bar.height; ++r) {
    const double t = bar.height > 1 ? 1.0 - static_cast<double>(r) / (bar.height - 1) : 0.5;
    cv::line(*canvas, {bar.x, bar.y + r}, {bar.x + bar.width - 1, bar.y + r}, ColourMapValue(t));
  }
  cv::rectangle(*canvas, cv::Rect(bar.x - 1, bar.y - 1, bar.width + 2, bar.height + 2), cv::Scalar(90, 90, 90));
  const Ticks t = NiceTicks(lo, hi, std::max(2, bar.height / 40));
  for (double v : t.values) {
    const double y = bar.y + (bar.height - 1) * (1.0 - (v - lo) / (hi - lo));
    DrawLine(canvas, {double(bar.x + bar.width), y}, {double(bar.x + bar.width + 4), y}, cv::Scalar(90, 90, 90));
    DrawText(canvas, FormatTick(v, t.decimals), {double(bar.x + bar.width + 7), y}, Anchor::kLeft, style);
  }
  if (!label.empty()) DrawText(canvas, label, {double(bar.x), double(bar.y - 8)}, Anchor::kBottomLeft, style);
}

cv::Rect DrawScaleBar(cv::Mat* canvas, const cv::Point2d& left, double px_per_unit, double max_px,
                      const std::string& units, const TextStyle& style) {
  const double len = NiceFloor(max_px / px_per_unit);
  if (!(len > 0)) return cv::Rect();
  const double px = len * px_per_unit;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g %s", len, units.c_str());
  const cv::Rect text = TextBox(buf, left + cv::Point2d(0.5 * px, -8), Anchor::kBottom, style);
  const cv::Rect box = (text | cv::Rect(int(left.x) - 1, int(left.y) - 5, int(px) + 3, 9));
  const cv::Rect backing(box.x - 4, box.y - 3, box.width + 8, box.height + 6);
  cv::rectangle(*canvas, backing, cv::Scalar(255, 255, 255), cv::FILLED);
  const cv::Scalar ink(40, 40, 40);
  cv::rectangle(*canvas, cv::Rect(int(left.x), int(left.y) - 2, int(std::lround(px)), 4), ink, cv::FILLED);
  DrawLine(canvas, left + cv::Point2d(0, -5), left + cv::Point2d(0, 3), ink);
  DrawLine(canvas, left + cv::Point2d(px, -5), left + cv::Point2d(px, 3), ink);
  DrawText(canvas, buf, left + cv::Point2d(0.5 * px, -8), Anchor::kBottom, style);
  return backing;
}

// ---- Primitives

void DrawLine(cv::Mat* canvas, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour, int thickness) {
  cv::line(*canvas, Fixed(a), Fixed(b), colour, thickness, cv::LINE_AA, 4);
}

void DrawDisc(cv::Mat* canvas, const cv::Point2d& c, double radius, const cv::Scalar& colour) {
  cv::circle(*canvas, Fixed(c), static_cast<int>(std::lround(radius * 16)), colour, cv::FILLED, cv::LINE_AA, 4);
}

void DrawCircle(cv::Mat* canvas, const cv::Point2d& c, double radius, const cv::Scalar& colour, int thickness) {
  cv::circle(*canvas, Fixed(c), static_cast<int>(std::lround(radius * 16)), colour, thickness, cv::LINE_AA, 4);
}

void DrawArrow(cv::Mat* canvas, const cv::Point2d& from, const cv::Point2d& to, const cv::Scalar& colour, int thickness,
               double tip_px) {
  const cv::Point2d d = to - from;
  const double len = std::hypot(d.x, d.y);
  if (!(len > 0)) return;
  DrawLine(canvas, from, to, colour, thickness);
  const cv::Point2d u = d / len, n(-u.y, u.x);
  const cv::Point2d base = to - u * tip_px;
  const cv::Point tip[3] = {Fixed(to), Fixed(base + n * (0.45 * tip_px)), Fixed(base - n * (0.45 * tip_px))};
  cv::fillConvexPoly(*canvas, tip, 3, colour, cv::LINE_AA, 4);
}

void DrawDashedLine(cv::Mat* canvas, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour,
                    int thickness, double dash, double gap) {
  const cv::Point2d d = b - a;
  const double len = std::hypot(d.x, d.y);
  if (!(len > 0)) return;
  const cv::Point2d u = d / len;
  for (double s = 0; s < len; s += dash + gap)
    DrawLine(canvas, a + u * s, a + u * std::min(len, s + dash), colour, thickness);
}

}  // namespace pano

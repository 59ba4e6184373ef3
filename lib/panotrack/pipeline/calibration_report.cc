// Report image (panocalib calibrate --report): corner coverage of every image
// over the mirror, the residuals of all corners (scatter and histogram), the
// RMS per image with its file name, and the fitted parameters.
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "panotrack/pipeline/calibration_report.h"
#include "panotrack/plot/figure.h"

namespace pano {

namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kInk(40, 40, 40);
const cv::Scalar kUnwarped(14, 127, 255);  // orange
const cv::Scalar kRms(40, 39, 214);        // red
const TextStyle kSmall{cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, kInk};
const TextStyle kHeader{cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, cv::Scalar(20, 20, 20)};

// One colour per image: Tableau 10 up to ten images, evenly spaced hues beyond.
cv::Scalar ImageColour(int i, int n) {
  if (n <= 10) return CategoricalColour(i);
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(180.0 * i / n, i % 2 ? 200 : 255, i % 2 ? 230 : 190)), bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return cv::Scalar(c[0], c[1], c[2]);
}

std::string Printf(const char* fmt, double a, double b = 0, double c = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}

// Words of `text` in lines of at most `width` px (a word longer than a line
// is shortened from the left).
std::vector<std::string> Wrap(const std::string& text, int width, const TextStyle& style) {
  std::vector<std::string> lines;
  std::string line, word;
  auto fits = [&](const std::string& s) { return TextBox(s, {0, 0}, Anchor::kTopLeft, style).width <= width; };
  auto add = [&](const std::string& w) {
    if (w.empty()) return;
    const std::string candidate = line.empty() ? w : line + " " + w;
    if (fits(candidate)) {
      line = candidate;
      return;
    }
    if (!line.empty()) lines.push_back(line);
    line = fits(w) ? w : ShortenLeft(w, width, style);
  };
  for (char ch : text) {
    if (ch == ' ') {
      add(word);
      word.clear();
    } else {
      word += ch;
    }
  }
  add(word);
  if (!line.empty()) lines.push_back(line);
  return lines;
}

// Draws lines from `y` down; returns the y below them.
int DrawLines(cv::Mat* canvas, const std::vector<std::string>& lines, int x, int y, const TextStyle& style) {
  for (const std::string& l : lines)
    y = DrawText(canvas, l, {double(x), double(y)}, Anchor::kTopLeft, style).br().y + 4;
  return y;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// Residual statistics over all corners: lengths and |x|, |y| components.
struct ResidualSets {
  std::vector<double> norms, components;
};

ResidualSets ResidualsOf(const CalibrationResult& r) {
  ResidualSets out;
  const int n = static_cast<int>(r.views.size());
  for (int i = 0; i < n && i < static_cast<int>(r.residuals.size()); ++i)
    for (const Eigen::Vector2d& e : r.residuals[i])
      if (std::isfinite(e.x()) && std::isfinite(e.y())) {
        out.norms.push_back(e.norm());
        out.components.push_back(std::abs(e.x()));
        out.components.push_back(std::abs(e.y()));
      }
  return out;
}

int UnwarpedCount(const CalibrationResult& r) {
  int n = 0;
  for (const BoardView& v : r.views) n += v.method == "unwarped";
  return n;
}

// The report's columns (coverage; residual plots; bars and parameters)
// and its size: the right column grows with the number of images.
struct ReportLayout {
  static constexpr int kMargin = 18, kGap = 28, kTitleH = 46, kLeftW = 560, kMidW = 400, kBarW = 230, kRowH = 20;
  double scale = 1.0;  // coverage picture pixels per image pixel
  cv::Size coverage;
  int name_w = 0, index_w = 0, right_w = 0;
  int width = 0, height = 0, x_left = 0, x_mid = 0, x_right = 0;
};

// The RMS of the fit's residuals, which the scatter, histogram and bars
// draw (CalibrationResult::rms_px is evaluate's figure after Calibrate()).
double ResidualRms(const CalibrationResult& r) { return std::isfinite(r.fit_rms_px) ? r.fit_rms_px : r.rms_px; }

ReportLayout LayoutOf(const CalibrationResult& r, int W, int H) {
  ReportLayout l;
  const int n = static_cast<int>(r.views.size());
  l.scale = static_cast<double>(ReportLayout::kLeftW) / std::max(W, H);
  l.coverage = cv::Size(static_cast<int>(std::lround(W * l.scale)), static_cast<int>(std::lround(H * l.scale)));
  for (const BoardView& v : r.views)
    l.name_w = std::max(l.name_w, TextBox(v.file, {0, 0}, Anchor::kTopLeft, kSmall).width);
  l.name_w = std::min(l.name_w, 320);
  l.index_w = TextBox(std::to_string(std::max(1, n)), {0, 0}, Anchor::kTopLeft, kSmall).width + 10;
  l.right_w = std::max(l.index_w + l.name_w + 10 + ReportLayout::kBarW + 110, 420);
  l.width = ReportLayout::kMargin + ReportLayout::kLeftW + ReportLayout::kGap + ReportLayout::kMidW +
            ReportLayout::kGap + l.right_w + ReportLayout::kMargin;
  l.x_left = ReportLayout::kMargin;
  l.x_mid = ReportLayout::kMargin + ReportLayout::kLeftW + ReportLayout::kGap;
  l.x_right = l.x_mid + ReportLayout::kMidW + ReportLayout::kGap;
  const int bars_h = 42 + std::max(1, n) * ReportLayout::kRowH + 40;
  const int params_h = 30 + static_cast<int>(r.parameters.size()) * 19 + 10;
  const int right_h = bars_h + 24 + params_h;
  const int mid_h = 30 + 400 + 24 + 30 + 250;
  const int left_h = 30 + l.coverage.height + 200;
  l.height = ReportLayout::kTitleH + std::max({left_h, mid_h, right_h}) + ReportLayout::kMargin;
  return l;
}

void DrawReportTitle(const CalibrationResult& r, int W, int H, cv::Mat* canvas) {
  const int n = static_cast<int>(r.views.size()), n_unwarped = UnwarpedCount(r);
  std::string title = "Calibration report: " + std::string(MirrorModelName(r.calib.sensor.model)) + " mirror, " +
                      std::to_string(W) + " x " + std::to_string(H) + " px, " + std::to_string(n) + " of " +
                      std::to_string(n + static_cast<int>(r.not_found.size())) + " images used";
  if (n_unwarped > 0) title += " (" + std::to_string(n_unwarped) + " by the unwarped retry)";
  title += r.poses_known ? ", board poses known" : ", board poses estimated";
  title += Printf(", RMS %.3f px", r.rms_px);
  if (std::isfinite(r.fit_rms_px)) title += Printf(" (fit %.3f)", r.fit_rms_px);
  DrawText(canvas, title, {double(ReportLayout::kMargin), 14.0}, Anchor::kTopLeft,
           TextStyle{cv::FONT_HERSHEY_SIMPLEX, 0.6, 1, cv::Scalar(20, 20, 20)});
}

// The smallest and largest image radius of the corners (r_max 0: none).
void CornerRadii(const CalibrationResult& r, double* r_min, double* r_max) {
  *r_min = 1e300;
  *r_max = 0;
  for (const BoardView& v : r.views)
    for (const Eigen::Vector2d& c : v.corners) {
      double rad, az;
      r.calib.sensor.to_polar(c.x(), c.y(), &rad, &az);
      if (!std::isfinite(rad)) continue;
      *r_min = std::min(*r_min, rad);
      *r_max = std::max(*r_max, rad);
    }
}

// The coverage picture: the faded image (or grey), the mirror's limb and
// centre, the annulus the corners cover, every corner and each image's number.
void DrawCoveragePicture(const CalibrationResult& r, const cv::Mat& image, const ReportLayout& l, double r_min,
                         double r_max, cv::Mat& panel) {
  const Sensor& s = r.calib.sensor;
  const int n = static_cast<int>(r.views.size());
  const int W = std::max(1, s.image_width), H = std::max(1, s.image_height);
  const double sc = l.scale;
  if (!image.empty() && image.cols == W && image.rows == H) {
    cv::Mat grey = image;
    if (grey.channels() == 3) cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
    cv::Mat faded, scaled;
    grey.convertTo(faded, CV_8U, 0.35, 165);
    cv::resize(faded, scaled, l.coverage, 0, 0, cv::INTER_AREA);
    cv::cvtColor(scaled, panel, cv::COLOR_GRAY2BGR);
  } else {
    panel.setTo(cv::Scalar(238, 238, 238));
  }
  auto P = [&](const Eigen::Vector2d& p) { return cv::Point2d(p.x() * sc, p.y() * sc); };
  auto ring = [&](double radius, const cv::Scalar& colour, bool dashed) {
    if (!(radius > 0) || !std::isfinite(radius) || radius > 4.0 * std::max(W, H)) return;
    cv::Point2d previous;
    for (int k = 0; k <= 180; ++k) {
      const cv::Point2d p = P(s.from_polar(radius, 2 * M_PI * k / 180));
      if (k > 0 && (!dashed || k % 2 == 0)) DrawLine(&panel, previous, p, colour, dashed ? 1 : 2);
      previous = p;
    }
  };
  ring(s.limb_radius(), cv::Scalar(150, 110, 60), false);
  if (r_max > 0) {
    ring(r_min, cv::Scalar(110, 110, 110), true);
    ring(r_max, cv::Scalar(110, 110, 110), true);
  }
  cv::drawMarker(panel, P(Eigen::Vector2d(s.params.cx, s.params.cy)), cv::Scalar(150, 110, 60), cv::MARKER_CROSS, 12,
                 1, cv::LINE_AA);
  LabelPlacer placer(cv::Rect(0, 0, panel.cols, panel.rows));
  std::vector<cv::Point2d> centres(n);
  for (int i = 0; i < n; ++i) {
    const BoardView& v = r.views[i];
    const cv::Scalar col = ImageColour(i, n);
    cv::Point2d centre(0, 0);
    for (const Eigen::Vector2d& c : v.corners) {
      const cv::Point2d p = P(c);
      centre += p;
      if (v.method == "unwarped")
        cv::drawMarker(panel, cv::Point(int(std::lround(p.x)), int(std::lround(p.y))), col, cv::MARKER_TRIANGLE_UP, 6,
                       1, cv::LINE_AA);
      else
        DrawDisc(&panel, p, 1.8, col);
    }
    if (!v.corners.empty()) centres[i] = centre / static_cast<double>(v.corners.size());
  }
  const TextStyle number{cv::FONT_HERSHEY_SIMPLEX, 0.42, 1, kInk, 2, kWhite};
  for (int i = 0; i < n; ++i)
    if (!r.views[i].corners.empty()) {
      const cv::Rect box = TextBox(std::to_string(i + 1), centres[i], Anchor::kCentre, number);
      if (placer.Free(box)) {
        TextStyle st = number;
        st.colour = ImageColour(i, n) * 0.7;
        DrawText(&panel, std::to_string(i + 1), box.tl(), Anchor::kTopLeft, st);
        placer.Reserve(box);
      }
    }
}

// The key under the coverage picture, then the images without a board and
// the warnings, as far as the canvas holds them.
void DrawCoverageKeyAndNotes(const CalibrationResult& r, const cv::Mat& image, int view_index, const ReportLayout& l,
                             double r_min, double r_max, int y, cv::Mat* canvas) {
  const int n = static_cast<int>(r.views.size());
  std::vector<LegendEntry> key = {{"corner (raw detection)", kInk, LegendEntry::Kind::kMarker, 1, -1}};
  if (UnwarpedCount(r) > 0)
    key.push_back({"corner (unwarped retry)", kInk, LegendEntry::Kind::kMarker, 1, cv::MARKER_TRIANGLE_UP});
  key.push_back({"mirror limb and centre", cv::Scalar(150, 110, 60), LegendEntry::Kind::kLine, 2});
  if (!image.empty() && view_index >= 0 && view_index < n)
    key.push_back({"background: " + r.views[view_index].file, cv::Scalar(200, 200, 200), LegendEntry::Kind::kPatch});
  if (r_max > 0)
    key.push_back({Printf("corner radii %.0f - %.0f px (limb %.0f px)", r_min, r_max, r.calib.sensor.limb_radius()),
                   cv::Scalar(110, 110, 110), LegendEntry::Kind::kLine, 1});
  const cv::Rect kb = DrawLegend(canvas, key, {l.x_left, y}, Anchor::kTopLeft, kSmall);
  y = kb.br().y + 10;
  std::vector<std::string> notes;
  if (!r.not_found_files.empty()) {
    std::string t = "No board found (not used):";
    for (const std::string& f : r.not_found_files) t += " " + f;
    notes.push_back(t);
  }
  for (const std::string& w : r.warnings) notes.push_back("Warning: " + w);
  const int bottom = l.height - ReportLayout::kMargin - 16;
  for (const std::string& note : notes) {
    if (y > bottom) break;
    for (const std::string& line : Wrap(note, ReportLayout::kLeftW, kSmall)) {
      if (y > bottom) break;
      y = DrawLines(canvas, {line}, l.x_left, y, kSmall);
    }
    y += 4;
  }
}

// Left column: every image's corners over the mirror.
void DrawCoverage(const CalibrationResult& r, const cv::Mat& image, int view_index, const ReportLayout& l,
                  cv::Mat* canvas) {
  int y = ReportLayout::kTitleH;
  DrawText(canvas, "Corners of all images over the mirror", {double(l.x_left), double(y)}, Anchor::kTopLeft, kHeader);
  y += 24;
  const cv::Rect cov_rect(l.x_left, y, l.coverage.width, l.coverage.height);
  double r_min, r_max;
  CornerRadii(r, &r_min, &r_max);
  cv::Mat panel = (*canvas)(cov_rect);
  DrawCoveragePicture(r, image, l, r_min, r_max, panel);
  cv::rectangle(*canvas, cv::Rect(cov_rect.x - 1, cov_rect.y - 1, cov_rect.width + 2, cov_rect.height + 2),
                cv::Scalar(90, 90, 90));
  DrawCoverageKeyAndNotes(r, image, view_index, l, r_min, r_max, cov_rect.br().y + 10, canvas);
}

// Notes in the plot's upper left corner, each on a white patch.
void DrawCornerNotes(const std::vector<std::string>& notes, const cv::Rect& a, cv::Mat* canvas) {
  double ty = a.y + 6.0;
  for (const std::string& note : notes) {
    const cv::Rect tb = TextBox(note, {a.x + 6.0, ty}, Anchor::kTopLeft, kSmall);
    cv::rectangle(*canvas, cv::Rect(tb.x - 3, tb.y - 2, tb.width + 6, tb.height + 4), kWhite, cv::FILLED);
    DrawText(canvas, note, tb.tl(), Anchor::kTopLeft, kSmall);
    ty = tb.br().y + 4;
  }
}

// Middle column, top: the residual scatter of all corners, the RMS circle
// dashed. Returns the y below it.
int DrawResidualScatter(const CalibrationResult& r, const ResidualSets& res, const ReportLayout& l, cv::Mat* canvas) {
  const int n = static_cast<int>(r.views.size());
  int y = ReportLayout::kTitleH;
  DrawText(canvas, Printf("Residuals of all %.0f corners", double(res.norms.size())), {double(l.x_mid), double(y)},
           Anchor::kTopLeft, kHeader);
  y += 24;
  const double lim = std::max({Quantile(res.components, 0.99) * 1.15, 3.0 * ResidualRms(r), 1e-3});
  AxesOptions ao;
  ao.x_label = "x residual (px)";
  ao.y_label = "y residual (px)";
  ao.equal_aspect = true;
  ao.x_ticks = 4;
  ao.y_ticks = 4;
  Axes axes(canvas, cv::Rect(l.x_mid, y, ReportLayout::kMidW, 400), -lim, lim, -lim, lim, ao);
  axes.DrawBackground();
  cv::Mat plot = axes.plot();
  DrawLine(&plot, axes.Px(-2 * lim, 0), axes.Px(2 * lim, 0), cv::Scalar(170, 170, 170));
  DrawLine(&plot, axes.Px(0, -2 * lim), axes.Px(0, 2 * lim), cv::Scalar(170, 170, 170));
  int outside = 0;
  for (int i = 0; i < n && i < static_cast<int>(r.residuals.size()); ++i)
    for (const Eigen::Vector2d& e : r.residuals[i]) {
      if (!std::isfinite(e.x()) || !std::isfinite(e.y())) continue;
      const double ax = axes.transform().x_hi(), ay = axes.transform().y_hi();
      if (std::abs(e.x()) > ax || std::abs(e.y()) > ay) ++outside;
      DrawDisc(&plot, axes.Px(e.x(), e.y()), 1.6, ImageColour(i, n));
    }
  cv::Point2d previous;
  for (int k = 0; k <= 120; ++k) {
    const double a = 2 * M_PI * k / 120;
    const cv::Point2d p = axes.Px(ResidualRms(r) * std::cos(a), ResidualRms(r) * std::sin(a));
    if (k > 0 && k % 2 == 0) DrawLine(&plot, previous, p, kRms, 1);
    previous = p;
  }
  axes.DrawFrame();
  std::vector<std::string> notes = {"projected - detected", Printf("dashed: RMS %.3f px", ResidualRms(r))};
  if (outside > 0) notes.push_back(Printf("%.0f beyond the axes", outside));
  DrawCornerNotes(notes, axes.area(), canvas);
  return y + 400 + 24;
}

// Middle column, below: the histogram of the residuals' lengths from `y`.
void DrawResidualHistogram(const CalibrationResult& r, const ResidualSets& res, const ReportLayout& l, int y,
                           cv::Mat* canvas) {
  DrawText(canvas, "Residual lengths", {double(l.x_mid), double(y)}, Anchor::kTopLeft, kHeader);
  y += 30;
  double hi = std::max(Quantile(res.norms, 0.995) * 1.05, std::max(1e-3, 2 * ResidualRms(r)));
  double lo = 0;
  NiceLimits(&lo, &hi, 5);
  const int bins = 30;
  std::vector<int> count(bins, 0);
  int beyond = 0;
  for (double v : res.norms) {
    const int b = static_cast<int>(v / hi * bins);
    if (b >= bins) ++beyond;
    ++count[std::min(b, bins - 1)];
  }
  const int top = std::max(1, *std::max_element(count.begin(), count.end()));
  AxesOptions ao;
  ao.x_label = "residual length (px)";
  ao.y_label = "corners";
  ao.x_ticks = 5;
  ao.y_ticks = 4;
  Axes axes(canvas, cv::Rect(l.x_mid, y, ReportLayout::kMidW, 250), 0, hi, 0, top * 1.08, ao);
  axes.DrawBackground();
  cv::Mat plot = axes.plot();
  for (int b = 0; b < bins; ++b) {
    if (count[b] == 0) continue;
    const cv::Point2d p0 = axes.Px(hi * b / bins, 0), p1 = axes.Px(hi * (b + 1) / bins, count[b]);
    cv::rectangle(plot, cv::Point(int(std::lround(p0.x)) + 1, int(std::lround(p1.y))),
                  cv::Point(int(std::lround(p1.x)) - 1, int(std::lround(p0.y))), cv::Scalar(200, 150, 90),
                  cv::FILLED);
  }
  const double xr = axes.Px(ResidualRms(r), 0).x;
  DrawDashedLine(&plot, {xr, 0.0}, {xr, double(plot.rows)}, kRms, 2);
  const cv::Rect a = axes.area();
  std::string note = Printf("RMS %.3f px", ResidualRms(r));
  TextStyle red = kSmall;
  red.colour = kRms;
  const cv::Rect nb = TextBox(note, {a.x + xr + 6, a.y + 6.0}, Anchor::kTopLeft, red);
  DrawText(
      canvas, note,
      nb.br().x < a.br().x ? cv::Point2d(a.x + xr + 6, a.y + 6.0) : cv::Point2d(a.x + xr - 6 - nb.width, a.y + 6.0),
      Anchor::kTopLeft, red);
  if (beyond > 0)
    DrawText(canvas, Printf("%.0f longer, counted in the last bin", beyond), {a.x + a.width - 6.0, a.y + 26.0},
             Anchor::kTopRight, kSmall);
  axes.DrawFrame();
}

// One image's row of the bar chart: number, name, bar, value.
void DrawImageBar(const CalibrationResult& r, int i, const ReportLayout& l, double yc, int bx0, double x_value,
                  cv::Mat* canvas) {
  const int n = static_cast<int>(r.views.size());
  const double v = i < static_cast<int>(r.image_rms.size()) ? r.image_rms[i] : 0.0;
  TextStyle value = kSmall;
  value.halo = 2;
  value.halo_colour = kWhite;
  DrawText(canvas, std::to_string(i + 1), {double(l.x_right + l.index_w - 8), yc}, Anchor::kRight, kSmall);
  DrawText(canvas, ShortenLeft(r.views[i].file, l.name_w, kSmall), {double(l.x_right + l.index_w), yc}, Anchor::kLeft,
           kSmall);
  cv::rectangle(*canvas, cv::Point(bx0 + 1, int(yc) - 6), cv::Point(int(std::lround(x_value)), int(yc) + 6),
                ImageColour(i, n), cv::FILLED);
  const cv::Rect vb = DrawText(canvas, Printf("%.3f", v), {x_value + 3, yc}, Anchor::kLeft, value);
  if (r.views[i].method == "unwarped") {
    TextStyle u = kSmall;
    u.colour = kUnwarped;
    DrawText(canvas, "unwarped", {vb.br().x + 6.0, yc}, Anchor::kLeft, u);
  }
}

// Right column, top: the RMS of each image as bars. Returns the y below.
int DrawRmsPerImage(const CalibrationResult& r, const ReportLayout& l, cv::Mat* canvas) {
  const int n = static_cast<int>(r.views.size());
  int y = ReportLayout::kTitleH;
  DrawText(canvas, "RMS per image (px)", {double(l.x_right), double(y)}, Anchor::kTopLeft, kHeader);
  y += 42;
  double vmax = ResidualRms(r);
  for (double v : r.image_rms) vmax = std::max(vmax, v);
  double lo = 0, hi = std::max(vmax * 1.05, 1e-3);
  NiceLimits(&lo, &hi, 4);
  const int bx0 = l.x_right + l.index_w + l.name_w + 10, bx1 = bx0 + ReportLayout::kBarW;
  const int by0 = y, by1 = y + std::max(1, n) * ReportLayout::kRowH;
  auto X = [&](double v) { return bx0 + (bx1 - bx0) * v / hi; };
  const Ticks t = NiceTicks(0, hi, 4);
  for (double v : t.values) {
    DrawLine(canvas, {X(v), double(by0)}, {X(v), double(by1)}, cv::Scalar(232, 232, 232));
    DrawLine(canvas, {X(v), double(by1)}, {X(v), by1 + 5.0}, cv::Scalar(90, 90, 90));
    DrawText(canvas, FormatTick(v, t.decimals), {X(v), by1 + 8.0}, Anchor::kTop, kSmall);
  }
  DrawLine(canvas, {double(bx0), double(by0)}, {double(bx0), double(by1)}, cv::Scalar(90, 90, 90));
  // The overall RMS under the bars and their values.
  const double xr = X(ResidualRms(r));
  DrawDashedLine(canvas, {xr, by0 - 6.0}, {xr, double(by1)}, kRms, 1);
  TextStyle red = kSmall;
  red.colour = kRms;
  DrawText(canvas, Printf("all %.3f", ResidualRms(r)), {xr, by0 - 8.0}, Anchor::kBottom, red);
  DrawLine(canvas, {double(bx0), double(by1)}, {double(bx1), double(by1)}, cv::Scalar(90, 90, 90));
  for (int i = 0; i < n; ++i) {
    const double v = i < static_cast<int>(r.image_rms.size()) ? r.image_rms[i] : 0.0;
    DrawImageBar(r, i, l, by0 + (i + 0.5) * ReportLayout::kRowH, bx0, X(v), canvas);
  }
  return by1 + 40;
}

// Right column, below: the parameters with their deviations, from `y`.
void DrawParameterTable(const CalibrationResult& r, const ReportLayout& l, int y, cv::Mat* canvas) {
  y += 10;
  DrawText(canvas, "Parameters (value, 1 standard deviation)", {double(l.x_right), double(y)}, Anchor::kTopLeft,
           kHeader);
  y += 28;
  int col1 = 0, col2 = 0;
  std::vector<std::array<std::string, 3>> rows;
  for (const ParameterEstimate& p : r.parameters) {
    std::array<std::string, 3> row = {p.name, Printf("%.6g", p.value), ""};
    if (p.fixed)
      row[2] = "fixed";
    else if (std::isfinite(p.stddev))
      row[2] = Printf("+/- %.3g", p.stddev) +
               (p.value != 0 ? Printf("  (%.2g %%)", 100 * std::abs(p.stddev / p.value)) : std::string());
    else
      row[2] = "not determined";
    col1 = std::max(col1, TextBox(row[0], {0, 0}, Anchor::kTopLeft, kSmall).width);
    col2 = std::max(col2, TextBox(row[1], {0, 0}, Anchor::kTopLeft, kSmall).width);
    rows.push_back(row);
  }
  for (size_t i = 0; i < rows.size(); ++i) {
    const double yc = y + i * 19.0 + 9;
    if (i % 2 == 0)
      cv::rectangle(*canvas, cv::Rect(l.x_right - 4, int(yc) - 9, l.right_w - 10, 19), cv::Scalar(246, 246, 246),
                    cv::FILLED);
    DrawText(canvas, rows[i][0], {double(l.x_right), yc}, Anchor::kLeft, kSmall);
    DrawText(canvas, rows[i][1], {double(l.x_right + col1 + 20 + col2), yc}, Anchor::kRight, kSmall);
    TextStyle st = kSmall;
    if (rows[i][2] == "not determined" || rows[i][2] == "fixed") st.colour = cv::Scalar(130, 130, 130);
    DrawText(canvas, rows[i][2], {double(l.x_right + col1 + 20 + col2 + 14), yc}, Anchor::kLeft, st);
  }
}

}  // namespace

int WorstView(const CalibrationResult& r) {
  int worst = 0;
  for (size_t i = 1; i < r.image_rms.size(); ++i)
    if (r.image_rms[i] > r.image_rms[worst]) worst = static_cast<int>(i);
  return worst;
}

cv::Mat DrawReport(const CalibrationResult& r, const cv::Mat& image, int view_index) {
  const Sensor& s = r.calib.sensor;
  const int W = std::max(1, s.image_width), H = std::max(1, s.image_height);
  const ReportLayout layout = LayoutOf(r, W, H);
  cv::Mat canvas(layout.height, layout.width, CV_8UC3, kWhite);
  DrawReportTitle(r, W, H, &canvas);
  DrawCoverage(r, image, view_index, layout, &canvas);
  const ResidualSets residuals = ResidualsOf(r);
  const int below_scatter = DrawResidualScatter(r, residuals, layout, &canvas);
  DrawResidualHistogram(r, residuals, layout, below_scatter, &canvas);
  DrawParameterTable(r, layout, DrawRmsPerImage(r, layout, &canvas), &canvas);
  return canvas;
}

}  // namespace pano

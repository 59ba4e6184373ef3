// Small plotting helpers over OpenCV drawing: "nice" tick values (1-2-5
// steps), data-to-pixel transforms (optionally with equal aspect), axes with
// ticks, labels and grid, legends, colour bars, scale bars, and text that is
// placed where it overlaps nothing drawn before (greedy, a few offsets).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <string>
#include <vector>

namespace pano {

// ---- Tick values -----------------------------------------------------------

// The smallest step of the form {1, 2, 5} x 10^k that is >= range / target_count
// (range > 0, target_count >= 1); 1 for a non-finite or non-positive range.
double NiceStep(double range, int target_count);
// The largest value of the form {1, 2, 5} x 10^k that is <= x (x > 0): the
// length of a scale bar. 0 for x <= 0 or non-finite.
double NiceFloor(double x);

struct Ticks {
  double step = 1.0;
  std::vector<double> values;  // the multiples of step within [lo, hi]
  int decimals = 0;            // digits after the point that print every value exactly
};
// Ticks on [lo, hi] with about target_count intervals. An empty or inverted
// range is widened around its centre first (by 1, or 10 % of |lo|).
Ticks NiceTicks(double lo, double hi, int target_count = 5);
// [lo, hi] widened outward to multiples of NiceStep(hi - lo, target_count).
void NiceLimits(double* lo, double* hi, int target_count = 5);
// A tick label: fixed with `decimals` digits, never "-0".
std::string FormatTick(double value, int decimals);

// ---- Data to pixel ---------------------------------------------------------

// Maps data [x_lo, x_hi] x [y_lo, y_hi] onto the pixel rectangle `area`, x to
// the right and y up: (x_lo, y_lo) goes to area's bottom-left corner
// (area.x, area.y + area.height), (x_hi, y_hi) to its top-right corner. With
// equal_aspect, one data unit spans the same number of pixels on both axes:
// the range that would be stretched more is widened about its centre. Empty
// ranges are widened as NiceTicks does.
class PlotTransform {
 public:
  PlotTransform() = default;
  PlotTransform(const cv::Rect2d& area, double x_lo, double x_hi, double y_lo, double y_hi, bool equal_aspect);
  cv::Point2d ToPixel(double x, double y) const;
  cv::Point2d ToPixel(const Eigen::Vector2d& p) const { return ToPixel(p.x(), p.y()); }
  Eigen::Vector2d ToData(const cv::Point2d& px) const;
  double x_lo() const { return x_lo_; }
  double x_hi() const { return x_hi_; }
  double y_lo() const { return y_lo_; }
  double y_hi() const { return y_hi_; }
  double px_per_unit_x() const { return sx_; }
  double px_per_unit_y() const { return sy_; }
  const cv::Rect2d& area() const { return area_; }

 private:
  cv::Rect2d area_{0, 0, 1, 1};
  double x_lo_ = 0, x_hi_ = 1, y_lo_ = 0, y_hi_ = 1;
  double sx_ = 1, sy_ = 1;
};

// ---- Text ------------------------------------------------------------------

struct TextStyle {
  int font = cv::FONT_HERSHEY_SIMPLEX;
  double scale = 0.45;
  int thickness = 1;
  cv::Scalar colour{40, 40, 40};
  // An outline of this colour and width (px) under the text, for text over
  // images; 0: none.
  int halo = 0;
  cv::Scalar halo_colour{0, 0, 0};
};

// Where `at` lies on the text's box.
enum class Anchor { kTopLeft, kTop, kTopRight, kLeft, kCentre, kRight, kBottomLeft, kBottom, kBottomRight };

// The box the text occupies (ascenders to descenders) with its `anchor` at `at`.
cv::Rect TextBox(const std::string& text, const cv::Point2d& at, Anchor anchor, const TextStyle& style);
// Draws the text so (TextBox) and returns its box.
cv::Rect DrawText(cv::Mat* canvas, const std::string& text, const cv::Point2d& at, Anchor anchor,
                  const TextStyle& style);
// Text turned 90 degrees anticlockwise (reading upwards), centred at `centre`.
void DrawTextVertical(cv::Mat* canvas, const std::string& text, const cv::Point2d& centre, const TextStyle& style);
// `text` shortened from the left with "..." until it fits max_width pixels
// (unchanged when it fits).
std::string ShortenLeft(const std::string& text, int max_width, const TextStyle& style);

// Places labels where they overlap nothing placed or reserved before and stay
// within `bounds`: each label tries a few positions around its point (right,
// upper right, lower right, left, ..., above, below) and is skipped when none
// is free.
class LabelPlacer {
 public:
  explicit LabelPlacer(const cv::Rect& bounds) : bounds_(bounds) {}
  void Reserve(const cv::Rect& r) { taken_.push_back(r); }
  // A point marker of radius r (px) that no label may cover.
  void ReservePoint(const cv::Point2d& p, int radius);
  bool Free(const cv::Rect& r) const;
  // The box chosen for `text` near `point` (gap px away), or an empty
  // rectangle when none is free. Does not draw or reserve.
  cv::Rect Find(const std::string& text, const cv::Point2d& point, const TextStyle& style, int gap = 4) const;
  // Find, then draw and reserve; false when skipped.
  bool Place(cv::Mat* canvas, const std::string& text, const cv::Point2d& point, const TextStyle& style, int gap = 4);

 private:
  cv::Rect bounds_;
  std::vector<cv::Rect> taken_;
};

// ---- Colours ---------------------------------------------------------------

// Viridis at t in [0, 1] (clamped; NaN gives grey), BGR. Its top end is
// trimmed so that the lightest colour still shows on white.
cv::Scalar ColourMapValue(double t);
// A qualitative palette (Tableau 10), BGR; i wraps around.
cv::Scalar CategoricalColour(int i);

// ---- Axes, legend, colour bar, scale bar --------------------------------

struct AxesOptions {
  std::string x_label;
  std::string y_label;
  bool equal_aspect = false;
  bool grid = true;
  int x_ticks = 6;  // about this many intervals
  int y_ticks = 5;
  // Widen the limits to whole tick steps (else the data range is kept).
  bool nice_limits = true;
  bool x_tick_labels = true;  // off for upper panels that share the x axis of the one below
  // The left margin is at least this (px): panels stacked with the same
  // value keep their x axes aligned whatever their tick labels.
  int min_left_margin = 0;
  TextStyle tick_style{cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, cv::Scalar(60, 60, 60)};
  TextStyle label_style{cv::FONT_HERSHEY_SIMPLEX, 0.45, 1, cv::Scalar(30, 30, 30)};
};

// One panel: a frame inside `outer` (margins sized to the tick labels and
// axis labels), grid, ticks and their labels. Data drawn through plot() and
// Px() is clipped to the frame.
class Axes {
 public:
  Axes(cv::Mat* canvas, const cv::Rect& outer, double x_lo, double x_hi, double y_lo, double y_hi,
       const AxesOptions& options);
  // Grid, tick marks, tick labels and axis labels (before the data).
  void DrawBackground();
  // The frame line again (after the data, so it stays on top).
  void DrawFrame();
  const PlotTransform& transform() const { return transform_; }
  cv::Rect area() const;
  // The canvas region inside the frame, and a data point in its pixels.
  cv::Mat plot() { return (*canvas_)(area()); }
  cv::Point2d Px(double x, double y) const;
  cv::Point2d Px(const Eigen::Vector2d& p) const { return Px(p.x(), p.y()); }
  const Ticks& x_ticks() const { return xt_; }
  const Ticks& y_ticks() const { return yt_; }

 private:
  cv::Mat* canvas_;
  AxesOptions opt_;
  PlotTransform transform_;
  Ticks xt_, yt_;
};

struct LegendEntry {
  enum class Kind { kLine, kMarker, kPatch };
  std::string label;
  cv::Scalar colour;
  Kind kind = Kind::kLine;
  int thickness = 2;
  int marker = cv::MARKER_CROSS;  // for kMarker; -1: a filled circle, -2: a filled square
};
cv::Size LegendSize(const std::vector<LegendEntry>& entries, const TextStyle& style);
// A boxed legend with its `anchor` corner at `at`; returns its box.
cv::Rect DrawLegend(cv::Mat* canvas, const std::vector<LegendEntry>& entries, const cv::Point& at, Anchor anchor,
                    const TextStyle& style);
// Draws one legend symbol centred at `centre`.
void DrawLegendSymbol(cv::Mat* canvas, const LegendEntry& e, const cv::Point2d& centre, int width);

// A vertical colour bar (ColourMapValue from lo at the bottom to hi at the
// top) in `bar`, with ticks and labels on its right and `label` above.
void DrawColourBar(cv::Mat* canvas, const cv::Rect& bar, double lo, double hi, const std::string& label,
                   const TextStyle& style);

// A scale bar of NiceFloor(max_px / px_per_unit) units with its left end at
// `left` (px), labelled "<length> <units>" above; returns its box.
cv::Rect DrawScaleBar(cv::Mat* canvas, const cv::Point2d& left, double px_per_unit, double max_px,
                      const std::string& units, const TextStyle& style);

// Drawing primitives with anti-aliasing (OpenCV's need integer points;
// these keep 4 bits of sub-pixel precision).
void DrawLine(cv::Mat* canvas, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour, int thickness = 1);
void DrawDisc(cv::Mat* canvas, const cv::Point2d& c, double radius, const cv::Scalar& colour);
void DrawCircle(cv::Mat* canvas, const cv::Point2d& c, double radius, const cv::Scalar& colour, int thickness = 1);
void DrawArrow(cv::Mat* canvas, const cv::Point2d& from, const cv::Point2d& to, const cv::Scalar& colour,
               int thickness = 1, double tip_px = 6);
// A dashed line (dash and gap in px).
void DrawDashedLine(cv::Mat* canvas, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour,
                    int thickness = 1, double dash = 6, double gap = 4);

}  // namespace pano

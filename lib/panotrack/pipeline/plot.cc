#include "panotrack/pipeline/plot.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>  // IMWRITE_ constants
#include <opencv2/imgproc.hpp>

#include "panotrack/core/angles.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/video/opencv_io.h"

namespace pano {

namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kInk(40, 40, 40);
const cv::Scalar kWall(70, 70, 70);
const cv::Scalar kTruth(205, 205, 205);
const cv::Scalar kStart(44, 160, 44);      // green
const cv::Scalar kEnd(40, 39, 214);        // red
const cv::Scalar kLost(14, 127, 255);      // orange
const cv::Scalar kEstimate(180, 119, 31);  // blue
const cv::Scalar kLostShade(226, 232, 252);

bool Known(const PoseRow& r) { return r.status != PoseStatus::kLost; }

// The truth by frame.
std::map<int, const PoseRow*> ByFrame(const std::vector<PoseRow>& rows) {
  std::map<int, const PoseRow*> m;
  for (const PoseRow& r : rows)
    if (Known(r)) m[r.frame] = &r;
  return m;
}

// Position error of each estimated row against the truth (NaN where either is missing).
std::vector<double> PositionErrors(const std::vector<PoseRow>& est, const std::map<int, const PoseRow*>& truth) {
  std::vector<double> e(est.size(), std::nan(""));
  for (size_t i = 0; i < est.size(); ++i) {
    if (est[i].status != PoseStatus::kOk) continue;
    const auto it = truth.find(est[i].frame);
    if (it != truth.end()) e[i] = std::hypot(est[i].pose.x - it->second->pose.x, est[i].pose.y - it->second->pose.y);
  }
  return e;
}

// Marks every few pixels of a polyline as taken, so that labels keep off it.
void ReservePath(LabelPlacer* placer, const std::vector<cv::Point2d>& pts, int radius) {
  for (size_t i = 0; i < pts.size(); ++i) {
    placer->ReservePoint(pts[i], radius);
    if (i + 1 == pts.size()) break;
    const cv::Point2d d = pts[i + 1] - pts[i];
    const int steps = static_cast<int>(std::hypot(d.x, d.y) / 5.0);
    for (int k = 1; k < steps; ++k) placer->ReservePoint(pts[i] + d * (static_cast<double>(k) / steps), radius);
  }
}

void EncodeAndWrite(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> png;
  try {
    if (!opencv_io::imencode(".png", image, png, {cv::IMWRITE_PNG_COMPRESSION, 9}))
      throw Error("cannot encode the plot");
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
  AtomicFile f(path);
  f.Write(png.data(), png.size());
  f.Commit();
}

}  // namespace

namespace {

// The run's counts and, with a truth, each estimate's position error.
struct RunCounts {
  std::vector<double> errors;  // per estimate row; NaN where there is none
  double max_error = 0.0, sum2 = 0.0;
  int n_errors = 0, n_ok = 0, n_lost = 0;
};

RunCounts CountRun(const std::vector<PoseRow>& est, const std::map<int, const PoseRow*>& truth) {
  RunCounts c;
  c.errors = PositionErrors(est, truth);
  for (double e : c.errors)
    if (std::isfinite(e)) {
      c.max_error = std::max(c.max_error, e);
      c.sum2 += e * e;
      ++c.n_errors;
    }
  for (const PoseRow& r : est) {
    c.n_ok += r.status == PoseStatus::kOk;
    c.n_lost += r.status == PoseStatus::kLost;
  }
  return c;
}

// The map, the estimate and the truth, with a margin of 4 %.
void PlotExtent(const Map& map, const std::vector<PoseRow>& est, const std::vector<PoseRow>& gt, Eigen::Vector2d* lo,
                Eigen::Vector2d* hi) {
  double top;
  map.Extent(lo, hi, &top);
  auto grow = [&](const PoseRow& r) {
    if (!Known(r) || !std::isfinite(r.pose.x) || !std::isfinite(r.pose.y)) return;
    *lo = lo->cwiseMin(Eigen::Vector2d(r.pose.x, r.pose.y));
    *hi = hi->cwiseMax(Eigen::Vector2d(r.pose.x, r.pose.y));
  };
  for (const PoseRow& r : est) grow(r);
  for (const PoseRow& r : gt) grow(r);
  if (!(hi->x() >= lo->x()) || !(hi->y() >= lo->y())) *lo = *hi = Eigen::Vector2d::Zero();
  const double pad = 0.04 * std::max({hi->x() - lo->x(), hi->y() - lo->y(), 1e-9});
  *lo -= Eigen::Vector2d(pad, pad);
  *hi += Eigen::Vector2d(pad, pad);
}

// The room, boxes, distractors and walls (landmark rectangles).
void DrawMapLayer(const Map& map, const Axes& axes, cv::Mat& plot, LabelPlacer* placer) {
  if (map.room.present) {
    cv::rectangle(plot, axes.Px(map.room.min), axes.Px(map.room.max), cv::Scalar(250, 248, 246), cv::FILLED);
    cv::rectangle(plot, axes.Px(map.room.min), axes.Px(map.room.max), cv::Scalar(150, 150, 150), 2);
  }
  for (const MapBox& b : map.boxes) {
    const cv::Point2d p0 = axes.Px(b.min.x(), b.min.y()), p1 = axes.Px(b.max.x(), b.max.y());
    cv::rectangle(plot, p0, p1, cv::Scalar(222, 222, 222), cv::FILLED);
    cv::rectangle(plot, p0, p1, kWall, 2);
    for (const cv::Point2d& c : {p0, p1, cv::Point2d(p0.x, p1.y), cv::Point2d(p1.x, p0.y)}) placer->ReservePoint(c, 3);
  }
  for (const MapRectangle& r : map.distractors)
    DrawDashedLine(&plot, axes.Px(r.from), axes.Px(r.to), cv::Scalar(170, 170, 170), 2);
  for (const MapRectangle& r : map.rectangles) {
    DrawLine(&plot, axes.Px(r.from), axes.Px(r.to), kWall, 3);
    ReservePath(placer, {axes.Px(r.from), axes.Px(r.to)}, 3);
  }
  for (const MapRectangle& r : map.rectangles)
    for (const Eigen::Vector2d& c : {r.from, r.to}) DrawDisc(&plot, axes.Px(c), 3.5, kInk);
}

// Ground truth (drawn under the estimate), broken where it is lost.
void DrawTruthPath(const std::vector<PoseRow>& gt, const Axes& axes, cv::Mat& plot, LabelPlacer* placer) {
  std::vector<cv::Point2d> path;
  auto flush = [&](const cv::Scalar& colour, int thickness) {
    for (size_t i = 1; i < path.size(); ++i) DrawLine(&plot, path[i - 1], path[i], colour, thickness);
    ReservePath(placer, path, 3);
    path.clear();
  };
  for (const PoseRow& r : gt) {
    if (!Known(r)) {
      flush(kTruth, 7);
      continue;
    }
    path.push_back(axes.Px(r.pose.x, r.pose.y));
  }
  flush(kTruth, 7);
}

// The estimate, broken at lost frames, each step in `colour(i)`; returns the
// rows with a pose.
template <typename Colour>
std::vector<size_t> DrawEstimatePath(const std::vector<PoseRow>& est, const Axes& axes, Colour colour, cv::Mat& plot,
                                     LabelPlacer* placer) {
  std::vector<size_t> known;
  for (size_t i = 0; i < est.size(); ++i) {
    if (!Known(est[i])) continue;
    const bool joined = !known.empty() && known.back() + 1 == i;
    if (joined)
      DrawLine(&plot, axes.Px(est[known.back()].pose.x, est[known.back()].pose.y),
               axes.Px(est[i].pose.x, est[i].pose.y), colour(i), 2);
    known.push_back(i);
  }
  const bool dots = known.size() <= 400;
  for (size_t i : known) {
    const cv::Point2d p = axes.Px(est[i].pose.x, est[i].pose.y);
    if (dots) DrawDisc(&plot, p, 2.2, colour(i));
    placer->ReservePoint(p, 3);
  }
  return known;
}

// Heading arrows: at most about 24 along the run, some 40 px apart. Returns
// the rows between two arrows.
size_t DrawHeadingArrows(const std::vector<PoseRow>& est, const std::vector<size_t>& known, const Axes& axes,
                         cv::Mat& plot, LabelPlacer* placer) {
  double path_px = 0.0;
  for (size_t k = 1; k < known.size(); ++k) {
    const cv::Point2d d = axes.Px(est[known[k]].pose.x, est[known[k]].pose.y) -
                          axes.Px(est[known[k - 1]].pose.x, est[known[k - 1]].pose.y);
    path_px += std::min(std::hypot(d.x, d.y), 60.0);  // a jump (kidnap) counts as one step
  }
  const size_t arrow_every = std::max<size_t>(
      {1, (known.size() + 23) / 24, static_cast<size_t>(std::ceil(40.0 * known.size() / std::max(1.0, path_px)))});
  const double arrow_px = 15.0;
  for (size_t k = 0; k < known.size(); k += arrow_every) {
    const PoseRow& r = est[known[k]];
    const cv::Point2d p = axes.Px(r.pose.x, r.pose.y);
    const cv::Point2d q = p + cv::Point2d(std::cos(r.pose.theta), -std::sin(r.pose.theta)) * arrow_px;
    // A white edge around the tip keeps it visible over the path it points along.
    const cv::Point2d u = (q - p) * (1.0 / arrow_px);
    DrawArrow(&plot, q - u * 0.5, q + u * 1.5, kWhite, 1, 9.5);
    DrawArrow(&plot, p, q, cv::Scalar(30, 30, 30), 1, 7);
    ReservePath(placer, {p, q}, 2);
  }
  return arrow_every;
}

// Lost frames: at the truth's pose, else at the last pose known.
void DrawLostFrames(const std::vector<PoseRow>& est, const std::map<int, const PoseRow*>& truth, const Axes& axes,
                    cv::Mat& plot, LabelPlacer* placer) {
  const PoseRow* last_known = nullptr;
  for (const PoseRow& r : est) {
    if (Known(r)) {
      last_known = &r;
      continue;
    }
    const auto it = truth.find(r.frame);
    const PoseRow* at = it != truth.end() ? it->second : last_known;
    if (!at) continue;
    const cv::Point2d p = axes.Px(at->pose.x, at->pose.y);
    cv::drawMarker(plot, cv::Point(int(std::lround(p.x)), int(std::lround(p.y))), kLost, cv::MARKER_TILTED_CROSS, 11, 2,
                   cv::LINE_AA);
    placer->ReservePoint(p, 6);
  }
}

void DrawStartAndEnd(const PoseRow& s, const PoseRow& e, const Axes& axes, cv::Mat& plot, LabelPlacer* placer) {
  const cv::Point2d ps = axes.Px(s.pose.x, s.pose.y), pe = axes.Px(e.pose.x, e.pose.y);
  cv::rectangle(plot, cv::Rect(int(std::lround(pe.x)) - 6, int(std::lround(pe.y)) - 6, 13, 13), kWhite, cv::FILLED);
  cv::rectangle(plot, cv::Rect(int(std::lround(pe.x)) - 5, int(std::lround(pe.y)) - 5, 11, 11), kEnd, cv::FILLED);
  DrawDisc(&plot, ps, 7.5, kWhite);
  DrawDisc(&plot, ps, 6, kStart);
  placer->ReservePoint(ps, 8);
  placer->ReservePoint(pe, 8);
}

// The walls' and boxes' names wherever they fit.
void PlaceMapLabels(const Map& map, const Axes& axes, cv::Mat& plot, LabelPlacer* placer) {
  const TextStyle label_style{cv::FONT_HERSHEY_SIMPLEX, 0.38, 1, cv::Scalar(30, 30, 30)};
  for (const MapRectangle& r : map.rectangles)
    placer->Place(&plot, r.id, axes.Px(0.5 * (r.from + r.to)), label_style, 6);
  for (const MapBox& b : map.boxes) {
    const cv::Point2d c = axes.Px(0.5 * (b.min.x() + b.max.x()), 0.5 * (b.min.y() + b.max.y()));
    const cv::Rect box = TextBox(b.id, c, Anchor::kCentre, label_style);
    if (placer->Free(box)) {
      DrawText(&plot, b.id, box.tl(), Anchor::kTopLeft, label_style);
      placer->Reserve(box);
    } else {
      placer->Place(&plot, b.id, c, label_style, 8);
    }
  }
}

std::string TrajectoryTitle(size_t frames, const RunCounts& c, const std::string& units) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "Trajectory: %d frames, %d tracked, %d lost", static_cast<int>(frames), c.n_ok,
                c.n_lost);
  std::string heading = buf;
  if (c.n_errors > 0) {
    std::snprintf(buf, sizeof buf, "; position error RMS %.3g, max %.3g %s", std::sqrt(c.sum2 / c.n_errors),
                  c.max_error, units.c_str());
    heading += buf;
  }
  return heading;
}

// What the side panel shows.
struct SidePanel {
  cv::Rect column;  // x and width of the panel; y and height of the map's area
  bool has_truth = false, any_known = false;
  size_t known = 0, arrow_every = 1;
  double colour_max = 1.0, px_per_unit = 1.0;
  std::string units;
};

std::vector<LegendEntry> TrajectoryLegend(const Map& map, const RunCounts& c, const SidePanel& s) {
  std::vector<LegendEntry> legend;
  if (!map.rectangles.empty()) legend.push_back({"wall (landmarks)", kWall, LegendEntry::Kind::kLine, 3});
  if (!map.boxes.empty()) legend.push_back({"box", cv::Scalar(200, 200, 200), LegendEntry::Kind::kPatch});
  if (s.has_truth) legend.push_back({"ground truth", kTruth, LegendEntry::Kind::kLine, 7});
  legend.push_back({s.has_truth ? "estimate (colour: error)" : "estimate",
                    s.has_truth ? ColourMapValue(0.3) : kEstimate, LegendEntry::Kind::kLine, 2});
  if (s.any_known)
    legend.push_back({s.known > s.arrow_every ? "heading (every " + std::to_string(s.arrow_every) +
                                                    (s.arrow_every == 1 ? " frame)" : " frames)")
                                              : std::string("heading"),
                      cv::Scalar(30, 30, 30), LegendEntry::Kind::kLine, 1});
  if (s.any_known) {
    legend.push_back({"start", kStart, LegendEntry::Kind::kMarker, 1, -1});
    legend.push_back({"end", kEnd, LegendEntry::Kind::kMarker, 1, -2});
  }
  if (c.n_lost > 0)
    legend.push_back({"lost frame" + std::string(s.has_truth ? " (at truth)" : " (at last pose)"), kLost,
                      LegendEntry::Kind::kMarker, 2, cv::MARKER_TILTED_CROSS});
  return legend;
}

// Side panel: legend, scale bar (beside the map, where it hides nothing)
// and the error's colour bar.
void DrawTrajectorySidePanel(const Map& map, const RunCounts& c, const SidePanel& s, cv::Mat* img) {
  const TextStyle small{cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, kInk};
  const int x = s.column.x, side = s.column.width;
  const cv::Rect lb = DrawLegend(img, TrajectoryLegend(map, c, s), {x + 4, s.column.y}, Anchor::kTopLeft, small);
  const cv::Rect sb = DrawScaleBar(img, {x + 10.0, lb.br().y + 44.0}, s.px_per_unit, side - 50.0, s.units, small);
  if (s.has_truth && c.n_errors > 0) {
    const int bar_top = std::max(lb.br().y, sb.br().y) + 40;
    const int bar_h = std::min(260, s.column.y + s.column.height - bar_top);
    if (bar_h > 60)
      DrawColourBar(img, cv::Rect(x + 10, bar_top, 18, bar_h), 0.0, s.colour_max, "position error (" + s.units + ")",
                    small);
  }
}

}  // namespace

TrajectoryFigure DrawTrajectoryPlot(const Map& map, const std::vector<PoseRow>& est, const std::vector<PoseRow>& gt) {
  const std::map<int, const PoseRow*> truth = ByFrame(gt);
  const bool has_truth = !truth.empty();
  const RunCounts counts = CountRun(est, truth);
  Eigen::Vector2d lo, hi;
  PlotExtent(map, est, gt, &lo, &hi);

  // Canvas: title, the map (equal aspect) and a side panel for the legend
  // and colour bar; the height follows the map's aspect.
  const int width = 1000, side = 220, title_h = 36;
  const double aspect = (hi.y() - lo.y()) / std::max(1e-9, hi.x() - lo.x());
  const int plot_h = static_cast<int>(std::clamp(680.0 * aspect, 360.0, 820.0));
  const int height = title_h + plot_h + 60;
  cv::Mat img(height, width, CV_8UC3, kWhite);
  const std::string units = map.units.empty() ? "units" : map.units;
  AxesOptions ao;
  ao.x_label = "x (" + units + ")";
  ao.y_label = "y (" + units + ")";
  ao.equal_aspect = true;
  ao.nice_limits = false;
  ao.x_ticks = 8;
  ao.y_ticks = std::max(3, static_cast<int>(8 * aspect));
  Axes axes(&img, cv::Rect(0, title_h, width - side, height - title_h), lo.x(), hi.x(), lo.y(), hi.y(), ao);
  axes.DrawBackground();
  const cv::Rect area = axes.area();
  cv::Mat plot = axes.plot();
  LabelPlacer placer(cv::Rect(0, 0, area.width, area.height));

  DrawMapLayer(map, axes, plot, &placer);
  DrawTruthPath(gt, axes, plot, &placer);
  // The estimate, coloured by its error where there is a truth.
  const double max_error = counts.max_error;
  const double colour_max =
      max_error > 0 ? NiceTicks(0, max_error, 4).step * std::ceil(max_error / NiceTicks(0, max_error, 4).step - 1e-9)
                    : 1.0;
  auto est_colour = [&](size_t i) { return has_truth ? ColourMapValue(counts.errors[i] / colour_max) : kEstimate; };
  const std::vector<size_t> known = DrawEstimatePath(est, axes, est_colour, plot, &placer);
  const size_t arrow_every = DrawHeadingArrows(est, known, axes, plot, &placer);
  DrawLostFrames(est, truth, axes, plot, &placer);
  if (!known.empty()) DrawStartAndEnd(est[known.front()], est[known.back()], axes, plot, &placer);
  PlaceMapLabels(map, axes, plot, &placer);
  axes.DrawFrame();

  const TextStyle title{cv::FONT_HERSHEY_SIMPLEX, 0.55, 1, cv::Scalar(20, 20, 20)};
  DrawText(&img, TrajectoryTitle(est.size(), counts, units), {double(area.x), 12.0}, Anchor::kTopLeft, title);
  SidePanel panel;
  panel.column = cv::Rect(width - side, area.y, side, area.height);
  panel.has_truth = has_truth;
  panel.any_known = !known.empty();
  panel.known = known.size();
  panel.arrow_every = arrow_every;
  panel.colour_max = colour_max;
  panel.px_per_unit = axes.transform().px_per_unit_x();
  panel.units = units;
  DrawTrajectorySidePanel(map, counts, panel, &img);
  if (known.empty())
    DrawText(&img, "no frame tracked", {area.x + 0.5 * area.width, area.y + 0.5 * area.height}, Anchor::kCentre,
             TextStyle{cv::FONT_HERSHEY_SIMPLEX, 0.7, 2, kEnd});
  return {img, axes.transform()};
}

namespace {

// One compared frame: its time, the error in x, y, heading (degrees) and
// three reported standard deviations of each (NaN where none).
struct ErrorSample {
  double t, e[3], sigma[3];
};

// The time axis: the rows' times when they increase, else frame numbers.
struct TimeAxis {
  bool use_time = false;
  double When(const PoseRow& r) const { return use_time ? r.time_s : static_cast<double>(r.frame); }
};

TimeAxis TimeAxisOf(const std::vector<PoseRow>& est) {
  TimeAxis axis;
  axis.use_time = est.size() > 1;
  for (size_t i = 1; i < est.size() && axis.use_time; ++i)
    axis.use_time =
        std::isfinite(est[i].time_s) && std::isfinite(est[i - 1].time_s) && est[i].time_s > est[i - 1].time_s;
  return axis;
}

std::vector<ErrorSample> ErrorSamples(const std::vector<PoseRow>& est, const std::map<int, const PoseRow*>& truth,
                                      const TimeAxis& axis) {
  std::vector<ErrorSample> samples;
  for (const PoseRow& r : est) {
    if (r.status != PoseStatus::kOk) continue;
    const auto it = truth.find(r.frame);
    if (it == truth.end()) continue;
    ErrorSample s;
    s.t = axis.When(r);
    s.e[0] = r.pose.x - it->second->pose.x;
    s.e[1] = r.pose.y - it->second->pose.y;
    s.e[2] = WrapAngle(r.pose.theta - it->second->pose.theta) * 180 / M_PI;
    for (int k = 0; k < 3; ++k) {
      const double sd = k < static_cast<int>(r.extra.size()) ? r.extra[k] : std::nan("");
      s.sigma[k] = 3.0 * (k == 2 ? sd * 180 / M_PI : sd);
    }
    samples.push_back(s);
  }
  return samples;
}

// One component's figures: RMS, how many frames carry a deviation and how
// many of those lie within it, and a symmetric range holding the errors and
// most of the band (a few frames' wide bands would flatten the rest).
struct ComponentStats {
  double rms = 0.0, ylim = 1.0;
  int within = 0, with_sigma = 0;
};

ComponentStats StatsOf(const std::vector<ErrorSample>& samples, int k) {
  ComponentStats c;
  std::vector<double> sig;
  double emax = 0;
  for (const ErrorSample& s : samples) {
    emax = std::max(emax, std::abs(s.e[k]));
    c.rms += s.e[k] * s.e[k];
    if (std::isfinite(s.sigma[k])) {
      sig.push_back(s.sigma[k]);
      ++c.with_sigma;
      c.within += std::abs(s.e[k]) <= s.sigma[k];
    }
  }
  if (!samples.empty()) c.rms = std::sqrt(c.rms / samples.size());
  double smax = 0;
  if (!sig.empty()) {
    std::sort(sig.begin(), sig.end());
    smax = sig[std::min(sig.size() - 1, static_cast<size_t>(0.95 * sig.size()))];
  }
  c.ylim = 1.1 * std::max(emax, smax);
  if (!(c.ylim > 0)) c.ylim = 1.0;
  return c;
}

const cv::Scalar kBand(240, 222, 200);

// Lost frames shaded, each one frame interval `dt` wide.
void ShadeLostFrames(const std::vector<PoseRow>& est, const TimeAxis& axis, double dt, const Axes& axes,
                     cv::Mat& plot) {
  for (const PoseRow& r : est)
    if (r.status == PoseStatus::kLost) {
      const double x0 = axes.Px(axis.When(r) - 0.5 * dt, 0).x, x1 = axes.Px(axis.When(r) + 0.5 * dt, 0).x;
      cv::rectangle(plot, cv::Point(int(std::floor(x0)), 0), cv::Point(int(std::ceil(x1)), plot.rows), kLostShade,
                    cv::FILLED);
    }
}

// The +- 3 sigma band of component k, per run of samples with a deviation
// (a gap of more than 1.5 frame intervals breaks it).
void DrawSigmaBand(const std::vector<ErrorSample>& samples, int k, double dt, double ylim, const Axes& axes,
                   cv::Mat& plot) {
  std::vector<cv::Point> upper, lower;
  auto flush_band = [&] {
    if (upper.size() >= 1) {
      std::vector<cv::Point> poly(upper);
      poly.insert(poly.end(), lower.rbegin(), lower.rend());
      if (upper.size() == 1) {
        cv::line(plot, upper[0], lower[0], kBand, 3);
      } else {
        cv::fillPoly(plot, std::vector<std::vector<cv::Point>>{poly}, kBand, cv::LINE_AA);
      }
    }
    upper.clear();
    lower.clear();
  };
  double previous_t = -1e300;
  for (const ErrorSample& s : samples) {
    if (!std::isfinite(s.sigma[k]) || s.t - previous_t > 1.5 * dt) flush_band();
    previous_t = s.t;
    if (!std::isfinite(s.sigma[k])) continue;
    const double sg = std::min(s.sigma[k], 4 * ylim);
    const cv::Point2d u = axes.Px(s.t, sg), l = axes.Px(s.t, -sg);
    upper.emplace_back(int(std::lround(u.x)), int(std::lround(u.y)));
    lower.emplace_back(int(std::lround(l.x)), int(std::lround(l.y)));
  }
  flush_band();
}

// Component k's errors, joined where frames follow each other.
void DrawErrorLine(const std::vector<ErrorSample>& samples, int k, double dt, const Axes& axes, cv::Mat& plot) {
  double previous_t = -1e300;
  for (size_t i = 0; i < samples.size(); ++i) {
    if (i > 0 && samples[i].t - previous_t <= 1.5 * dt)
      DrawLine(&plot, axes.Px(samples[i - 1].t, samples[i - 1].e[k]), axes.Px(samples[i].t, samples[i].e[k]),
               kEstimate, 1);
    previous_t = samples[i].t;
    if (samples.size() <= 150) DrawDisc(&plot, axes.Px(samples[i].t, samples[i].e[k]), 1.8, kEstimate);
  }
}

// The panel's figures at its upper right.
void DrawPanelFigures(const std::vector<ErrorSample>& samples, const ComponentStats& c, const cv::Rect& area,
                      const TextStyle& style, cv::Mat* img) {
  char buf[160];
  if (samples.empty())
    std::snprintf(buf, sizeof buf, "no frame to compare");
  else if (c.with_sigma > 0)
    std::snprintf(buf, sizeof buf, "RMS %.3g, within 3 sigma: %.0f %%", c.rms, 100.0 * c.within / c.with_sigma);
  else
    std::snprintf(buf, sizeof buf, "RMS %.3g", c.rms);
  const cv::Rect tb = TextBox(buf, {double(area.x + area.width - 8), double(area.y + 6)}, Anchor::kTopRight, style);
  cv::rectangle(*img, cv::Rect(tb.x - 4, tb.y - 3, tb.width + 8, tb.height + 6), kWhite, cv::FILLED);
  DrawText(img, buf, tb.tl(), Anchor::kTopLeft, style);
}

}  // namespace

cv::Mat DrawErrorPlot(const std::vector<PoseRow>& est, const std::vector<PoseRow>& gt, const std::string& units_in) {
  const std::string units = units_in.empty() ? "units" : units_in;
  const TimeAxis time = TimeAxisOf(est);
  const std::vector<ErrorSample> samples = ErrorSamples(est, ByFrame(gt), time);
  double t_lo = est.empty() ? 0 : time.When(est.front()), t_hi = est.empty() ? 1 : time.When(est.back());
  const double dt = est.size() > 1 ? (t_hi - t_lo) / (est.size() - 1) : 1.0;
  const bool any_lost =
      std::any_of(est.begin(), est.end(), [](const PoseRow& r) { return r.status == PoseStatus::kLost; });

  const int width = 960, panel_h = 210, title_h = 36;
  const int height = title_h + 3 * panel_h + 44;
  cv::Mat img(height, width, CV_8UC3, kWhite);
  const TextStyle small{cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, kInk};
  const char* names[3] = {"x error", "y error", "heading error"};
  for (int k = 0; k < 3; ++k) {
    const ComponentStats stats = StatsOf(samples, k);
    AxesOptions ao;
    ao.y_label = std::string(names[k]) + (k == 2 ? " (deg)" : " (" + units + ")");
    ao.x_label = k == 2 ? (time.use_time ? "time (s)" : "frame") : "";
    ao.x_ticks = 10;
    ao.y_ticks = 4;
    ao.nice_limits = false;  // the time axis spans the run exactly; y is made nice below
    ao.x_tick_labels = k == 2;
    ao.min_left_margin = 90;
    double y_lo = -stats.ylim, y_hi = stats.ylim;
    NiceLimits(&y_lo, &y_hi, ao.y_ticks);
    // The same left margin on every panel, so the time axes line up.
    Axes axes(&img, cv::Rect(0, title_h + k * panel_h, width, k == 2 ? panel_h + 40 : panel_h), t_lo - 0.5 * dt,
              t_hi + 0.5 * dt, y_lo, y_hi, ao);
    axes.DrawBackground();
    cv::Mat plot = axes.plot();
    ShadeLostFrames(est, time, dt, axes, plot);
    DrawSigmaBand(samples, k, dt, stats.ylim, axes, plot);
    DrawLine(&plot, axes.Px(t_lo - dt, 0), axes.Px(t_hi + dt, 0), cv::Scalar(150, 150, 150));
    DrawErrorLine(samples, k, dt, axes, plot);
    axes.DrawFrame();
    const cv::Rect a = axes.area();
    DrawPanelFigures(samples, stats, a, small, &img);
    if (k == 0) {
      std::vector<LegendEntry> legend = {{"estimate - truth", kEstimate, LegendEntry::Kind::kLine, 1},
                                         {"+/- 3 std (reported)", kBand, LegendEntry::Kind::kPatch}};
      if (any_lost) legend.push_back({"lost frame", kLostShade, LegendEntry::Kind::kPatch});
      DrawLegend(&img, legend, {a.x + 8, a.y + 6}, Anchor::kTopLeft, small);
    }
  }
  int n_lost = 0;
  for (const PoseRow& r : est) n_lost += r.status == PoseStatus::kLost;
  char buf[200];
  std::snprintf(buf, sizeof buf, "Error against ground truth: %d frames compared, %d lost",
                static_cast<int>(samples.size()), n_lost);
  DrawText(&img, buf, {10.0, 12.0}, Anchor::kTopLeft,
           TextStyle{cv::FONT_HERSHEY_SIMPLEX, 0.55, 1, cv::Scalar(20, 20, 20)});
  return img;
}

std::string ErrorPlotPath(const std::string& plot_path) {
  const std::filesystem::path p(plot_path);
  return (p.parent_path() / (p.stem().string() + "_error.png")).string();
}

void WritePlot(const std::string& path, const Map& map, const std::vector<PoseRow>& estimate,
               const std::vector<PoseRow>& truth) {
  const TrajectoryFigure fig = DrawTrajectoryPlot(map, estimate, truth);
  cv::Mat errors;
  if (!truth.empty()) errors = DrawErrorPlot(estimate, truth, map.units);
  EncodeAndWrite(path, fig.image);
  if (!errors.empty()) EncodeAndWrite(ErrorPlotPath(path), errors);
}

}  // namespace pano

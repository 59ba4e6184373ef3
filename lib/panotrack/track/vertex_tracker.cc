#include "panotrack/track/vertex_tracker.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/track/edge_profile.h"

namespace pano {

void VertexOptions::Check() const {
  if (min_half_px < 2 || max_half_px < min_half_px || max_half_px > 64)
    throw Error("vertex tracker: template quadrant sizes: expected 2 <= min_half_px <= max_half_px <= 64");
  if (!(face_fraction > 0.0 && face_fraction <= 1.0))
    throw Error("vertex tracker: face_fraction: expected 0..1");
  if (!(min_score > 0.0 && min_score < 1.0)) throw Error("vertex tracker: min_score: expected 0..1");
  if (!(min_peak_margin >= 0.0 && min_peak_margin < 1.0))
    throw Error("vertex tracker: min_peak_margin: expected 0..1");
  if (!(min_search_px >= 0.0) || max_search_warped_px < 1 || max_search_warped_px > 512)
    throw Error("vertex tracker: search widths: expected min_search_px >= 0, max_search_warped_px 1..512");
  if (!(inner_radius_fraction >= 0.0 && inner_radius_fraction < 1.0))
    throw Error("vertex tracker: inner_radius_fraction: expected 0..1");
}

double HorizonRadius(const Sensor& sensor) {
  // E(infinity, 0): a point at the pinhole's height, far away in mirror units.
  const double scale = std::abs(sensor.params.vertex_distance) + std::abs(sensor.params.curvature_radius);
  for (double k = 1e6; k >= 10.0; k /= 10.0) {
    double r;
    if (sensor.image_radius(k * scale, 0.0, &r) && std::isfinite(r) && r > 0.0) return r;
  }
  throw Error("vertex tracker: the sensor does not see the horizon (no image radius for E(inf, 0))");
}

// ---------------------------------------------------------------------------
// Quasi-cylindrical view.

QuasiCylindricalView::QuasiCylindricalView(const Sensor& sensor, double inner_radius,
                                           double outer_radius, int pad)
    : rad_h_(HorizonRadius(sensor)), pad_(pad), image_width_(sensor.image_width),
      image_height_(sensor.image_height) {
  if (!(inner_radius >= 0.0) || !(outer_radius > inner_radius + 2.0) || pad < 0)
    throw Error("quasi-cylindrical view: expected 0 <= inner radius < outer radius, pad >= 0");
  if (image_width_ < 2 || image_height_ < 2) throw Error("quasi-cylindrical view: no image size");
  width_ = static_cast<int>(std::lround(2.0 * M_PI * rad_h_));
  r0_ = inner_radius;
  rows_ = static_cast<int>(std::ceil(outer_radius - inner_radius)) + 1;
  map_u_.create(rows_, cols(), CV_32FC1);
  map_v_.create(rows_, cols(), CV_32FC1);
  taps_.resize(static_cast<size_t>(rows_) * cols());
  const int stride = image_width_ + 2;  // the padded frame
  for (int y = 0; y < rows_; ++y) {
    const double r = radius_of_y(y);
    for (int x = 0; x < cols(); ++x) {
      // Columns beyond the ends repeat the azimuths of the other end.
      const Eigen::Vector2d px = sensor.from_polar(r, azimuth_of_x(x));
      map_u_.at<float>(y, x) = static_cast<float>(px.x());
      map_v_.at<float>(y, x) = static_cast<float>(px.y());
      // Padded-frame coordinates: pixel (u, v) is at (u + 1, v + 1).
      const double pu = px.x() + 1.0, pv = px.y() + 1.0;
      Tap& t = taps_[static_cast<size_t>(y) * cols() + x];
      const double fu = std::floor(pu), fv = std::floor(pv);
      if (fu < 0 || fv < 0 || fu + 1 > image_width_ + 1 || fv + 1 > image_height_ + 1) {
        t = {-1, 0.f, 0.f};
        continue;
      }
      t.offset = static_cast<int>(fv) * stride + static_cast<int>(fu);
      t.wx = static_cast<float>(pu - fu);
      t.wy = static_cast<float>(pv - fv);
    }
  }
}

double QuasiCylindricalView::x_of_azimuth(double azimuth) const {
  double x = WrapAnglePositive(azimuth) * width_ / (2.0 * M_PI);
  if (x >= width_) x -= width_;
  return pad_ + x;
}

double QuasiCylindricalView::azimuth_of_x(double x) const {
  return (x - pad_) * (2.0 * M_PI / width_);
}

void QuasiCylindricalView::PadFrame(const cv::Mat& grey, cv::Mat* padded) const {
  if (grey.type() != CV_8UC1 || grey.cols != image_width_ || grey.rows != image_height_)
    throw Error("quasi-cylindrical view: expected an 8-bit grey frame of the sensor's size");
  cv::copyMakeBorder(grey, *padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  // The taps index a contiguous padded frame of width + 2 columns.
  CV_Assert(padded->isContinuous() && static_cast<int>(padded->step[0]) == image_width_ + 2);
}

// One row of bilinear taps.
void QuasiCylindricalView::WarpRow(const uint8_t* src, int stride, const Tap* taps, int n, float* out) {
  for (int x = 0; x < n; ++x) {
    const Tap& t = taps[x];
    if (t.offset < 0) {
      out[x] = 0.f;
      continue;
    }
    const uint8_t* p = src + t.offset;
    const float top = p[0] + t.wx * (static_cast<float>(p[1]) - p[0]);
    const float bottom = p[stride] + t.wx * (static_cast<float>(p[stride + 1]) - p[stride]);
    out[x] = top + t.wy * (bottom - top);
  }
}

void QuasiCylindricalView::WarpRegion(const cv::Mat& padded, int x0, int y0, int w, int h,
                                      cv::Mat* out) const {
  CV_Assert(x0 >= 0 && y0 >= 0 && w > 0 && h > 0 && x0 + w <= cols() && y0 + h <= rows_);
  CV_Assert(padded.type() == CV_8UC1 && padded.cols == image_width_ + 2 && padded.rows == image_height_ + 2);
  out->create(h, w, CV_32FC1);
  const int stride = static_cast<int>(padded.step[0]);
  for (int y = 0; y < h; ++y)
    WarpRow(padded.ptr<uint8_t>(0), stride, &taps_[static_cast<size_t>(y0 + y) * cols() + x0], w,
            out->ptr<float>(y));
}

void QuasiCylindricalView::Warp(const cv::Mat& grey, cv::Mat* view, int num_threads) const {
  cv::Mat padded;
  PadFrame(grey, &padded);
  const int stride = static_cast<int>(padded.step[0]);
  view->create(rows_, cols(), CV_32FC1);
  const int n_rows = rows_, n_cols = cols();
  // Interpolation only: the rows cannot throw.
#pragma omp parallel for schedule(static) num_threads(ThreadCount(num_threads))
  for (int y = 0; y < n_rows; ++y)
    WarpRow(padded.ptr<uint8_t>(0), stride, &taps_[static_cast<size_t>(y) * n_cols], n_cols, view->ptr<float>(y));
}

// ---------------------------------------------------------------------------
// Corner search.

CornerPeak FindCorner(const cv::Mat& sum, const cv::Mat& sqsum, const CornerType& type, int half_x,
                      int half_y, double cx, double cy, double sx, double sy) {
  CornerPeak best;
  const int cols = sum.cols - 1, rows = sum.rows - 1;
  // A placement is the integer boundary (bx, by) between the quadrants: the
  // corner at (bx - 0.5, by - 0.5) in pixel-centre coordinates.
  const int bx0 = std::max(half_x, static_cast<int>(std::ceil(cx - sx + 0.5)));
  const int bx1 = std::min(cols - half_x, static_cast<int>(std::floor(cx + sx + 0.5)));
  const int by0 = std::max(half_y, static_cast<int>(std::ceil(cy - sy + 0.5)));
  const int by1 = std::min(rows - half_y, static_cast<int>(std::floor(cy + sy + 0.5)));
  if (bx1 < bx0 || by1 < by0) return best;
  // Template levels per quadrant (qx, qy in {0: -side, 1: +side}): the face 0,
  // across the vertical edge -v, across the horizontal edge (and diagonally:
  // the horizontal edge usually continues as the surroundings' own boundary)
  // -h. Zero-mean, so the image mean drops out of the covariance.
  double level[2][2];
  const int fx = type.x_sign > 0 ? 1 : 0, fy = type.y_sign > 0 ? 1 : 0;
  level[fy][fx] = 0.0;
  level[fy][1 - fx] = -type.v_polarity;
  level[1 - fy][fx] = -type.h_polarity;
  level[1 - fy][1 - fx] = -type.h_polarity;
  double mean = 0.0;
  for (auto& row : level)
    for (double l : row) mean += 0.25 * l;
  double t_norm2 = 0.0;
  for (auto& row : level)
    for (double& l : row) {
      l -= mean;
      t_norm2 += l * l;
    }
  const double n = 4.0 * half_x * half_y;
  t_norm2 *= half_x * half_y;
  if (!(t_norm2 > 0.0)) return best;
  auto rect = [](const cv::Mat& s, int x0, int y0, int x1, int y1) {
    return s.at<double>(y1, x1) - s.at<double>(y0, x1) - s.at<double>(y1, x0) + s.at<double>(y0, x0);
  };
  const int nx = bx1 - bx0 + 1, ny = by1 - by0 + 1;
  std::vector<double> score(static_cast<size_t>(nx) * ny);
  int best_i = -1;
  for (int j = 0; j < ny; ++j) {
    const int by = by0 + j;
    const int ys[3] = {by - half_y, by, by + half_y};
    for (int i = 0; i < nx; ++i) {
      const int bx = bx0 + i;
      const int xs[3] = {bx - half_x, bx, bx + half_x};
      double s_all = 0.0, cov = 0.0;
      for (int qy = 0; qy < 2; ++qy)
        for (int qx = 0; qx < 2; ++qx) {
          const double s = rect(sum, xs[qx], ys[qy], xs[qx + 1], ys[qy + 1]);
          s_all += s;
          cov += level[qy][qx] * s;
        }
      const double var = rect(sqsum, xs[0], ys[0], xs[2], ys[2]) - s_all * s_all / n;
      // A flat patch (no variance: far below one grey level) correlates with nothing.
      const double c = var > 1e-6 * n ? cov / std::sqrt(t_norm2 * var) : 0.0;
      score[static_cast<size_t>(j) * nx + i] = c;
      if (best_i < 0 || c > score[best_i]) best_i = j * nx + i;
    }
  }
  const int bi = best_i % nx, bj = best_i / nx;
  // The runner-up: the best placement a template's size or more away.
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      if (std::abs(i - bi) >= half_x || std::abs(j - bj) >= half_y)
        best.second = std::max(best.second, score[static_cast<size_t>(j) * nx + i]);
  // Sub-pixel peak: a parabola through the neighbours in x and in y.
  auto parabola = [](double a, double b, double c) {
    const double den = a - 2.0 * b + c;
    return den < 0.0 ? std::clamp(0.5 * (a - c) / den, -0.5, 0.5) : 0.0;
  };
  double dx = 0.0, dy = 0.0;
  const double s0 = score[best_i];
  if (bi > 0 && bi < nx - 1) dx = parabola(score[best_i - 1], s0, score[best_i + 1]);
  if (bj > 0 && bj < ny - 1) dy = parabola(score[best_i - nx], s0, score[best_i + nx]);
  best.found = true;
  best.score = s0;
  best.x = bx0 + bi + dx - 0.5;
  best.y = by0 + bj + dy - 0.5;
  return best;
}

// ---------------------------------------------------------------------------
// The tracker.

namespace {

int ViewPad(const VertexOptions& o) { return o.max_half_px + o.max_search_warped_px + 2; }

}  // namespace

VertexTracker::VertexTracker(const Sensor& sensor, const VertexOptions& options)
    : sensor_(sensor),
      opt_((options.Check(), options)),
      view_(sensor, std::max(0.0, options.inner_radius_fraction * sensor.limb_radius()),
            sensor.limb_radius() + options.max_half_px + 4.0, ViewPad(options)) {}

void VertexTracker::BeginFrame(const cv::Mat& grey) { view_.PadFrame(grey, &padded_); }

CornerType VertexTracker::TypeOf(const PredictedLandmark& p) {
  CornerType t;
  t.x_sign = p.inside_azimuth_sign >= 0 ? 1 : -1;
  t.y_sign = p.inside_radius_sign >= 0 ? 1 : -1;
  t.v_polarity = p.v_polarity != 0 ? p.v_polarity : p.h_polarity;
  t.h_polarity = p.h_polarity != 0 ? p.h_polarity : p.v_polarity;
  return t;
}

std::vector<CornerType> VertexTracker::TypesOf(const PredictedLandmark& p) {
  const CornerType base = TypeOf(p);
  std::vector<CornerType> out;
  for (int v : p.v_polarity != 0 ? std::vector<int>{p.v_polarity} : std::vector<int>{1, -1})
    for (int h : p.h_polarity != 0 ? std::vector<int>{p.h_polarity} : std::vector<int>{1, -1}) {
      CornerType t = base;
      t.v_polarity = v;
      t.h_polarity = h;
      out.push_back(t);
    }
  return out;
}

namespace {

// The corner's azimuth, refined: the template's correlation peak is broad
// along x (and flat over the ramp of an edge blurred by the camera's turn,
// `ramp_cols` wide, where noise decides where it falls), while the step
// across the vertical edge locates it to a fraction of a pixel. The edge's
// position is the centre of its ramp by the step detector's area method in
// `half_y` rows of the face along the edge from the corner (median over the
// rows: the more rows, the less texture and noise matter), within the
// ramp's half-width and 2 columns of the template's peak; also the ramp's
// median width (columns, 15 % to 85 %). False when too few rows show the
// step there.
bool LocateVerticalEdge(const QuasiCylindricalView& view, const cv::Mat& padded, const CornerType& type,
                        double ramp_cols, int half_y, CornerPeak* peak, double* width_cols, double* contrast) {
  const int reach = static_cast<int>(std::ceil(ramp_cols)) + 12;  // the ramp, its tails, the plateaus
  const int x0 = static_cast<int>(std::floor(peak->x)) - reach, w = 2 * reach + 1;
  const int rows = std::max(3, half_y);
  const int y0 = type.y_sign > 0 ? static_cast<int>(std::ceil(peak->y)) + 2
                                 : static_cast<int>(std::floor(peak->y)) - 1 - rows;
  if (x0 < 0 || x0 + w > view.cols() || y0 < 0 || y0 + rows > view.rows()) return false;
  cv::Mat strip;
  view.WarpRegion(padded, x0, y0, w, rows, &strip);
  std::vector<double> xs, widths, strengths;
  for (int r = 0; r < rows; ++r) {
    StepEdge e;
    if (!FindStep(strip.ptr<float>(r), w, type.x_sign * type.v_polarity, 2, 8.0, &e, ramp_cols)) continue;
    if (std::abs(x0 + e.location - peak->x) > 0.5 * ramp_cols + 2.0) continue;  // another edge
    xs.push_back(x0 + e.location);
    widths.push_back(e.width);
    strengths.push_back(e.strength);
  }
  if (xs.size() < 3) return false;
  auto median = [](std::vector<double>* v) {
    std::nth_element(v->begin(), v->begin() + v->size() / 2, v->end());
    return (*v)[v->size() / 2];
  };
  peak->x = median(&xs);
  *width_cols = median(&widths);
  *contrast = median(&strengths);
  return true;
}

}  // namespace

LandmarkMeasurement VertexTracker::Measure(const PredictedLandmark& p, double search_px) const {
  LandmarkMeasurement m;
  if (padded_.empty()) {
    m.why = "no frame";
    return m;
  }
  const std::vector<CornerType> types = TypesOf(p);
  const double px_per_rad = view_.width() / (2.0 * M_PI);
  const double cx = view_.x_of_azimuth(p.azimuth), cy = view_.y_of_radius(p.corner_radius);
  // Search: the expected image motion, tangential px at the corner's radius
  // turned into view columns.
  const double s = std::max(search_px, opt_.min_search_px);
  const double sx = std::min(s * px_per_rad / std::max(p.corner_radius, 1.0),
                             static_cast<double>(opt_.max_search_warped_px));
  const double sy = s;
  // Template quadrants: as large as the predicted face allows.
  const double v_len = std::abs(p.v_radius - p.corner_radius);
  const double h_len = std::abs(WrapAngle(p.h_end_azimuth - p.azimuth)) * px_per_rad;
  auto half = [&](double len) {
    return std::clamp(static_cast<int>(std::floor(opt_.face_fraction * len)), opt_.min_half_px,
                      opt_.max_half_px);
  };
  const int hx = half(h_len), hy = half(v_len);
  // The window: every placement's quadrants, inside the view.
  const int bx0 = std::max(hx, static_cast<int>(std::ceil(cx - sx + 0.5)));
  const int bx1 = std::min(view_.cols() - hx, static_cast<int>(std::floor(cx + sx + 0.5)));
  const int by0 = std::max(hy, static_cast<int>(std::ceil(cy - sy + 0.5)));
  const int by1 = std::min(view_.rows() - hy, static_cast<int>(std::floor(cy + sy + 0.5)));
  if (bx1 < bx0 || by1 < by0) {
    m.why = "search window outside the view";
    return m;
  }
  const int x0 = bx0 - hx, y0 = by0 - hy;
  cv::Mat window, sum, sqsum;
  view_.WarpRegion(padded_, x0, y0, bx1 + hx - x0, by1 + hy - y0, &window);
  cv::integral(window, sum, sqsum, CV_64F, CV_64F);
  // With an edge of unknown polarity, every corner type is tried, the best
  // response first; the first that passes the checks below wins (its own
  // runner-up decides whether it is ambiguous: the other types respond to
  // parts of the same corner, such as its vertical edge alone).
  struct Candidate {
    CornerType type;
    CornerPeak peak;
  };
  std::vector<Candidate> candidates;
  for (const CornerType& t : types) {
    const CornerPeak found = FindCorner(sum, sqsum, t, hx, hy, cx - x0, cy - y0, sx, sy);
    if (found.found) candidates.push_back({t, found});
  }
  if (candidates.empty()) {
    m.why = "search window outside the view";
    return m;
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.peak.score > b.peak.score; });
  // Motion blur expected across the vertical edge, in view columns (2 px and
  // less the detector's own baseline spans).
  double ramp_cols = p.tangential_motion_px * px_per_rad / std::max(p.corner_radius, 1.0);
  if (ramp_cols < 2.0) ramp_cols = 0.0;
  double width_cols = 0.0, contrast = 0.0;
  const int edge_rows = std::clamp(static_cast<int>(0.7 * v_len), 3, 24);  // along the vertical edge
  CornerType type;
  CornerPeak peak;
  bool located = false;
  for (size_t k = 0; k < candidates.size() && !located; ++k) {
    type = candidates[k].type;
    peak = candidates[k].peak;
    peak.x += x0;
    peak.y += y0;
    const char* why = nullptr;
    if (peak.score < opt_.min_score)
      why = "weak corner response";
    else if (peak.score - peak.second < opt_.min_peak_margin)
      why = "ambiguous: another corner-like response in the search window";
    else if (!LocateVerticalEdge(view_, padded_, type, ramp_cols, edge_rows, &peak, &width_cols, &contrast))
      why = "vertical edge not located beside the corner";
    else
      located = true;
    if (k == 0) {  // what is reported when none passes
      m.weight = 1.0;
      m.azimuth = WrapAngle(view_.azimuth_of_x(peak.x));
      m.radius = view_.radius_of_y(peak.y);
      if (why) m.why = why;
    }
  }
  if (!located) return m;
  m.why = "";
  m.radius = view_.radius_of_y(peak.y);
  m.azimuth = WrapAngle(view_.azimuth_of_x(peak.x));
  m.edge_width_px = width_cols * p.corner_radius / px_per_rad;
  m.found = true;
  m.v_polarity = type.v_polarity;
  m.h_polarity = type.h_polarity;
  m.v_contrast = contrast;
  // For the debug video: the face quadrant's two sides from the corner.
  for (int k = 1; k <= hx; k += 2)
    m.edge_points.push_back(sensor_.from_polar(m.radius, view_.azimuth_of_x(peak.x + type.x_sign * k)));
  for (int k = 1; k <= hy; k += 2)
    m.edge_points.push_back(sensor_.from_polar(view_.radius_of_y(peak.y + type.y_sign * k), m.azimuth));
  return m;
}

}  // namespace pano

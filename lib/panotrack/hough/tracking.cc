#include "panotrack/hough/tracking.h"

#include <algorithm>
#include <limits>
#include <sstream>
#include <string>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/hough/peak_refine.h"

namespace pano {

namespace {

void CheckWindow(const TrackingWindow& w) {
  // The message is built only when thrown: this runs for every tracked edge.
  auto fail = [](const char* why) { throw Error(std::string("TrackHorizontalLine: window: ") + why); };
  const double vals[] = {w.r_main, w.theta_main, w.r_halfwidth, w.theta_halfwidth, w.r_bin,
                         w.theta_bin, w.max_abs_dtheta, w.inlier_r_bins, w.min_score};
  for (double v : vals)
    if (!std::isfinite(v)) fail("a parameter is not a finite number (NaN or infinity)");
  if (std::isnan(w.theta_min) || std::isnan(w.theta_max))
    fail("theta_min/theta_max: NaN (use infinity for no bound)");
  if (!(w.r_bin > 0.0) || !(w.theta_bin > 0.0))
    fail("r_bin/theta_bin: expected positive bin sizes (zero-size accumulator)");
  if (w.r_halfwidth < 0.0 || w.theta_halfwidth < 0.0)
    fail("r_halfwidth/theta_halfwidth: expected non-negative half-widths");
  if (!(w.theta_halfwidth < M_PI / 2)) fail("theta_halfwidth: expected less than pi/2");
  const double nr = 2.0 * std::ceil(w.r_halfwidth / w.r_bin) + 1.0;
  const double nt = 2.0 * std::ceil(w.theta_halfwidth / w.theta_bin) + 1.0;
  if (nr * nt > 1e6) fail("more than 1e6 accumulator bins");
}

// Per point: its table rows (PhTable::RowAt), looked up once per call.
struct PointRow {
  PhTable::MainRow row;
  bool ok = false;
};

// Robust Gauss-Newton on e_k = PH(R_k, T - theta_k) - R (Eqns 7-8), Tukey
// biweight of scale c. The derivative de/dT is the table's central difference.
bool RefineRobust(const PhTable& table, const TrackingVote* pts, const PointRow* rows, size_t n, double dt_cap,
                  double r_lo, double r_hi, double t_lo, double t_hi, double c,
                  int iterations, double tol_r, double* R, double* T, double* sig_r,
                  double* sig_t) {
  const double h = 0.5 * table.options().dtheta_step;
  double r = *R, t = *T;
  bool ok = false;
  // Annealed scale: c, c/2, ... down to c_final = c/3 (one r_bin by default).
  const double c_final = c / 3.0;
  for (int it = 0; it < iterations; ++it) {
    if (it > 0) c = std::max(c_final, 0.5 * c);
    double a11 = 0, a12 = 0, a22 = 0, b1 = 0, b2 = 0, se = 0;
    int used = 0;
    for (size_t k = 0; k < n; ++k) {
      const double dt = WrapAngle(t - pts[k].azimuth);
      if (!(std::abs(dt) + h < dt_cap)) continue;
      // A point needs PH at dt - h and dt + h only when its residual is
      // within the scale (it is skipped otherwise either way).
      double pm, pp, p0;
      const PhTable::MainRow& row = rows[k].row;
      if (!rows[k].ok || !table.MainOnRow(row, dt, &p0)) continue;
      const double e = p0 - r;
      if (!(std::abs(e) < c)) continue;
      if (!table.MainOnRow(row, dt - h, &pm) || !table.MainOnRow(row, dt + h, &pp)) continue;
      const double u = e / c;
      const double wk = pts[k].weight * (1 - u * u) * (1 - u * u);
      const double g = (pp - pm) / (2 * h);  // de/dT; de/dR = -1
      // J = [-1, g]: normal equations J^T W J d = -J^T W e.
      a11 += wk;
      a12 -= wk * g;
      a22 += wk * g * g;
      b1 += wk * e;
      b2 -= wk * g * e;
      se += wk * e * e;
      ++used;
    }
    if (used < 3 || !(a11 > 0)) return ok;
    const double det = a11 * a22 - a12 * a12;
    {
      // Covariance s^2 A^-1 at this iterate (kept from the last step).
      const double s2 = se / std::max(a11 * (used - 2.0) / used, 1e-300);
      const bool observable = det > 1e-12 * a11 * std::max(a22, 1e-300) && a22 > 0;
      *sig_r = observable ? std::sqrt(s2 * a22 / det) : std::sqrt(s2 / a11);
      *sig_t = observable ? std::sqrt(s2 * a11 / det) : std::numeric_limits<double>::infinity();
    }
    double dr, dtt;
    if (det > 1e-12 * a11 * std::max(a22, 1e-300) && a22 > 0) {
      dr = (a22 * b1 - a12 * b2) / det;
      dtt = (a11 * b2 - a12 * b1) / det;
    } else {
      dr = b1 / a11;  // theta not observable: R only
      dtt = 0;
    }
    // Projected onto the window (theta relative to the start value).
    r = std::clamp(r + dr, r_lo, r_hi);
    t = std::clamp(t + dtt, t_lo, t_hi);
    ok = true;
    if (c <= c_final && std::abs(dr) < tol_r && std::abs(dtt) < 1e-6) break;
  }
  *R = r;
  *T = t;
  return ok;
}

void CheckVotes(const TrackingVote* points, size_t n_points) {
  if (n_points > 0 && points == nullptr) throw Error("TrackHorizontalLine: null point array");
  for (size_t i = 0; i < n_points; ++i) {
    const TrackingVote& p = points[i];
    if (!std::isfinite(p.radius) || !std::isfinite(p.azimuth) || !std::isfinite(p.weight) || p.weight < 0.0)
      throw Error("TrackHorizontalLine: point " + std::to_string(i) +
                  ": expected finite radius/azimuth and a finite non-negative weight");
  }
}

// The window's accumulator: nt theta columns by nr R bins, bin (c, i)
// centred on (t_lo + c theta_bin, r_lo + i r_bin); the columns
// theta_min..theta_max allow (a counter-clockwise arc).
struct WindowGrid {
  int nr = 0, nt = 0;
  double r_lo = 0.0, t_lo = 0.0, inv_r_bin = 1.0;
  double dt_cap = 0.0;  // |dtheta| voted: the window's and the table's limit
  std::vector<unsigned char>* col_ok = nullptr;
};

WindowGrid GridOf(const PhTable& table, const TrackingWindow& w) {
  WindowGrid g;
  const int hr = static_cast<int>(std::ceil(w.r_halfwidth / w.r_bin));
  const int ht = static_cast<int>(std::ceil(w.theta_halfwidth / w.theta_bin));
  g.nr = 2 * hr + 1;
  g.nt = 2 * ht + 1;
  g.r_lo = w.r_main - hr * w.r_bin;          // centre of R bin 0
  g.t_lo = w.theta_main - ht * w.theta_bin;  // centre of theta bin 0
  g.inv_r_bin = 1.0 / w.r_bin;
  g.dt_cap = std::min(w.max_abs_dtheta, table.dtheta_max());
  thread_local std::vector<unsigned char> col_ok;
  col_ok.assign(g.nt, 1);
  if (std::isfinite(w.theta_min) && std::isfinite(w.theta_max)) {
    const double span = WrapAnglePositive(w.theta_max - w.theta_min);
    for (int c = 0; c < g.nt; ++c) {
      const double off = WrapAnglePositive(g.t_lo + c * w.theta_bin - w.theta_min);
      col_ok[c] = off > 0.0 && off < span;
    }
  }
  g.col_ok = &col_ok;
  return g;
}

// The cells a call voted into, cleared on every way out: the accumulator
// [theta][R] stays all zero between calls.
struct VotedBox {
  float* acc;
  int nr;
  int c_min, c_max, x_min, x_max;
  ~VotedBox() {
    for (int c = c_min; c <= c_max; ++c)
      std::fill(acc + static_cast<size_t>(c) * nr + x_min, acc + static_cast<size_t>(c) * nr + x_max + 1, 0.0f);
  }
};

// Each point votes along its curve (Eqns 7-8) into the window, R
// interpolated between two bins; returns the weight of the points that
// voted (res->n_votes of them).
double VoteInWindow(const PhTable& table, const TrackingWindow& w, const WindowGrid& g, const TrackingVote* points,
                    size_t n_points, float* acc, PointRow* rows, VotedBox* box, TrackingResult* res) {
  const std::vector<unsigned char>& col_ok = *g.col_ok;
  const int nr = g.nr, nt = g.nt;
  const double nr_bins = nr;
  double total_weight = 0.0;
  for (size_t i = 0; i < n_points; ++i) {
    const TrackingVote& p = points[i];
    PointRow& pr = rows[i];
    pr.ok = table.RowAt(p.radius, &pr.row);  // Eqn 7 along R_i
    if (!pr.ok) continue;
    const float wt = static_cast<float>(p.weight);
    const double dt0 = WrapAngle(g.t_lo - p.azimuth);  // dtheta of column 0 (Eqn 8)
    int c_first = -1, c_last = -1, i_lo = nr, i_hi = -1;
    for (int c = 0; c < nt; ++c) {
      const double dt = dt0 + c * w.theta_bin;
      if (!col_ok[c] || !(std::abs(dt) < g.dt_cap)) continue;
      double rm;
      if (!table.MainOnRow(pr.row, dt, &rm)) continue;  // Eqn 7
      const double x = (rm - g.r_lo) * g.inv_r_bin;
      if (!(x > -1.0) || !(x < nr_bins)) continue;
      const int i0 = x >= 0.0 ? static_cast<int>(x) : -1;  // floor(x) on (-1, nr)
      const float f = static_cast<float>(x - i0);
      float* row = &acc[static_cast<size_t>(c) * nr];
      if (i0 >= 0) row[i0] += wt * (1.0f - f);
      if (i0 + 1 < nr) row[i0 + 1] += wt * f;
      i_lo = std::min(i_lo, i0);
      i_hi = std::max(i_hi, i0);
      if (c_first < 0) c_first = c;
      c_last = c;
    }
    if (c_last >= 0) {
      box->c_min = std::min(box->c_min, c_first);
      box->c_max = std::max(box->c_max, c_last);
      box->x_min = std::min(box->x_min, std::max(i_lo, 0));
      box->x_max = std::max(box->x_max, std::min(i_hi + 1, nr - 1));
      ++res->n_votes;
      total_weight += p.weight;
    }
  }
  return total_weight;
}

// Cells beyond the voted box (smoothed: one cell more) are zero, and the
// peak, if positive, lies inside: smoothing and searching the box gives the
// whole window's result.
PeakFit PeakInBox(const TrackingWindow& w, const WindowGrid& g, float* acc, const VotedBox& box) {
  const int nr = g.nr, nt = g.nt;
  if (!w.smooth)
    return FindAndRefinePeakInBlock(&acc[static_cast<size_t>(box.c_min) * nr + box.x_min], box.c_max - box.c_min + 1,
                                    box.x_max - box.x_min + 1, nr, box.c_min, box.x_min, nt, nr);
  thread_local std::vector<float> smooth, rows_pass;
  const int y0 = std::max(box.c_min - 1, 0), y1 = std::min(box.c_max + 1, nt - 1);
  const int x0 = std::max(box.x_min - 1, 0), x1 = std::min(box.x_max + 1, nr - 1);
  const int by = y1 - y0 + 1, bx = x1 - x0 + 1;
  smooth.resize(static_cast<size_t>(by) * bx);
  rows_pass.resize(smooth.size());
  SmoothBinomial3x3Separable(&acc[static_cast<size_t>(y0) * nr + x0], by, bx, nr, rows_pass.data(), smooth.data());
  return FindAndRefinePeakInBlock(smooth.data(), by, bx, bx, y0, x0, nt, nr);
}

// The peak refined on the points themselves (RefineRobust), within the
// window and the columns theta_min..theta_max allow.
void RefinePeak(const PhTable& table, const TrackingWindow& w, const WindowGrid& g, const TrackingVote* points,
                const PointRow* rows, size_t n_points, TrackingResult* res) {
  const std::vector<unsigned char>& col_ok = *g.col_ok;
  const int nt = g.nt;
  double R = res->r_main, T = res->theta_main;
  double sr = 0, st = 0;
  // theta unwrapped next to the window's prediction.
  T = w.theta_main + WrapAngle(T - w.theta_main);
  int c_first = 0, c_last = nt - 1;
  while (c_first < nt - 1 && !col_ok[c_first]) ++c_first;
  while (c_last > 0 && !col_ok[c_last]) --c_last;
  if (c_last < c_first) c_last = c_first;
  if (RefineRobust(table, points, rows, n_points, g.dt_cap, g.r_lo - 0.5 * w.r_bin, g.r_lo + (g.nr - 0.5) * w.r_bin,
                   g.t_lo + (c_first - 0.5) * w.theta_bin, g.t_lo + (c_last + 0.5) * w.theta_bin,
                   w.refine_scale_bins * w.r_bin, w.refine_iterations, 1e-3 * w.r_bin, &R, &T, &sr, &st)) {
    res->r_main = R;
    res->theta_main = WrapAngle(T);
    res->r_sigma = sr;
    res->theta_sigma = st;
  }
}

// The inliers' weight at the refined peak (res->n_inliers of them).
double InlierWeight(const PhTable& table, const TrackingWindow& w, const WindowGrid& g, const TrackingVote* points,
                    const PointRow* rows, size_t n_points, TrackingResult* res) {
  double inlier_w = 0.0;
  const double tol = w.inlier_r_bins * w.r_bin;
  for (size_t i = 0; i < n_points; ++i) {
    const TrackingVote& p = points[i];
    const double dt = WrapAngle(res->theta_main - p.azimuth);
    double rm;
    if (!(std::abs(dt) < g.dt_cap) || !rows[i].ok || !table.MainOnRow(rows[i].row, dt, &rm)) continue;
    if (std::abs(rm - res->r_main) <= tol) {
      inlier_w += p.weight;
      ++res->n_inliers;
    }
  }
  return inlier_w;
}

}  // namespace

TrackingResult TrackHorizontalLine(const PhTable& table, const TrackingWindow& w,
                                   const TrackingVote* points, size_t n_points) {
  if (table.empty()) throw Error("TrackHorizontalLine: empty Panoramic Hough table");
  CheckWindow(w);
  CheckVotes(points, n_points);
  const WindowGrid g = GridOf(table, w);
  thread_local std::vector<float> acc;
  const size_t n_cells = static_cast<size_t>(g.nt) * g.nr;
  if (acc.size() < n_cells) acc.resize(n_cells, 0.0f);
  VotedBox box{acc.data(), g.nr, g.nt, -1, g.nr, -1};
  thread_local std::vector<PointRow> rows;
  rows.resize(n_points);
  TrackingResult res;
  const double total_weight = VoteInWindow(table, w, g, points, n_points, acc.data(), rows.data(), &box, &res);
  if (res.n_votes == 0 || !(total_weight > 0.0)) return res;
  const PeakFit fit = PeakInBox(w, g, acc.data(), box);
  if (!(fit.value > 0.0f)) return res;
  res.peak = fit.value;
  res.at_border = fit.at_border;
  res.r_main = g.r_lo + fit.x * w.r_bin;
  res.theta_main = WrapAngle(g.t_lo + fit.y * w.theta_bin);
  if (w.refine_iterations > 0) RefinePeak(table, w, g, points, rows.data(), n_points, &res);
  // Score: inlier weight fraction at the refined peak.
  res.score = InlierWeight(table, w, g, points, rows.data(), n_points, &res) / total_weight;
  res.found = res.score >= w.min_score;
  return res;
}

}  // namespace pano

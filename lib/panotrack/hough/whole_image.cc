#include "panotrack/hough/whole_image.h"

#include <omp.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include "panotrack/core/angles.h"
#include "panotrack/core/cpu_features.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/hough/gradient_bin.h"
#include "panotrack/hough/peak_refine.h"

namespace pano {

namespace {

constexpr int32_t kInvalid = -1;
constexpr int kPhiBins = detail::kGradientAngleBins;  // gradient angle to the radial, 1 degree bins
// Byte order, for the mask scan's bit arithmetic (big-endian machines take
// the bytes of a word one by one).
constexpr bool kLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

std::string Num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

void WholeImageOptions::Check(const std::string& what) const {
  if (heights.empty()) throw Error(what + ": heights: expected at least one Z plane");
  for (double z : heights)
    if (!std::isfinite(z)) throw Error(what + ": heights: not a finite number (NaN or infinity)");
  const double vals[] = {r_bin, theta_bin, dtheta_max, r_row_step, orientation_tolerance, r_min,
                         r_max, vertical_tolerance, distance_min, distance_max, explain_tolerance};
  for (double v : vals)
    if (!std::isfinite(v)) throw Error(what + ": a parameter is not a finite number (NaN or infinity)");
  if (!(r_bin > 0.0) || !(theta_bin > 0.0))
    throw Error(what + ": r_bin/theta_bin: expected positive bin sizes (zero-size accumulator)");
  if (theta_bin > M_PI) throw Error(what + ": theta_bin: expected at most pi");
  if (!(dtheta_max > 0.0) || !(dtheta_max < 89.0 * M_PI / 180))
    throw Error(what + ": dtheta_max: expected 0 < dtheta_max < 89 degrees, got " + Num(dtheta_max));
  if (sub_steps < 1 || sub_steps > 64) throw Error(what + ": sub_steps: expected 1..64");
  if (!(r_row_step > 0.0)) throw Error(what + ": r_row_step: expected a positive step in px");
  if (r_min < 0.0 || r_max < 0.0 || (r_max > 0.0 && r_max <= r_min))
    throw Error(what + ": r_min/r_max: expected 0 <= r_min < r_max (r_max 0: the limb)");
  if (!(orientation_tolerance > 0.0) || !(vertical_tolerance > 0.0))
    throw Error(what + ": orientation tolerances: expected positive angles");
  if (distance_min < 0.0 || distance_max < 0.0 || (distance_max > 0.0 && distance_max <= distance_min))
    throw Error(what + ": distance_min/distance_max: expected 0 <= min < max (0: the table's range)");
  if (!(explain_tolerance > 0.0)) throw Error(what + ": explain_tolerance: expected a positive value");
  if (min_votes < 1 || vertical_min_votes < 1)
    throw Error(what + ": min_votes: expected at least 1");
  if (nms_r < 0 || nms_theta < 0 || vertical_nms < 0 || max_peaks < 0)
    throw Error(what + ": nms/max_peaks: expected non-negative values");
  CheckThreadCount(num_threads, what + ": num_threads");
}

void PhWholeImage::SetGeometry(const Sensor& sensor, const WholeImageOptions& options) {
  const std::string what = "Panoramic Hough whole-image";
  options_ = options;
  cx_ = sensor.params.cx;
  cy_ = sensor.params.cy;
  aspect_ = sensor.params.aspect;
  const double limb = sensor.limb_radius();
  r_max_ = options.r_max > 0.0 ? std::min(options.r_max, limb) : limb - 3.0;
  r_min_ = options.r_min;
  if (!(r_max_ > r_min_)) throw Error(what + ": r_min: expected less than the limb radius");
  n_theta_ = static_cast<int>(std::lround(2.0 * M_PI / options.theta_bin));
  if (n_theta_ < 2 || n_theta_ > 20000)
    throw Error(what + ": theta_bin: expected 2 to 20000 bins over the circle");
  theta_bin_ = 2.0 * M_PI / n_theta_;
  n_r_ = static_cast<int>(std::ceil(r_max_ / options.r_bin));
  if (n_r_ < 1 || n_r_ > 20000) throw Error(what + ": r_bin: expected 1 to 20000 radius bins");
  if (static_cast<double>(n_r_) * n_theta_ * options.heights.size() > 2e8)
    throw Error(what + ": more than 2e8 accumulator bins");
  sub_steps_ = options.sub_steps;
  half_width_ = static_cast<int>(std::ceil(options.dtheta_max / theta_bin_));
  width_ = 2 * half_width_ + 1;
  n_rows_ = static_cast<int>(std::floor(r_max_ / options.r_row_step)) + 2;
  // Runs that pass 2 pi wrap to row 0 (voters split them): no padding rows.
  n_rows_padded_ = n_theta_;
  if (width_ > n_theta_) throw Error(what + ": theta_bin: too coarse for dtheta_max");
  int_plane_size_ = static_cast<size_t>(n_rows_) * sub_steps_ * width_;
  if (int_plane_size_ * options.heights.size() > 1e8 ||
      int_plane_size_ > static_cast<size_t>(std::numeric_limits<int32_t>::max()))
    throw Error(what + ": integer table too large; use a larger r_row_step or theta_bin");
}

PhWholeImage::PolarPixel PhWholeImage::Polar(int u, int v) const {
  const double du = u - cx_, dv = (v - cy_) / aspect_;
  const double r = std::sqrt(du * du + dv * dv);
  const double t = WrapAnglePositive(std::atan2(dv, du));
  return {static_cast<float>(r), static_cast<float>(t), static_cast<float>(r > 0 ? du / r : 1.0),
          static_cast<float>(r > 0 ? dv / r : 0.0)};
}

void PhWholeImage::FillPolarTable(const Sensor& sensor) {
  // The annulus's bounding box (one pixel of margin), within the image.
  const double half_u = r_max_ + 1.0, half_v = (r_max_ + 1.0) * aspect_;
  az_u0_ = std::clamp(static_cast<int>(std::floor(cx_ - half_u)), 0, sensor.image_width);
  az_v0_ = std::clamp(static_cast<int>(std::floor(cy_ - half_v)), 0, sensor.image_height);
  az_cols_ = std::clamp(static_cast<int>(std::ceil(cx_ + half_u)) + 1, az_u0_, sensor.image_width) - az_u0_;
  az_rows_ = std::clamp(static_cast<int>(std::ceil(cy_ + half_v)) + 1, az_v0_, sensor.image_height) - az_v0_;
  polar_.resize(static_cast<size_t>(az_cols_) * az_rows_);
  // Arithmetic only (nothing throws).
#pragma omp parallel for schedule(static) num_threads(ThreadCount(options_.num_threads))
  for (int y = 0; y < az_rows_; ++y)
    for (int x = 0; x < az_cols_; ++x) polar_[static_cast<size_t>(y) * az_cols_ + x] = Polar(az_u0_ + x, az_v0_ + y);
}

void PhWholeImage::FillIntegerPlane(const PhTable& ph, double d_min, double d_max, int32_t* tab,
                                    std::vector<unsigned char>* valid, std::vector<float>* psi) const {
  const int S = sub_steps_, W = width_, M = half_width_, NR = n_rows_;
  const double q = options_.r_row_step, scale = 256.0 / options_.r_bin;
  const double r_lim = n_r_ * options_.r_bin;
  valid->assign(static_cast<size_t>(NR) * W, 0);
  psi->assign(static_cast<size_t>(NR) * W, std::numeric_limits<float>::quiet_NaN());
  // The rows only evaluate the PH table (nothing throws).
#pragma omp parallel for schedule(static) num_threads(ThreadCount(options_.num_threads))
  for (int i = 0; i < NR; ++i) {
    const double R = i * q;
    double D_row = 0.0;
    const bool row_ok = ph.SliceDistance(R, &D_row) && D_row >= d_min && D_row <= d_max;
    for (int m = -M; m <= M; ++m) {
      bool all = row_ok;
      for (int s = 0; s < S; ++s) {
        const double dt = (m - double(s) / S) * theta_bin_;
        double v;
        int32_t iv = kInvalid;
        if (row_ok && std::abs(dt) <= options_.dtheta_max + theta_bin_ && D_row * std::cos(dt) >= d_min &&
            ph.Main(R, dt, &v) && v >= 0.0 && v < r_lim)
          iv = static_cast<int32_t>(std::lround(v * scale));  // Eqn 7, 1/256 bin
        else
          all = false;
        tab[(static_cast<size_t>(i) * S + s) * W + (m + M)] = iv;
      }
      (*valid)[static_cast<size_t>(i) * W + m + M] = all;
      // Curve normal angle to the radial at (R, dtheta): psi = atan(PH_dt / (R PH_R)).
      const double dt = m * theta_bin_, hr = 0.25, ht = 0.25 * M_PI / 180;
      double a, b, c, d;
      if (all && ph.Main(R + hr, dt, &a) && ph.Main(R - hr, dt, &b) && ph.Main(R, dt + ht, &c) &&
          ph.Main(R, dt - ht, &d) && R > 0.0) {
        const double ph_r = (a - b) / (2 * hr), ph_t = (c - d) / (2 * ht);
        (*psi)[static_cast<size_t>(i) * W + m + M] = static_cast<float>(std::atan2(ph_t, R * ph_r));
      }
    }
  }
}

void PhWholeImage::FillOrientationRanges(const std::vector<unsigned char>& valid,
                                         const std::vector<float>& psi, size_t plane) {
  const int W = width_, M = half_width_, NR = n_rows_;
  // Ranges of m per (row pair r0, r0+1) and gradient angle bin.
  const size_t P = options_.heights.size();
  const double tol = options_.orientation_tolerance + 0.5 * M_PI / 180;
  // Arithmetic on the tables only (nothing throws).
#pragma omp parallel for schedule(static) num_threads(ThreadCount(options_.num_threads))
  for (int i = 0; i < NR - 1; ++i) {
    auto ok = [&](int m) {
      return valid[static_cast<size_t>(i) * W + m + M] && valid[static_cast<size_t>(i + 1) * W + m + M];
    };
    if (!ok(0)) continue;
    int v_lo = 0, v_hi = 0;
    while (v_lo - 1 >= -M && ok(v_lo - 1)) --v_lo;
    while (v_hi + 1 <= M && ok(v_hi + 1)) ++v_hi;
    const float* ps = &psi[static_cast<size_t>(i) * W + M];
    for (int f = 0; f < kPhiBins; ++f) {
      const double phi = (f + 0.5 - 90.0) * M_PI / 180;
      int lo = 1, hi = 0;
      for (int m = v_lo; m <= v_hi; ++m) {
        const double d = std::remainder(ps[m] - phi, M_PI);  // NaN never matches
        if (std::abs(d) <= tol) {
          if (lo > hi) lo = m;
          hi = m;
        }
      }
      VoteRange& range = ranges_[(static_cast<size_t>(i) * kPhiBins + f) * P + plane];
      range.lo = static_cast<int16_t>(lo);
      range.hi = static_cast<int16_t>(hi);
    }
  }
}

void PhWholeImage::VotedBins(const int32_t* tab, int* j0, int* cols) const {
  // A vote interpolates two entries a, b >= 0 of the table (1/256 bin):
  // a (256 - t) + b t lies between 256 min(a, b) and 256 max(a, b), so its
  // bin (>> 16, then at most n_r) between min(a, b) >> 8 and max(a, b) >> 8.
  int lo = n_r_, hi = 0;
  for (size_t i = 0; i < int_plane_size_; ++i)
    if (tab[i] >= 0) {
      lo = std::min(lo, tab[i] >> 8);
      hi = std::max(hi, tab[i] >> 8);
    }
  hi = std::min(hi, n_r_);
  if (lo > hi) lo = hi = 0;  // a plane without votes: one column
  *j0 = lo;
  *cols = hi - lo + 1;
}

PhWholeImage::AccumulatorLayout PhWholeImage::AccumulatorLayout::Make(int n_theta, const std::vector<int>& j0,
                                                                      const std::vector<int>& cols) {
  AccumulatorLayout l;
  l.j0 = j0;
  l.cols = cols;
  for (int c : cols) {
    l.offset.push_back(l.size);
    l.size += static_cast<size_t>(n_theta) * c;
  }
  return l;
}

void PhWholeImage::FillCurveTable(Plane* plane) const {
  const int S = sub_steps_, W = width_, M = half_width_, NR = n_rows_;
  const double q = options_.r_row_step;
  // PH^-1 table for the explain-away step.
  plane->curve.assign(int_plane_size_, std::numeric_limits<float>::quiet_NaN());
  const PhTable& ph = plane->table;
  // The rows only evaluate the PH table (nothing throws).
#pragma omp parallel for schedule(static) num_threads(ThreadCount(options_.num_threads))
  for (int i = 0; i < NR; ++i)
    for (int s2 = 0; s2 < S; ++s2)
      for (int m = -M; m <= M; ++m) {
        double r;
        if (ph.Curve(i * q, (m - double(s2) / S) * theta_bin_, &r))
          plane->curve[(static_cast<size_t>(i) * S + s2) * W + m + M] = static_cast<float>(r);
      }
}

PhWholeImage PhWholeImage::Build(const RadiusTable& table, const WholeImageOptions& options) {
  const std::string what = "Panoramic Hough whole-image";
  options.Check(what);
  if (table.empty()) throw Error(what + ": the E(D,Z) lookup table is empty");
  PhWholeImage w;
  w.SetGeometry(table.sensor(), options);
  w.FillPolarTable(table.sensor());
  w.int_table_.assign(w.int_plane_size_ * options.heights.size(), kInvalid);
  w.ranges_.assign(static_cast<size_t>(w.n_rows_) * kPhiBins * options.heights.size(), VoteRange{1, 0});
  PhTableOptions po;
  po.dtheta_max = std::min(89.0 * M_PI / 180, options.dtheta_max + 2.0 * w.theta_bin_);
  const double d_min = options.distance_min > 0.0 ? options.distance_min : table.ranges().d_min;
  const double d_max = options.distance_max > 0.0 ? options.distance_max : table.ranges().d_max;
  std::vector<unsigned char> valid;  // [row][m + M]: every sub step defined
  std::vector<float> psi;            // [row][m + M]: curve normal to the radial
  const size_t P = options.heights.size();
  std::vector<int> full_j0(P, 0), full_cols(P, w.n_r_ + 1), band_j0(P), band_cols(P);
  for (size_t p = 0; p < P; ++p) {
    Plane plane;
    plane.table = PhTable::Build(table, options.heights[p], po);
    w.FillIntegerPlane(plane.table, d_min, d_max, &w.int_table_[p * w.int_plane_size_], &valid, &psi);
    w.FillOrientationRanges(valid, psi, p);
    w.FillCurveTable(&plane);
    w.planes_.push_back(std::move(plane));
    w.VotedBins(&w.int_table_[p * w.int_plane_size_], &band_j0[p], &band_cols[p]);
  }
  w.padded_layout_ = AccumulatorLayout::Make(w.n_theta_, full_j0, full_cols);
  w.compact_layout_ = AccumulatorLayout::Make(w.n_theta_, band_j0, band_cols);
  return w;
}

EdgeMap ComputeEdgeMap(const cv::Mat& image, const EdgeOptions& options) {
  if (image.empty()) throw Error("ComputeEdgeMap: empty image");
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw Error("ComputeEdgeMap: expected an 8-bit grey or BGR image");
  if (!std::isfinite(options.low_threshold) || !std::isfinite(options.high_threshold) ||
      options.low_threshold < 0 || options.high_threshold < options.low_threshold)
    throw Error("ComputeEdgeMap: thresholds: expected 0 <= low <= high");
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  if (options.blur) cv::blur(grey, grey, cv::Size(3, 3));
  EdgeMap e;
  cv::Sobel(grey, e.dx, CV_16S, 1, 0, 3);
  cv::Sobel(grey, e.dy, CV_16S, 0, 1, 3);
  cv::Canny(e.dx, e.dy, e.mask, options.low_threshold, options.high_threshold, true);
  return e;
}

void PhWholeImage::CheckEdgeMap(const EdgeMap& edges) const {
  const std::string what = "Panoramic Hough whole-image";
  if (empty()) throw Error(what + ": transform not built");
  if (edges.mask.empty()) throw Error(what + ": empty edge map");
  if (edges.mask.type() != CV_8UC1 || edges.dx.type() != CV_16SC1 || edges.dy.type() != CV_16SC1)
    throw Error(what + ": edge map: expected mask CV_8UC1 and dx, dy CV_16SC1");
  if (edges.dx.size() != edges.mask.size() || edges.dy.size() != edges.mask.size())
    throw Error(what + ": edge map: mask, dx and dy differ in size");
  if (edges.mask.rows > 32767 || edges.mask.cols > 32767) throw Error(what + ": edge map too large");
}

void PhWholeImage::ResetResult(WholeImageResult* res) const {
  res->n_planes = static_cast<int>(planes_.size());
  res->n_theta = n_theta_;
  res->n_r = n_r_;
  res->vertical_histogram.assign(n_theta_, 0);
  res->vertical_peaks.clear();
  res->peaks.clear();
  res->n_edge_pixels = 0;
  res->n_votes = 0;
  res->voter_radius.clear();
  res->voter_azimuth.clear();
  res->vertical_r_min.assign(n_theta_, std::numeric_limits<float>::infinity());
  res->vertical_r_max.assign(n_theta_, 0.0f);
}

// An edge pixel in image polar coordinates (aspect-corrected), its gradient
// in (du, dv), and the per-run constants its votes need.
struct PhWholeImage::EdgePixel {
  double R, theta, cr, sr;  // radius, azimuth in [0, 2 pi), cos and sin of it
  double gx, gy, gn;        // gradient and its norm
};
struct PhWholeImage::VoteScales {
  double inv_q, inv_tb, cos_vert;  // 1 / r_row_step, 1 / theta_bin, vertical gradient limit
  const detail::GradientBinEdges* bin_edges;
};

void PhWholeImage::AddVertical(const EdgePixel& e, double g_rad, const VoteScales& k,
                               WholeImageResult* res) const {
  if (std::abs(g_rad) > k.cos_vert * e.gn) return;  // not a tangential gradient: no radial (vertical) edge
  int kb = static_cast<int>(e.theta * k.inv_tb);
  if (kb >= n_theta_) kb = n_theta_ - 1;
  ++res->vertical_histogram[kb];
  res->vertical_r_min[kb] = std::min(res->vertical_r_min[kb], static_cast<float>(e.R));
  res->vertical_r_max[kb] = std::max(res->vertical_r_max[kb], static_cast<float>(e.R));
}

bool PhWholeImage::LocateVotes(const EdgePixel& e, int fb, const VoteScales& k, PixelVotes* out) const {
  const int S = sub_steps_, W = width_, M = half_width_;
  const double fr = e.R * k.inv_q;
  int r0 = static_cast<int>(fr);
  int t8 = detail::RoundNonNegative((fr - r0) * 256.0);
  if (t8 == 256) {
    ++r0;
    t8 = 0;
  }
  if (r0 + 1 >= n_rows_) return false;
  const double x = e.theta * k.inv_tb - 0.5;
  int fl = detail::FloorToInt(x);
  int s = detail::RoundNonNegative((x - fl) * S);
  if (s == S) {
    ++fl;
    s = 0;
  }
  out->radius = static_cast<float>(e.R);
  out->azimuth = static_cast<float>(e.theta);
  out->ranges = (static_cast<size_t>(r0) * kPhiBins + fb) * planes_.size();
  out->offset = static_cast<int32_t>((static_cast<size_t>(r0) * S + s) * W + M);
  out->fl = fl;
  out->t8 = static_cast<uint16_t>(t8);
  return true;
}

bool PhWholeImage::AddRecords(const PixelVotes& pv, std::vector<PhVoteRecord>* records,
                              WholeImageResult* res) const {
  bool voted = false;
  const size_t P = planes_.size();
  const VoteRange* ranges = &ranges_[pv.ranges];
  for (size_t p = 0; p < P; ++p) {
    const int lo = ranges[p].lo, hi = ranges[p].hi;
    if (lo > hi) continue;
    PhVoteRecord rec;
    rec.offset = pv.offset + lo;
    int kt = pv.fl + lo;  // -M - 1 <= kt <= n_theta + M, and M < n_theta: one wrap at most
    if (kt < 0) kt += n_theta_;
    if (kt >= n_theta_) kt -= n_theta_;
    rec.k_start = static_cast<int16_t>(kt);
    rec.count = static_cast<int16_t>(hi - lo + 1);
    rec.t = pv.t8;
    rec.plane = static_cast<uint16_t>(p);
    records->push_back(rec);
    res->n_votes += rec.count;
    voted = true;
  }
  return voted;
}

bool PhWholeImage::AddEdgePixel(const EdgePixel& e, const VoteScales& k, PixelVotes* pv,
                                WholeImageResult* res) const {
  ++res->n_edge_pixels;
  // Gradient angle to the radial, modulo pi, in [-pi/2, pi/2).
  const double g_rad = e.gx * e.cr + e.gy * e.sr, g_tan = -e.gx * e.sr + e.gy * e.cr;
  AddVertical(e, g_rad, k, res);
  return LocateVotes(e, detail::GradientAngleBin(g_tan, g_rad, *k.bin_edges), k, pv);
}

void PhWholeImage::Prepare(const EdgeMap& edges, std::vector<PhVoteRecord>* records,
                           WholeImageResult* result) const {
  CheckEdgeMap(edges);
  ResetResult(result);
  records->clear();
  static const detail::GradientBinEdges bin_edges;
  const VoteScales k{1.0 / options_.r_row_step, 1.0 / theta_bin_,
                     std::cos(M_PI / 2 - options_.vertical_tolerance), &bin_edges};
  // The sparse edge list first (raster order), then the pixels' work: the
  // mask scan stays a tight loop, and the gradients of the pixels ahead can
  // be fetched while one pixel is processed.
  thread_local std::vector<uint32_t> list;  // v << 16 | u (CheckEdgeMap: both < 2^15)
  list.clear();
  const int cols = edges.mask.cols;
  constexpr uint64_t kLow7 = 0x7F7F7F7F7F7F7F7FULL, kHigh = 0x8080808080808080ULL;
  for (int v = 0; v < edges.mask.rows; ++v) {
    const double dv = (v - cy_) / aspect_;
    // Only the columns that can lie inside the annulus's outer circle (one
    // pixel of margin; the exact radius test follows).
    if (std::abs(dv) > r_max_ + 1.0) continue;
    const double half = std::sqrt(std::max(0.0, (r_max_ + 1.0) * (r_max_ + 1.0) - dv * dv));
    const int u_begin = std::clamp(static_cast<int>(std::floor(cx_ - half)), 0, cols);
    const int u_end = std::clamp(static_cast<int>(std::ceil(cx_ + half)) + 1, u_begin, cols);
    const uint8_t* mrow = edges.mask.ptr<uint8_t>(v);
    const uint32_t row_key = static_cast<uint32_t>(v) << 16;
    // Edge pixels are sparse (about 1 %): eight mask bytes at a time, the
    // non-zero bytes of a word found by bit arithmetic, in order.
    int u = u_begin;
    for (; u + 8 <= u_end; u += 8) {
      uint64_t word;
      std::memcpy(&word, mrow + u, sizeof(word));
      if (word == 0) continue;
      uint64_t nonzero = (((word & kLow7) + kLow7) | word) & kHigh;  // top bit of each non-zero byte
      if (!kLittleEndian) {
        for (int b = 0; b < 8; ++b)
          if (mrow[u + b]) list.push_back(row_key | static_cast<uint32_t>(u + b));
        continue;
      }
      while (nonzero) {
        list.push_back(row_key | static_cast<uint32_t>(u + (__builtin_ctzll(nonzero) >> 3)));
        nonzero &= nonzero - 1;
      }
    }
    for (; u < u_end; ++u)
      if (mrow[u]) list.push_back(row_key | static_cast<uint32_t>(u));
  }
  constexpr size_t kAhead = 8;
  thread_local std::vector<PixelVotes> located;
  located.resize(list.size());  // filled in place (no copy of each pixel's values)
  size_t n_located = 0;
  for (size_t i = 0; i < list.size(); ++i) {
    if (i + kAhead < list.size()) {
      const int va = static_cast<int>(list[i + kAhead] >> 16), ua = static_cast<int>(list[i + kAhead] & 0xFFFF);
      __builtin_prefetch(edges.dx.ptr<int16_t>(va) + ua);
      __builtin_prefetch(edges.dy.ptr<int16_t>(va) + ua);
      if (InPolarTable(ua, va)) __builtin_prefetch(&polar_[PolarIndex(ua, va)]);
    }
    const int v = static_cast<int>(list[i] >> 16), u = static_cast<int>(list[i] & 0xFFFF);
    // Polar coordinates in single precision (voter_radius / voter_azimuth
    // keep them).
    const PolarPixel polar = PolarAt(u, v);
    EdgePixel e;
    e.R = polar.radius;
    if (e.R < r_min_ || e.R > r_max_) continue;
    e.theta = polar.azimuth;
    e.cr = polar.cos_r;
    e.sr = polar.sin_r;
    e.gx = edges.dx.ptr<int16_t>(v)[u];
    e.gy = edges.dy.ptr<int16_t>(v)[u] * aspect_;
    e.gn = std::sqrt(e.gx * e.gx + e.gy * e.gy);
    if (!(e.gn > 0.0)) continue;
    n_located += AddEdgePixel(e, k, &located[n_located], result);
  }
  located.resize(n_located);
  // The records, in the same order; the orientation ranges of the pixels
  // ahead are fetched meanwhile (the table is larger than the caches, and
  // the gradient angle makes its accesses random).
  result->voter_radius.reserve(located.size());
  result->voter_azimuth.reserve(located.size());
  for (size_t i = 0; i < located.size(); ++i) {
    if (i + kAhead < located.size()) __builtin_prefetch(&ranges_[located[i + kAhead].ranges]);
    if (AddRecords(located[i], records, result)) {
      result->voter_radius.push_back(located[i].radius);
      result->voter_azimuth.push_back(located[i].azimuth);
    }
  }
}

namespace {

// Where a record's votes go: the integer tables and the working accumulator.
struct VoteLayout {
  const int32_t* table;  // all planes' integer tables
  size_t plane_size;     // ints per plane table
  int stride;            // ints between the table's R rows
  const size_t* plane_offset;  // the working accumulator's planes (PhWholeImage::AccumulatorLayout)
  const int* plane_j0;
  const int* plane_cols;
  int n_r, n_theta;
};

// The voting loops are compiled twice, for the baseline and (where the
// processor has it) for AVX2, whose 32-bit multiplies and minima the
// baseline's SSE2 lacks: PANO_VOTE_INLINE makes each loop part of the
// function that is compiled for AVX2. Both compute the same integers.
#if defined(__GNUC__) || defined(__clang__)
#define PANO_VOTE_INLINE inline __attribute__((always_inline))
#else
#define PANO_VOTE_INLINE inline
#endif

// One run of a record's votes: bins j = 0..n-1 of rows acc + j * cols (whose
// first column is R bin first_bin), R_main bin (Eqn 7) interpolated between the
// table rows a and b with 8-bit weights.
// The bins are computed in chunks by a vectorisable loop (SIMD over theta),
// then counted; every vote lands in its own theta row, so the counts never
// collide within a run.
template <typename T>
PANO_VOTE_INLINE void VoteRun(const int32_t* a, const int32_t* b, int w1, int n, T* acc, int cols, int n_r,
                              int first_bin) {
  constexpr int kChunk = 256;  // a whole run, mostly (measured faster than 64)
  int32_t idx[kChunk];
  for (int j0 = 0; j0 < n; j0 += kChunk) {
    const int m = std::min(kChunk, n - j0);
    const int32_t* aj = a + j0;
    const int32_t* bj = b + j0;
    const int32_t row0 = j0 * cols;
    for (int j = 0; j < m; ++j) {
      // a (256 - w1) + b w1 with one multiply; integer-exact, as on the GPU.
      int32_t v = (aj[j] * 256 + (bj[j] - aj[j]) * w1) >> 16;
      v = v < n_r ? v : n_r;  // column n_r collects out-of-range votes
      idx[j] = row0 + j * cols + (v - first_bin);
    }
    for (int j = 0; j < m; ++j) acc[idx[j]] += 1;
  }
}

template <typename T>
PANO_VOTE_INLINE void VoteRecord(const PhVoteRecord& rec, const VoteLayout& l, T* padded) {
  const int32_t* a = l.table + rec.plane * l.plane_size + rec.offset;
  const int32_t* b = a + l.stride;
  const int cols = l.plane_cols[rec.plane], j0 = l.plane_j0[rec.plane];
  T* plane_acc = padded + l.plane_offset[rec.plane];
  const int n = rec.count;
  const int n1 = std::min(n, l.n_theta - rec.k_start);  // bins before theta_main wraps at 2 pi
  VoteRun(a, b, rec.t, n1, plane_acc + static_cast<size_t>(rec.k_start) * cols, cols, l.n_r, j0);
  if (n > n1) VoteRun(a + n1, b + n1, rec.t, n - n1, plane_acc, cols, l.n_r, j0);
}

template <typename T>
PANO_VOTE_INLINE void VoteRecordsInline(const PhVoteRecord* records, size_t n, const VoteLayout& l, T* padded) {
  for (size_t i = 0; i < n; ++i) VoteRecord(records[i], l, padded);
}

#ifdef PANO_HAVE_X86_TARGETS
template <typename T>
__attribute__((target("avx2"))) void VoteRecordsAvx2(const PhVoteRecord* records, size_t n, const VoteLayout& l,
                                                     T* padded) {
  VoteRecordsInline(records, n, l, padded);
}
#endif

// Votes records[0..n) into padded.
template <typename T>
void VoteRecords(const PhVoteRecord* records, size_t n, const VoteLayout& l, T* padded) {
#ifdef PANO_HAVE_X86_TARGETS
  if (HaveAvx2()) return VoteRecordsAvx2(records, n, l, padded);
#endif
  VoteRecordsInline(records, n, l, padded);
}

}  // namespace

template <typename T>
void PhWholeImage::VoteInto(const std::vector<PhVoteRecord>& unsorted, const AccumulatorLayout& acc_layout,
                            T* padded) const {
  const size_t total = acc_layout.size;
  int64_t votes = 0;
  for (const PhVoteRecord& r : unsorted) votes += r.count;
  // Vote in (plane, first theta bin) order rather than raster order: then
  // consecutive records count into the same few hundred theta rows of one
  // plane, which stay in cache. Integer sums do not depend on the order.
  const int n_keys = static_cast<int>(planes_.size()) * n_theta_;
  thread_local std::vector<int> start;
  thread_local std::vector<PhVoteRecord> sorted;
  std::vector<PhVoteRecord>& records = sorted;  // this thread's, also inside the parallel region
  start.assign(n_keys + 1, 0);
  for (const PhVoteRecord& r : unsorted) ++start[r.plane * n_theta_ + r.k_start + 1];
  for (int i = 0; i < n_keys; ++i) start[i + 1] += start[i];
  records.resize(unsorted.size());
  for (const PhVoteRecord& r : unsorted) records[start[r.plane * n_theta_ + r.k_start]++] = r;
  const int n_threads = votes < options_.parallel_min_votes ? 1 : ThreadCount(options_.num_threads);
  const VoteLayout layout{int_table_.data(),       int_plane_size_,        row_stride(),
                          acc_layout.offset.data(), acc_layout.j0.data(), acc_layout.cols.data(),
                          n_r_,                     n_theta_};
  if (n_threads <= 1) {
    VoteRecords(records.data(), records.size(), layout, padded);
    return;
  }
  // Per-thread integer accumulators (thread 0 writes the output), summed
  // afterwards: integer addition makes the result independent of the split.
  // Allocated before the region: nothing in it throws, and a team smaller
  // than asked for leaves its unused accumulators zero rather than empty.
  std::vector<std::vector<T>> local(n_threads - 1, std::vector<T>(total, 0));
#pragma omp parallel num_threads(n_threads)
  {
    const int tid = omp_get_thread_num();
    T* acc = tid > 0 ? local[tid - 1].data() : padded;
    // The records in equal contiguous shares (what a static schedule gives).
    const int team = omp_get_num_threads();
    const size_t n = records.size(), first = n * tid / team, last = n * (tid + 1) / team;
    VoteRecords(records.data() + first, last - first, layout, acc);
#pragma omp barrier
#pragma omp for schedule(static)
    for (long i = 0; i < static_cast<long>(total); ++i) {
      T s = 0;
      for (int t = 0; t + 1 < n_threads; ++t) s += local[t][i];
      padded[i] += s;
    }
  }
}

void PhWholeImage::VoteCpu(const std::vector<PhVoteRecord>& records, int32_t* padded) const {
  VoteInto(records, padded_layout_, padded);
}

template <typename T>
void PhWholeImage::CopyAccumulator(const T* padded, const AccumulatorLayout& layout,
                                   WholeImageResult* res) const {
  const int P = static_cast<int>(planes_.size()), NT = n_theta_, NR = n_r_;
  if (!options_.keep_accumulator) {
    res->accumulator.clear();
    return;
  }
  res->accumulator.assign(static_cast<size_t>(P) * NT * NR, 0);  // zero outside the planes' windows
  for (int p = 0; p < P; ++p) {
    const int cols = layout.cols[p], j0 = layout.j0[p], n = layout.RealBins(p, NR);
    if (n <= 0) continue;  // only the out-of-range column
    for (int k = 0; k < NT; ++k)
      std::copy_n(padded + layout.offset[p] + static_cast<size_t>(k) * cols, n,
                  res->accumulator.data() + (static_cast<size_t>(p) * NT + k) * NR + j0);
  }
}

// True if bin (k, j) of plane g (value v >= 1; rows of cols bins, the first
// n of them R bins, bins outside them zero) is the maximum of its
// +-nms_theta (circular) x +-nms_r neighbourhood, the first in index order on
// ties: no bin before it in index order reaches v, and none after it
// exceeds v.
template <typename T>
bool PhWholeImage::IsPeak(const T* g, int cols, int n, int k, int j, int32_t v) const {
  const int NT = n_theta_;
  const int a = options_.nms_theta, b = options_.nms_r;
  const int j_lo = std::max(0, j - b), j_hi = std::min(n - 1, j + b);
  // Largest value in bins [lo, hi] of a row.
  auto row_max = [](const T* row, int lo, int hi) {
    int32_t m = std::numeric_limits<int32_t>::min();
    for (int jj = lo; jj <= hi; ++jj) m = std::max<int32_t>(m, row[jj]);
    return m;
  };
  // The nearest rows first (most candidates on a ridge fail there): dk = 0,
  // -1, 1, -2, 2, ...
  for (int step = 0; step <= 2 * a; ++step) {
    const int dk = (step & 1) ? -(step + 1) / 2 : step / 2;
    int kk = k + dk;  // circular in theta
    while (kk < 0) kk += NT;
    while (kk >= NT) kk -= NT;
    const T* orow = g + static_cast<size_t>(kk) * cols;
    if (kk != k) {
      if (row_max(orow, j_lo, j_hi) >= (kk < k ? v : v + 1)) return false;
    } else if ((j_lo < j && row_max(orow, j_lo, j - 1) >= v) || row_max(orow, j, j_hi) > v) {
      return false;  // bin (k, j) itself is not above v
    }
  }
  return true;
}

// The peak at bin (k, j) of plane p (laid out as for IsPeak, R bin j0 + j).
template <typename T>
HorizontalPeak PhWholeImage::RefinedPeak(const T* g, int cols, int n, int j0, int p, int k, int j,
                                         int32_t v) const {
  const int NT = n_theta_, NR = n_r_;
  double f[3][3], ox = 0, oy = 0;
  for (int dk = -1; dk <= 1; ++dk) {
    const T* orow = g + static_cast<size_t>(((k + dk) % NT + NT) % NT) * cols;
    for (int dj = -1; dj <= 1; ++dj) {
      const int jj = j + dj, r_bin = j0 + jj;
      // Beyond the R range: the peak's own value (no curvature there).
      f[dk + 1][dj + 1] = (r_bin < 0 || r_bin >= NR) ? v : (jj >= 0 && jj < n) ? orow[jj] : 0;
    }
  }
  RefineOffset(f, &ox, &oy);
  HorizontalPeak pk;
  pk.plane = p;
  pk.height = options_.heights[p];
  pk.r_main = (j0 + j + 0.5 + ox) * options_.r_bin;
  pk.theta_main = WrapAngle((k + 0.5 + oy) * theta_bin_);
  pk.votes = v;
  return pk;
}

namespace {

// The tests a peak candidate must pass before IsPeak's full one: at least
// thr, not beaten by its row neighbours (when nms_r > 0), by the rows above
// and below (when nms_theta > 0) nor, with both, by its diagonal
// neighbours; ties lose to the bin before in index order (up_before /
// down_before: that row comes first).
template <typename T>
struct NeighbourTest {
  const T *row, *up, *down;
  int n;  // bins in the row
  T thr;
  bool use_row, use_up_down, up_before, down_before;

  // Whether o, in a row before (or after) the candidate's, beats value v.
  static bool Beats(T o, T v, bool before) { return before ? o >= v : o > v; }

  bool Passes(int j) const {
    const T v = row[j];
    if (v < thr) return false;
    if (use_row && ((j > 0 && row[j - 1] >= v) || (j + 1 < n && row[j + 1] > v))) return false;
    if (!use_up_down) return true;
    if (Beats(up[j], v, up_before) || Beats(down[j], v, down_before)) return false;
    if (!use_row) return true;
    // The diagonal neighbours.
    if (j > 0 && (Beats(up[j - 1], v, up_before) || Beats(down[j - 1], v, down_before))) return false;
    return !(j + 1 < n && (Beats(up[j + 1], v, up_before) || Beats(down[j + 1], v, down_before)));
  }

  // Calls on_candidate(j) for the bins that pass, in order. Candidates are
  // sparse: with SSE2 the tests run on 16 bytes of bins at a time, and most
  // of the accumulator, below thr, is skipped 64 bytes at a time.
  template <typename F>
  void ForEachCandidate(F on_candidate) const {
    int j = 0;
#if defined(__SSE2__)
    constexpr int kLanes = 16 / sizeof(T);
    // One bit of the byte mask per bin (the lowest of its bytes').
    constexpr unsigned kLaneBits = sizeof(T) == 2 ? 0x5555u : 0x1111u;
    auto load = [](const T* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); };
    auto gt = [](__m128i x, __m128i y) {
      return sizeof(T) == 2 ? _mm_cmpgt_epi16(x, y) : _mm_cmpgt_epi32(x, y);
    };
    auto eq = [](__m128i x, __m128i y) {
      return sizeof(T) == 2 ? _mm_cmpeq_epi16(x, y) : _mm_cmpeq_epi32(x, y);
    };
    // o beats v: greater, or equal in a row before v's.
    auto beats = [&](const T* o, __m128i v, bool before) {
      const __m128i x = load(o);
      return before ? _mm_or_si128(gt(x, v), eq(x, v)) : gt(x, v);
    };
    if (n > 0 && Passes(0)) on_candidate(0);
    j = 1;
    const __m128i t = sizeof(T) == 2 ? _mm_set1_epi16(static_cast<int16_t>(thr)) : _mm_set1_epi32(thr);
    for (; j + kLanes < n; j += kLanes) {  // j + kLanes <= n - 1: the right neighbours exist
      if (j + 4 * kLanes < n) {            // four vectors all below thr: skipped
        __m128i below;
        if constexpr (sizeof(T) == 2) {
          const __m128i m =
              _mm_max_epi16(_mm_max_epi16(load(row + j), load(row + j + kLanes)),
                            _mm_max_epi16(load(row + j + 2 * kLanes), load(row + j + 3 * kLanes)));
          below = gt(t, m);
        } else {  // SSE2 has no 32-bit maximum
          below = _mm_and_si128(
              _mm_and_si128(gt(t, load(row + j)), gt(t, load(row + j + kLanes))),
              _mm_and_si128(gt(t, load(row + j + 2 * kLanes)), gt(t, load(row + j + 3 * kLanes))));
        }
        if (_mm_movemask_epi8(below) == 0xFFFF) {
          j += 3 * kLanes;
          continue;
        }
      }
      const __m128i v = load(row + j);
      __m128i bad = gt(t, v);
      if (_mm_movemask_epi8(bad) == 0xFFFF) continue;
      if (use_row)
        bad = _mm_or_si128(bad, _mm_or_si128(beats(row + j - 1, v, true), beats(row + j + 1, v, false)));
      if (use_up_down) {
        bad = _mm_or_si128(bad, _mm_or_si128(beats(up + j, v, up_before), beats(down + j, v, down_before)));
        if (use_row) {  // the diagonal neighbours
          bad =
              _mm_or_si128(bad, _mm_or_si128(beats(up + j - 1, v, up_before), beats(up + j + 1, v, up_before)));
          bad = _mm_or_si128(
              bad, _mm_or_si128(beats(down + j - 1, v, down_before), beats(down + j + 1, v, down_before)));
        }
      }
      for (unsigned good = ~_mm_movemask_epi8(bad) & kLaneBits; good; good &= good - 1)
        on_candidate(j + __builtin_ctz(good) / static_cast<int>(sizeof(T)));
    }
#endif
    for (; j < n; ++j)
      if (Passes(j)) on_candidate(j);
  }
};

}  // namespace

template <typename T>
std::vector<HorizontalPeak> PhWholeImage::PlanePeaks(const T* padded, const AccumulatorLayout& layout,
                                                     int p) const {
  const int NT = n_theta_, cols = layout.cols[p], n = layout.RealBins(p, n_r_), j0 = layout.j0[p];
  std::vector<HorizontalPeak> peaks;
  if (options_.min_votes > std::numeric_limits<T>::max()) return peaks;  // no bin can reach it
  const T* g = padded + layout.offset[p];  // rows of cols bins
  for (int k = 0; k < NT; ++k) {
    const int kp = k + 1 < NT ? k + 1 : 0, km = k > 0 ? k - 1 : NT - 1;  // circular in theta
    NeighbourTest<T> test;
    test.row = g + static_cast<size_t>(k) * cols;
    test.up = g + static_cast<size_t>(kp) * cols;
    test.down = g + static_cast<size_t>(km) * cols;
    test.n = n;
    test.thr = static_cast<T>(options_.min_votes);
    test.use_row = options_.nms_r > 0;
    test.use_up_down = options_.nms_theta > 0;
    test.up_before = kp < k;
    test.down_before = km < k;
    test.ForEachCandidate([&](int j) {
      if (IsPeak(g, cols, n, k, j, test.row[j]))
        peaks.push_back(RefinedPeak(g, cols, n, j0, p, k, j, test.row[j]));
    });
  }
  return peaks;
}

template <typename T>
void PhWholeImage::FindHorizontalPeaks(const T* padded, const AccumulatorLayout& layout,
                                       WholeImageResult* res) const {
  // Local maxima with at least min_votes. Planes are independent: searched
  // in parallel (for large accumulators), their peaks joined in plane order
  // afterwards, so the result is the sequential one for any thread count.
  const int P = static_cast<int>(planes_.size());
  std::vector<std::vector<HorizontalPeak>> plane_peaks(P);
  const bool parallel = static_cast<int64_t>(layout.size) >= options_.parallel_min_votes;
  ParallelFor(P, [&](int p) { plane_peaks[p] = PlanePeaks(padded, layout, p); }, parallel, options_.num_threads);
  res->peaks.clear();
  for (const std::vector<HorizontalPeak>& pp : plane_peaks)
    res->peaks.insert(res->peaks.end(), pp.begin(), pp.end());
  std::stable_sort(res->peaks.begin(), res->peaks.end(),
                   [](const HorizontalPeak& x, const HorizontalPeak& y) { return x.votes > y.votes; });
  if (options_.explain_away) ExplainAway(res);
  if (static_cast<int>(res->peaks.size()) > options_.max_peaks) res->peaks.resize(options_.max_peaks);
}

void PhWholeImage::FindVerticalPeaks(WholeImageResult* res) const {
  // Peaks on the circular theta histogram smoothed by [1 2 1] (a radial line
  // near a bin border splits its pixels between two bins).
  const int NT = n_theta_;
  res->vertical_peaks.clear();
  const std::vector<int32_t>& h = res->vertical_histogram;
  std::vector<int32_t> sm(NT);
  for (int k = 0; k < NT; ++k) sm[k] = h[(k + NT - 1) % NT] + 2 * h[k] + h[(k + 1) % NT];
  const int c = options_.vertical_nms;
  for (int k = 0; k < NT; ++k) {
    const int32_t v = sm[k];
    if (v < 2 * options_.vertical_min_votes) continue;
    bool is_max = true;
    for (int dk = -c; dk <= c && is_max; ++dk) {
      if (dk == 0) continue;
      const int kk = ((k + dk) % NT + NT) % NT;
      if (sm[kk] > v || (sm[kk] == v && kk < k)) is_max = false;
    }
    if (is_max) res->vertical_peaks.push_back(VerticalPeakAt(*res, sm, k));
  }
  std::stable_sort(res->vertical_peaks.begin(), res->vertical_peaks.end(),
                   [](const VerticalPeak& x, const VerticalPeak& y) { return x.votes > y.votes; });
}

VerticalPeak PhWholeImage::VerticalPeakAt(const WholeImageResult& res, const std::vector<int32_t>& sm,
                                          int k) const {
  const int NT = n_theta_;
  const std::vector<int32_t>& h = res.vertical_histogram;
  const double m = sm[(k + NT - 1) % NT], z = sm[k], pl = sm[(k + 1) % NT];
  const double den = m - 2 * z + pl;
  const double off = den < 0 ? std::clamp(0.5 * (m - pl) / den, -0.5, 0.5) : 0.0;
  VerticalPeak vp;
  vp.theta = WrapAngle((k + 0.5 + off) * theta_bin_);
  vp.votes = h[(k + NT - 1) % NT] + h[k] + h[(k + 1) % NT];
  vp.r_min = std::numeric_limits<double>::infinity();
  vp.r_max = 0.0;
  for (int dk = -1; dk <= 1; ++dk) {
    const int kk = (k + dk + NT) % NT;
    if (h[kk] == 0 || res.vertical_r_min.empty()) continue;
    vp.r_min = std::min<double>(vp.r_min, res.vertical_r_min[kk]);
    vp.r_max = std::max<double>(vp.r_max, res.vertical_r_max[kk]);
  }
  return vp;
}

template <typename T>
void PhWholeImage::FinishWith(const T* padded, const AccumulatorLayout& layout,
                              WholeImageResult* result) const {
  CopyAccumulator(padded, layout, result);
  FindHorizontalPeaks(padded, layout, result);
  FindVerticalPeaks(result);
}

void PhWholeImage::Finish(int32_t* padded, WholeImageResult* result) const {
  FinishWith(padded, padded_layout_, result);
}

// The voters' radii bucketed by theta bin, each bucket sorted: bucket k is
// radius[start[k] .. start[k + 1]). The explain-away step knows a voter by
// its position here (it needs only the radius and whether it is claimed).
struct PhWholeImage::VoterIndex {
  std::vector<int> start;
  std::vector<float> radius;
};

PhWholeImage::VoterIndex PhWholeImage::BucketVoters(const WholeImageResult& res) const {
  const int NT = n_theta_;
  const size_t n = res.voter_radius.size();
  VoterIndex index;
  index.start.assign(NT + 1, 0);
  std::vector<int> bin(n);
  for (size_t i = 0; i < n; ++i) {
    int k = static_cast<int>(res.voter_azimuth[i] / theta_bin_);
    bin[i] = std::clamp(k, 0, NT - 1);
    ++index.start[bin[i] + 1];
  }
  for (int k = 0; k < NT; ++k) index.start[k + 1] += index.start[k];
  std::vector<int> fill(index.start.begin(), index.start.end() - 1);
  index.radius.resize(n);
  for (size_t i = 0; i < n; ++i) index.radius[fill[bin[i]]++] = res.voter_radius[i];
  // The buckets are small (a few voters per degree): insertion sort.
  for (int k = 0; k < NT; ++k) {
    float* r = index.radius.data();
    for (int i = index.start[k] + 1; i < index.start[k + 1]; ++i) {
      const float x = r[i];
      int j = i;
      for (; j > index.start[k] && r[j - 1] > x; --j) r[j] = r[j - 1];
      r[j] = x;
    }
  }
  return index;
}

void PhWholeImage::PeakCurve(const HorizontalPeak& pk, CurveRows* rows) const {
  const int S = sub_steps_, W = width_, M = half_width_;
  const double t0 = WrapAnglePositive(pk.theta_main);
  // Bin edges (kc + d) theta_bin - theta_main = (d - frac) theta_bin.
  const double x = t0 / theta_bin_;
  int kc = static_cast<int>(std::floor(x));
  int sub = static_cast<int>(std::lround((x - kc) * S));
  if (sub == S) {
    ++kc;
    sub = 0;
  }
  const double fr = pk.r_main / options_.r_row_step;
  const int r0 = static_cast<int>(fr);
  if (r0 < 0 || r0 + 1 >= n_rows_) {
    rows->c0 = rows->c1 = nullptr;
    return;
  }
  rows->kc = kc;
  rows->tr = static_cast<float>(fr - r0);
  rows->c0 = &planes_[pk.plane].curve[(static_cast<size_t>(r0) * S + sub) * W + M];
  rows->c1 = rows->c0 + static_cast<size_t>(S) * W;
}

void PhWholeImage::PeakSupport(const CurveRows& curve, const VoterIndex& index,
                               const std::vector<unsigned char>& claimed, std::vector<int>* support) const {
  const int NT = n_theta_, M = half_width_;
  const double tol = options_.explain_tolerance;
  support->clear();
  const float tr = curve.tr;
  const float *c0 = curve.c0, *c1 = curve.c1;
  const float* rad = index.radius.data();
  // Curve radius (Eqn 6) at the edges of each theta bin kc-M..kc+M.
  double r_prev = 0.0;
  bool ok_prev = false;
  int k = ((curve.kc - M - 1) % NT + NT) % NT;  // theta bin between the edges d - 1 and d
  for (int d = -M; d <= M; ++d, k = k + 1 < NT ? k + 1 : 0) {
    const double r = (1.0f - tr) * c0[d] + tr * c1[d];
    const bool ok = !std::isnan(r);
    const int b = index.start[k], e = index.start[k + 1];
    if (ok && ok_prev && b < e) {
      const double lo = std::min(r, r_prev) - tol, hi = std::max(r, r_prev) + tol;
      const int first = static_cast<int>(
          std::lower_bound(rad + b, rad + e, lo, [](float a, double v) { return a < v; }) - rad);
      for (int i = first; i < e && rad[i] <= hi; ++i)
        if (!claimed[i]) support->push_back(i);
    }
    r_prev = r;
    ok_prev = ok;
  }
}

void PhWholeImage::ExplainAway(WholeImageResult* result) const {
  WholeImageResult& res = *result;
  const VoterIndex index = BucketVoters(res);
  const size_t n = res.peaks.size();
  std::vector<CurveRows> curves(n);  // c0 null: outside the table
  for (size_t i = 0; i < n; ++i) PeakCurve(res.peaks[i], &curves[i]);
  std::vector<unsigned char> claimed(res.voter_radius.size(), 0);  // by position in the index
  std::vector<int> support;
  std::vector<HorizontalPeak> kept;
  for (size_t i = 0; i < n; ++i) {
    // The next peak's curve rows are fetched meanwhile (the table is larger
    // than the caches).
    if (i + 1 < n && curves[i + 1].c0)
      for (int d = -half_width_; d <= half_width_; d += 16) {
        __builtin_prefetch(curves[i + 1].c0 + d);
        __builtin_prefetch(curves[i + 1].c1 + d);
      }
    if (!curves[i].c0) continue;  // no support
    PeakSupport(curves[i], index, claimed, &support);
    if (static_cast<int>(support.size()) < options_.min_votes) continue;
    for (int v : support) claimed[v] = 1;
    kept.push_back(res.peaks[i]);
  }
  res.peaks = std::move(kept);
}

WholeImageResult PhWholeImage::Run(const EdgeMap& edges) const {
  WholeImageResult res;
  thread_local std::vector<PhVoteRecord> records;
  Prepare(edges, &records, &res);
  // A record votes at most once in a bin (its bins lie in distinct theta
  // rows), so no bin exceeds the number of records: with fewer than 2^15 of
  // them 16-bit counts are exact, and the accumulator (zeroing, voting, peak
  // search) takes half the memory. The result is the same either way, as
  // with the compact layout (each plane only the R bins it can vote for).
  const AccumulatorLayout& layout = compact_layout_;
  if (records.size() <= static_cast<size_t>(std::numeric_limits<int16_t>::max())) {
    thread_local std::vector<int16_t> padded16;
    padded16.assign(layout.size, 0);
    VoteInto(records, layout, padded16.data());
    FinishWith(padded16.data(), layout, &res);
  } else {
    thread_local std::vector<int32_t> padded;
    padded.assign(layout.size, 0);
    VoteInto(records, layout, padded.data());
    FinishWith(padded.data(), layout, &res);
  }
  return res;
}

double NominalHeightError(const Sensor& sensor, const PhTable& nominal, double true_z, double d_lo,
                          double d_hi, double dtheta_lim) {
  double worst = 0.0;
  for (int i = 0; i <= 40; ++i) {
    const double d_main = d_lo * std::pow(d_hi / d_lo, i / 40.0);
    double r_main;
    if (!sensor.image_radius(d_main, true_z, &r_main)) continue;
    for (int j = 0; j <= 60; ++j) {
      const double dt = dtheta_lim * j / 60.0;
      double r_i, r_nom;
      if (!sensor.image_radius(d_main / std::cos(dt), true_z, &r_i)) continue;
      if (!nominal.Main(r_i, dt, &r_nom)) continue;
      worst = std::max(worst, std::abs(r_nom - r_main));
    }
  }
  return worst;
}

}  // namespace pano

#include "panotrack/track/edge_profile.h"

#include <algorithm>
#include <cmath>

namespace pano {

bool SampleLine(const cv::Mat& grey, const Eigen::Vector2d& start, const Eigen::Vector2d& step,
                int n, float* out) {
  if (n <= 0) return true;
  // A straight line lies inside the image when both its ends do: check them
  // once, then interpolate without per-sample checks.
  float ends[2];
  const Eigen::Vector2d last = start + (n - 1) * step;
  if (!SampleGrey(grey, start.x(), start.y(), &ends[0]) || !SampleGrey(grey, last.x(), last.y(), &ends[1]))
    return false;
  // In float, in chunks whose coordinates, corner pixels and blends are
  // each one loop the compiler vectorises (the line is inside the image, so
  // truncation is floor).
  const uchar* data = grey.data;
  const int stride = static_cast<int>(grey.step[0]);
  const float sx = static_cast<float>(start.x()), sy = static_cast<float>(start.y());
  const float dx = static_cast<float>(step.x()), dy = static_cast<float>(step.y());
  const int max_ix = grey.cols - 2, max_iy = grey.rows - 2;
  constexpr int kChunk = 32;
  int offset[kChunk];
  float fx[kChunk], fy[kChunk], p00[kChunk], p01[kChunk], p10[kChunk], p11[kChunk];
  for (int k0 = 0; k0 < n; k0 += kChunk) {
    const int m = std::min(kChunk, n - k0);
    for (int j = 0; j < m; ++j) {
      const float x = sx + static_cast<float>(k0 + j) * dx, y = sy + static_cast<float>(k0 + j) * dy;
      // Clamped: float rounding must not step past the last pixel pair
      // that the ends' check allowed (it can only move by far less than one).
      const int ix = std::clamp(static_cast<int>(x), 0, max_ix), iy = std::clamp(static_cast<int>(y), 0, max_iy);
      fx[j] = x - static_cast<float>(ix);
      fy[j] = y - static_cast<float>(iy);
      offset[j] = iy * stride + ix;
    }
    for (int j = 0; j < m; ++j) {
      const uchar* r0 = data + offset[j];
      p00[j] = r0[0];
      p01[j] = r0[1];
      p10[j] = r0[stride];
      p11[j] = r0[stride + 1];
    }
    for (int j = 0; j < m; ++j)
      out[k0 + j] = (1 - fy[j]) * ((1 - fx[j]) * p00[j] + fx[j] * p01[j]) + fy[j] * ((1 - fx[j]) * p10[j] + fx[j] * p11[j]);
  }
  return true;
}

namespace {

float MeanOf(const float* p, int n, int a, int b) {
  a = std::clamp(a, 0, n - 1);
  b = std::clamp(b, 0, n - 1);
  float s = 0;
  for (int i = a; i <= b; ++i) s += p[i];
  return s / static_cast<float>(b - a + 1);
}

// The edge's location by the area method over samples [a, b], the ramp
// lying inside and the plateaus `left` and `right` outside: with n_i the
// profile normalised from left (0) to right (1), an ideal step at x gives
// sum n_i = b + 0.5 - x.
double AreaLocation(const float* p, int a, int b, float left, float right) {
  double area = 0.0;
  const double inv = 1.0 / (right - left);
  for (int i = a; i <= b; ++i) area += (p[i] - left) * inv;
  return b + 0.5 - area;
}

}  // namespace

bool FindStep(const float* p, int n, int polarity, int baseline, double min_step, StepEdge* edge,
              double ramp) {
  // Half-width of the rise: the baseline's, or enough to span the ramp.
  const int h = std::max(std::max(1, baseline / 2), static_cast<int>(std::ceil(0.5 * ramp)) + 1);
  const int w = 3;  // plateau samples either side
  if (n < 2 * (h + w) + 1) return false;
  // Signed rise over the window centred on each sample (SIMD-friendly).
  int best = -1;
  float best_rise = static_cast<float>(min_step);
  const float sgn = polarity >= 0 ? 1.0f : -1.0f;
  for (int i = h; i < n - h; ++i) {
    const float rise = sgn * (p[i + h] - p[i - h]);
    if (rise > best_rise) {
      best_rise = rise;
      best = i;
    }
  }
  if (best < 0) return false;
  // The plateaus either side of the ramp, first a whole rise window away,
  // then right beside the ramp's own extent: plateaus measured far out pick
  // up shading and other structure, whose error the area multiplies by the
  // window's width.
  const int c0 = best;
  float left = MeanOf(p, n, c0 - h - w, c0 - h), right = MeanOf(p, n, c0 + h, c0 + h + w);
  double loc = best;
  int last_a = -1, last_b = -1;
  for (int pass = 0; pass < 3; ++pass) {
    if (!(sgn * (right - left) > 0.5 * min_step)) return false;
    // The ramp's extent: where the normalised profile leaves 0 and 1
    // (allowing for noise), plus the optics' tails.
    const int c = static_cast<int>(std::lround(loc));
    if (c < w + 4 || c > n - 1 - w - 4) return false;
    const float inv = 1.0f / (right - left);
    int a = c, b = c;
    // No wider than the expected ramp: beyond it lies other structure.
    const int lo = std::max(w + 4, c - h - 1), hi = std::min(n - 1 - w - 4, c + h + 1);
    while (a > lo && (p[a - 1] - left) * inv > 0.15f) --a;
    while (b < hi && (p[b + 1] - left) * inv < 0.85f) ++b;
    // A ramp running on well past the widest expected (blurred more than
    // predicted): its plateaus and so its centre are out of reach.
    if ((a == lo && (p[a - 1] - left) * inv > 0.3f) || (b == hi && (p[b + 1] - left) * inv < 0.7f)) return false;
    // The same extent as the last pass: the same plateaus and location.
    if (a == last_a && b == last_b) break;
    last_a = a;
    last_b = b;
    edge->width = b - a + 1;
    a -= 3;
    b += 3;
    left = MeanOf(p, n, a - w, a - 1);
    right = MeanOf(p, n, b + 1, b + w);
    if (!(sgn * (right - left) > 0.5 * min_step)) return false;
    loc = AreaLocation(p, a, b, left, right);
    if (!(loc >= a && loc <= b)) return false;  // not one clean step
  }
  edge->location = loc;
  edge->strength = sgn * (right - left);
  return true;
}

}  // namespace pano

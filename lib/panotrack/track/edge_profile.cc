#include "panotrack/track/edge_profile.h"

#include <algorithm>
#include <cmath>

#include "panotrack/core/cpu_features.h"

#ifdef PANO_HAVE_X86_TARGETS
#include <immintrin.h>
#define PANO_EDGE_PROFILE_AVX2 1
#endif

namespace pano {

namespace {

// One bilinear sample: the blend every path below computes, in this order
// and in float, so that all of them give the same bits.
inline float Blend(float fx, float fy, float p00, float p01, float p10, float p11) {
  return (1 - fy) * ((1 - fx) * p00 + fx * p01) + fy * ((1 - fx) * p10 + fx * p11);
}

#ifdef PANO_EDGE_PROFILE_AVX2
// The n samples of a line inside the image, eight at a time, each pixel
// pair fetched by one 4-byte gather (the row's pixels ix .. ix + 3). The caller
// guarantees that those reads stay inside the image's buffer: no sample in
// its last three rows. AVX2 without FMA: every product rounds as in the
// scalar blend.
__attribute__((target("avx2"))) void SampleLineAvx2(const uchar* data, int stride, float sx, float sy, float dx,
                                                     float dy, int max_ix, int max_iy, int n, float* out) {
  const __m256 vsx = _mm256_set1_ps(sx), vsy = _mm256_set1_ps(sy);
  const __m256 vdx = _mm256_set1_ps(dx), vdy = _mm256_set1_ps(dy);
  const __m256 one = _mm256_set1_ps(1.0f);
  const __m256i zero = _mm256_setzero_si256(), byte = _mm256_set1_epi32(0xff);
  const __m256i vmax_ix = _mm256_set1_epi32(max_ix), vmax_iy = _mm256_set1_epi32(max_iy);
  const __m256i vstride = _mm256_set1_epi32(stride);
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const int* top_base = reinterpret_cast<const int*>(data);
  const int* bottom_base = reinterpret_cast<const int*>(data + stride);
  for (int k0 = 0; k0 < n; k0 += 8) {
    // The last group's lanes past the line's end neither read nor write.
    const __m256i live = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - k0), lanes);
    const __m256 k = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(k0), lanes));
    const __m256 x = _mm256_add_ps(vsx, _mm256_mul_ps(k, vdx));
    const __m256 y = _mm256_add_ps(vsy, _mm256_mul_ps(k, vdy));
    const __m256i ix = _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(x), zero), vmax_ix);
    const __m256i iy = _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(y), zero), vmax_iy);
    const __m256 fx = _mm256_sub_ps(x, _mm256_cvtepi32_ps(ix));
    const __m256 fy = _mm256_sub_ps(y, _mm256_cvtepi32_ps(iy));
    const __m256i offset = _mm256_add_epi32(_mm256_mullo_epi32(iy, vstride), ix);
    const __m256i top = _mm256_mask_i32gather_epi32(zero, top_base, offset, live, 1);
    const __m256i bottom = _mm256_mask_i32gather_epi32(zero, bottom_base, offset, live, 1);
    const __m256 p00 = _mm256_cvtepi32_ps(_mm256_and_si256(top, byte));
    const __m256 p01 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(top, 8), byte));
    const __m256 p10 = _mm256_cvtepi32_ps(_mm256_and_si256(bottom, byte));
    const __m256 p11 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(bottom, 8), byte));
    const __m256 gx = _mm256_sub_ps(one, fx);
    const __m256 upper = _mm256_add_ps(_mm256_mul_ps(gx, p00), _mm256_mul_ps(fx, p01));
    const __m256 lower = _mm256_add_ps(_mm256_mul_ps(gx, p10), _mm256_mul_ps(fx, p11));
    _mm256_maskstore_ps(out + k0, live,
                        _mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(one, fy), upper), _mm256_mul_ps(fy, lower)));
  }
}
#endif

}  // namespace

bool SampleLine(const cv::Mat& grey, const Eigen::Vector2d& start, const Eigen::Vector2d& step,
                int n, float* out) {
  if (n <= 0) return true;
  // A straight line lies inside the image when both its ends do: check them
  // once (where SampleGrey samples), then interpolate without per-sample checks.
  const Eigen::Vector2d last = start + (n - 1) * step;
  auto inside = [&](const Eigen::Vector2d& q) {
    return q.x() >= 0.0 && q.y() >= 0.0 && q.x() <= grey.cols - 1.001 && q.y() <= grey.rows - 1.001;
  };
  if (!inside(start) || !inside(last)) return false;
  // In float, in chunks whose coordinates, corner pixels and blends are
  // each one loop the compiler vectorises (the line is inside the image, so
  // truncation is floor).
  const uchar* data = grey.data;
  const int stride = static_cast<int>(grey.step[0]);
  const float sx = static_cast<float>(start.x()), sy = static_cast<float>(start.y());
  const float dx = static_cast<float>(step.x()), dy = static_cast<float>(step.y());
  const int max_ix = grey.cols - 2, max_iy = grey.rows - 2;
#ifdef PANO_EDGE_PROFILE_AVX2
  // The gathers read two bytes past each pixel pair: clear of the buffer's
  // end when the line keeps out of the last rows (margin for float rounding).
  if (HaveAvx2() && std::max(start.y(), last.y()) < grey.rows - 3.5) {
    SampleLineAvx2(data, stride, sx, sy, dx, dy, max_ix, max_iy, n, out);
    return true;
  }
#endif
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
    for (int j = 0; j < m; ++j) out[k0 + j] = Blend(fx[j], fy[j], p00[j], p01[j], p10[j], p11[j]);
  }
  return true;
}

namespace {

// std::lround of a finite value well inside int's range, inline: the
// baseline x86-64 has no rounding instruction, so std::lround is a library
// call. Halves round away from zero, as std::lround's.
inline int RoundToInt(double x) {
  int r = static_cast<int>(x);  // towards zero
  const double fraction = x - r;  // exact
  if (fraction >= 0.5) ++r;
  else if (fraction <= -0.5) --r;
  return r;
}

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

int LargestRiseScalar(const float* p, int n, int h, float sgn, float min_rise) {
  int best = -1;
  float best_rise = min_rise;
  for (int i = h; i < n - h; ++i) {
    const float rise = sgn * (p[i + h] - p[i - h]);
    if (rise > best_rise) {
      best_rise = rise;
      best = i;
    }
  }
  return best;
}

#ifdef PANO_EDGE_PROFILE_AVX2
// The same, eight rises at a time: their maximum, then the first sample
// that reaches it (what the scalar scan keeps, as it moves on only for a
// strictly larger rise).
__attribute__((target("avx2"))) int LargestRiseAvx2(const float* p, int n, int h, float sgn, float min_rise) {
  const int end = n - h;  // rises at i = h .. end - 1
  const __m256 vsgn = _mm256_set1_ps(sgn);
  __m256 vmax = _mm256_set1_ps(min_rise);
  int i = h;
  for (; i + 8 <= end; i += 8)
    // max(rise, vmax): a NaN rise keeps vmax, as the scalar comparison skips it.
    vmax = _mm256_max_ps(_mm256_mul_ps(vsgn, _mm256_sub_ps(_mm256_loadu_ps(p + i + h), _mm256_loadu_ps(p + i - h))),
                         vmax);
  float lanes[8];
  _mm256_storeu_ps(lanes, vmax);
  float top = lanes[0];
  for (int k = 1; k < 8; ++k) top = std::max(top, lanes[k]);
  const int vector_end = i;
  for (; i < end; ++i) top = std::max(top, sgn * (p[i + h] - p[i - h]));
  if (!(top > min_rise)) return -1;
  const __m256 vtop = _mm256_set1_ps(top);
  for (i = h; i < vector_end; i += 8) {
    const __m256 rise = _mm256_mul_ps(vsgn, _mm256_sub_ps(_mm256_loadu_ps(p + i + h), _mm256_loadu_ps(p + i - h)));
    const int mask = _mm256_movemask_ps(_mm256_cmp_ps(rise, vtop, _CMP_EQ_OQ));
    if (mask) return i + __builtin_ctz(static_cast<unsigned>(mask));
  }
  for (; i < end; ++i)
    if (sgn * (p[i + h] - p[i - h]) == top) return i;
  return -1;
}
#endif

// The first sample of the largest signed rise p[i + h] - p[i - h] (times
// sgn) above min_rise; -1 when none is.
int LargestRise(const float* p, int n, int h, float sgn, float min_rise) {
#ifdef PANO_EDGE_PROFILE_AVX2
  if (HaveAvx2()) return LargestRiseAvx2(p, n, h, sgn, min_rise);
#endif
  return LargestRiseScalar(p, n, h, sgn, min_rise);
}

}  // namespace

bool FindStep(const float* p, int n, int polarity, int baseline, double min_step, StepEdge* edge,
              double ramp) {
  // Half-width of the rise: the baseline's, or enough to span the ramp.
  const int h = std::max(std::max(1, baseline / 2), static_cast<int>(std::ceil(0.5 * ramp)) + 1);
  const int w = 3;  // plateau samples either side
  if (n < 2 * (h + w) + 1) return false;
  // Signed rise over the window centred on each sample: the first of the
  // largest, when above min_step.
  const float sgn = polarity >= 0 ? 1.0f : -1.0f;
  const int best = LargestRise(p, n, h, sgn, static_cast<float>(min_step));
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
    const int c = RoundToInt(loc);
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

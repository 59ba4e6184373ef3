#include "track/edge_profile.h"

#include <algorithm>
#include <cmath>

namespace pano {

bool SampleLine(const cv::Mat& grey, const Eigen::Vector2d& start, const Eigen::Vector2d& step,
                int n, float* out) {
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector2d p = start + k * step;
    if (!SampleGrey(grey, p.x(), p.y(), &out[k])) return false;
  }
  return true;
}

bool FindStep(const float* p, int n, int polarity, int baseline, double min_step, StepEdge* edge) {
  const int h = std::max(1, baseline / 2);
  if (n < 2 * h + 3) return false;
  // Signed rise over the baseline centred on each sample (SIMD-friendly).
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
  // Plateaus: the mean a little outside the step on each side.
  const int w = h + 1;
  auto mean = [&](int a, int b) {
    a = std::clamp(a, 0, n - 1);
    b = std::clamp(b, 0, n - 1);
    float s = 0;
    for (int i = a; i <= b; ++i) s += p[i];
    return s / (b - a + 1);
  };
  const float lo = mean(best - 2 * w, best - w), hi = mean(best + w, best + 2 * w);
  const float mid = 0.5f * (lo + hi);
  double loc = -1.0;
  // The crossing of `mid` nearest the derivative peak.
  for (int d = 0; d <= w && loc < 0; ++d) {
    for (int i : {best - d, best + d - 1}) {
      if (i < 0 || i + 1 >= n) continue;
      const float a = p[i] - mid, b = p[i + 1] - mid;
      if ((a <= 0 && b > 0) || (a >= 0 && b < 0)) {
        loc = i + a / (a - b);
        break;
      }
    }
  }
  if (loc < 0) {
    // Parabola through the rise at the peak and its neighbours.
    auto rise = [&](int i) {
      i = std::clamp(i, h, n - h - 1);
      return sgn * (p[i + h] - p[i - h]);
    };
    const double a = rise(best - 1), b = rise(best), c = rise(best + 1);
    const double den = a - 2 * b + c;
    loc = best + (den < 0 ? 0.5 * (a - c) / den : 0.0);
  }
  edge->location = loc;
  edge->strength = sgn * (hi - lo);
  return edge->strength > 0.5 * min_step;
}

}  // namespace pano

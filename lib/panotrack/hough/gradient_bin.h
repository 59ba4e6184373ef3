// Internal: the per-pixel arithmetic of the whole-image transform's
// Prepare step, here so that the tests can hold it against its reference.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace pano {
namespace detail {

// Gradient angle bins: 1 degree over [-90, 90) degrees.
constexpr int kGradientAngleBins = 180;

// std::floor and std::lround for the per-pixel arithmetic, without the
// library calls the baseline x86-64 makes for them; the same integers for
// |x| < 2^31 (x - trunc(x) is exact).
inline int FloorToInt(double x) {
  const int i = static_cast<int>(x);
  return x < i ? i - 1 : i;
}
inline int RoundNonNegative(double x) {  // x >= 0: halves round up, as lround
  const int i = static_cast<int>(x);
  return x - i >= 0.5 ? i + 1 : i;
}

// The gradient angle bin (1-degree bins over [-90, 90)) of the gradient
// (g_rad, g_tan) in the radial frame, modulo 180 degrees: the angle in
// single precision, as the orientation ranges were built for.
inline int GradientAngleBinExact(double g_tan, double g_rad) {
  double phi = std::atan2(static_cast<float>(g_tan), static_cast<float>(g_rad));
  if (phi >= M_PI / 2) phi -= M_PI;
  if (phi < -M_PI / 2) phi += M_PI;
  return std::clamp(FloorToInt((phi + M_PI / 2) * (180.0 / M_PI)), 0, kGradientAngleBins - 1);
}

// The bins' lower edges as tangents, tan((b - 90) degrees) for b = 1..179;
// -inf for b = 0 and +inf for b = 180.
struct GradientBinEdges {
  double tan_edge[kGradientAngleBins + 1];
  GradientBinEdges() {
    tan_edge[0] = -std::numeric_limits<double>::infinity();
    tan_edge[kGradientAngleBins] = std::numeric_limits<double>::infinity();
    for (int b = 1; b < kGradientAngleBins; ++b) tan_edge[b] = std::tan((b - 90) * M_PI / 180);
  }
};

// GradientAngleBinExact without the arctangent: a polynomial arctangent
// (error under 0.1 degree) gives the bin or a neighbour, and the bins' edges
// as tangents decide. The single-precision angle can fall on the other side
// of an edge only very near it: within 1e-5 rad of an edge, and near +-90
// degrees, GradientAngleBinExact decides, so the bins are the same.
inline int GradientAngleBin(double g_tan, double g_rad, const GradientBinEdges& edges) {
  const double t = static_cast<double>(static_cast<float>(g_tan)) / static_cast<float>(g_rad);
  constexpr double kTanLimit = 100.0, kNear = 1e-5;  // tan(89.4 degrees); rad
  const double at = std::abs(t);
  if (!(at < kTanLimit)) return GradientAngleBinExact(g_tan, g_rad);
  // atan(u) on [0, 1], |error| < 0.0015 rad; atan(t) = pi/2 - atan(1/t).
  const double u = at > 1.0 ? 1.0 / at : at;
  double a = u * (M_PI / 4) - u * (u - 1.0) * (0.2447 + 0.0663 * u);
  a = at > 1.0 ? M_PI / 2 - a : a;
  a = t < 0.0 ? -a : a;
  int b = std::clamp(static_cast<int>(a * (180.0 / M_PI) + 90.0), 0, kGradientAngleBins - 1);
  const double* e = edges.tan_edge;
  b -= t < e[b];
  b += t >= e[b + 1];
  // d tan / d angle = 1 + tan^2.
  const double lo = e[b], hi = e[b + 1];
  const bool near_lo = b > 0 && t - lo < kNear * (1.0 + lo * lo);
  const bool near_hi = b + 1 < kGradientAngleBins && hi - t < kNear * (1.0 + hi * hi);
  if (near_lo || near_hi) return GradientAngleBinExact(g_tan, g_rad);
  return b;
}

}  // namespace detail
}  // namespace pano

// Angle wrapping, written once for the whole toolkit.
#pragma once

#include <cmath>

namespace pano {

// Wraps an angle to (-pi, pi].
inline double wrap_angle(double a) {
  if (a > -M_PI && a <= M_PI) return a;  // the common case, without a division
  a = std::remainder(a, 2.0 * M_PI);
  if (a <= -M_PI) a += 2.0 * M_PI;
  return a;
}

// Wraps an angle to [0, 2 pi).
inline double wrap_angle_positive(double a) {
  a = std::fmod(a, 2.0 * M_PI);
  if (a < 0.0) a += 2.0 * M_PI;
  return a >= 2.0 * M_PI ? 0.0 : a;
}

}  // namespace pano

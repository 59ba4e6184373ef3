// Shared fixtures of the Panoramic Hough tests: the paper's synthetic sensor
// (calib/paper-synthetic.yaml: 500 x 500, f 590 px, sphere r 4.9, centre 15.1
// above the pinhole), a compact E(D,Z) table, and points generated through the
// exact sensor model from known horizontal 3-D lines.
#pragma once

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "panotrack/hough/ph_table.h"
#include "panotrack/hough/tracking.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/sensor/sensor.h"

namespace pano::test {

inline Sensor PaperSyntheticSensor() {
  return MakeSphereSensor(500, 500, 590.0, 249.5, 249.5, 1.0, 4.9, 15.1);
}
// Non-square pixels, shifted centre, camera turned about its axis.
inline Sensor TurnedSensor() {
  return MakeSphereSensor(500, 480, 590.0, 251.0, 238.5, 0.95, 4.9, 15.1, 0.3);
}

// Heights -35..95 cover a room 120 high seen from a pinhole 30 above the floor.
inline LutRanges HoughTestRanges() { return {20.0, 800.0, -35.0, 95.0}; }
// Smaller than the default 1024-node table so each test process builds it
// in a fraction of a second.
inline LutSize HoughTestLutSize() { return {512, 512, 768, 131}; }

inline std::shared_ptr<const RadiusTable> BuildTestTable(const Sensor& s) {
  return std::make_shared<const RadiusTable>(
      RadiusTable::Build(s, HoughTestRanges(), HoughTestLutSize()));
}

// A horizontal line at height z (sensor frame) whose foot (closest point to
// the axis) is at horizontal distance d_main, bearing `bearing`.
struct HLine {
  double z, d_main, bearing;
  Eigen::Vector3d Point(double dtheta) const {
    const double c = std::cos(bearing), s = std::sin(bearing);
    const double t = d_main * std::tan(dtheta);  // along the line
    return {d_main * c - t * s, d_main * s + t * c, z};
  }
};

// Truth in image terms: R_main = E(D_main, Z) (Eqn 4), theta_main = the image
// azimuth of the foot.
inline bool LineTruth(const Sensor& s, const HLine& l, double* r_main, double* theta_main) {
  if (!s.image_radius(l.d_main, l.z, r_main)) return false;
  *theta_main = s.image_azimuth(l.bearing);
  return true;
}

// Points of the line for dtheta in [dt0, dt1] (n of them, evenly spaced),
// projected to pixels and back to image polar coordinates (the way the
// localiser's step-edge points arrive), optionally with Gaussian pixel noise.
template <typename Rng>
std::vector<TrackingVote> LinePoints(const Sensor& s, const HLine& l, double dt0, double dt1, int n,
                                     double noise_px, Rng& rng) {
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<TrackingVote> out;
  for (int k = 0; k < n; ++k) {
    const double dt = dt0 + (dt1 - dt0) * (n == 1 ? 0.5 : k / double(n - 1));
    Eigen::Vector2d px;
    if (!s.project(l.Point(dt), &px)) continue;
    if (noise_px > 0) {
      const double ny = noise(rng), nx = noise(rng);  // (drawn in a set order: a call's argument order is the compiler's)
      px += noise_px * Eigen::Vector2d(nx, ny);
    }
    TrackingVote v;
    s.to_polar(px.x(), px.y(), &v.radius, &v.azimuth);
    out.push_back(v);
  }
  return out;
}

inline double AngleDiff(double a, double b) { return std::remainder(a - b, 2.0 * M_PI); }

}  // namespace pano::test

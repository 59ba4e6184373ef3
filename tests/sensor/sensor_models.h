// The sensor models every sensor test runs over: the round-trip harness is
// one function applied to each of them.
#pragma once

#include <string>
#include <vector>

#include "panotrack/sensor/sensor.h"

namespace pano::test {

struct NamedSensor {
  std::string name;
  Sensor sensor;
};

// Mei's unified model as fitted to a real parabolic mirror behind a
// near-telecentric lens (1280 x 1024; measured xi 1.28, f 340 px, k1 0.07,
// k2 0.04), at the given xi.
inline Sensor MeiParabolic(double xi = 1.28) {
  Sensor s;
  s.model = MirrorModel::kUnified;
  s.image_width = 1280;
  s.image_height = 1024;
  SensorParams<double>& p = s.params;
  p.unified = true;
  p.xi = xi;
  p.focal_px = 340.0;
  p.cx = 643.0;
  p.cy = 522.8;
  p.aspect = 1.0;
  p.k1 = 0.07;
  p.k2 = 0.04;
  p.rim_radius = 1.55;  // the image disc's edge, as a normalised radius
  return s;
}

inline std::vector<NamedSensor> AllSensorModels() {
  std::vector<NamedSensor> out;
  // The paper's real sensor (f 590 px, r 4.9 cm, d 15.1 cm), 640 x 480.
  out.push_back({"sphere/paper-real", MakeSphereSensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1)});
  // The paper's synthetic sensor: 500 x 500 px, horizon radius about 157 px.
  out.push_back({"sphere/paper-synthetic",
                 MakeSphereSensor(500, 500, 438.0, 249.5, 249.5, 1.0, 4.9, 15.1)});
  // Non-square pixels, a turned camera.
  out.push_back({"sphere/aspect-offset",
                 MakeSphereSensor(752, 480, 400, 370.2, 241.7, 0.93, 3.0, 11.0, 0.4)});
  // Hyperboloid with a rim, and lens distortion.
  Sensor hyper = MakeSphereSensor(752, 480, 300, 376, 240, 1.0, 1, 1);
  hyper.model = MirrorModel::kConic;
  hyper.params.curvature_radius = 2.0;
  hyper.params.conic_constant = -2.2;
  hyper.params.vertex_distance = 6.0;
  hyper.params.rim_radius = 3.0;
  hyper.params.k1 = -0.05;
  hyper.params.k2 = 0.01;
  out.push_back({"conic/hyperboloid-distorted", hyper});
  // Prolate ellipsoid, no rim (limb-limited).
  Sensor ell = MakeSphereSensor(640, 640, 500, 320, 320, 1.0, 1, 1);
  ell.model = MirrorModel::kConic;
  ell.params.curvature_radius = 3.0;
  ell.params.conic_constant = -0.4;
  ell.params.vertex_distance = 9.0;
  out.push_back({"conic/ellipsoid", ell});
  return out;
}

}  // namespace pano::test

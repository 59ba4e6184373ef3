#include "panotrack/sensor/sensor.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"

namespace pano {

const char* MirrorModelName(MirrorModel m) {
  switch (m) {
    case MirrorModel::kSphere: return "sphere";
    case MirrorModel::kConic: return "conic";
    case MirrorModel::kAsphere: return "asphere";
    case MirrorModel::kUnified: return "unified";
  }
  return "unknown";
}

namespace {

// The visible part of an even-asphere profile curves towards its axis
// everywhere (w'' = sigma + 2 u dsigma/du > 0), as the reflection solves
// assume: sampled from the axis to the point seen at m_max.
bool ConvexProfile(const SensorParams<double>& p, double m_max) {
  double s_edge, z_edge;
  if (!MirrorHit(p, m_max * (1.0 - 1e-9), &s_edge, &z_edge)) return false;
  const int n = 200;
  for (int i = 0; i <= n; ++i) {
    const double s = s_edge * i / n, u = s * s;
    double w = 0.0, sigma = 0.0;
    if (!detail::AsphereSag(p, u, &w, &sigma)) return false;
    if (!(sigma + 2.0 * u * detail::AsphereDsigmaDu(p, u) > 0.0) || !(w >= 0.0)) return false;
  }
  return true;
}

// The unified profile's own parameters: xi within what a real camera has
// (0 a pinhole, 1 a parabolic mirror; beyond a few the image disc shrinks
// to nothing), no mirror terms.
template <typename Fail>
void CheckUnified(const SensorParams<double>& p, const Fail& fail) {
  if (!(p.xi >= 0.0 && p.xi <= 10.0)) fail("xi", "expected 0 <= xi <= 10");
  if (p.curvature_radius != 0.0 || p.conic_constant != 0.0 || p.vertex_distance != 0.0 || p.asphere_a4 != 0.0 ||
      p.asphere_a6 != 0.0)
    fail("curvature_radius/conic_constant/vertex_distance", "the unified profile has no mirror terms");
}

}  // namespace

void Sensor::Check(const std::string& what) const {
  auto fail = [&](const std::string& key, const std::string& problem) {
    throw Error(what + ": " + key + ": " + problem);
  };
  const SensorParams<double>& p = params;
  const double vals[] = {p.focal_px, p.cx, p.cy, p.aspect, p.azimuth_offset, p.k1, p.k2,
                         p.curvature_radius, p.conic_constant, p.vertex_distance, p.rim_radius,
                         p.asphere_a4, p.asphere_a6, p.xi};
  for (double v : vals)
    if (!std::isfinite(v)) fail("parameters", "not a finite number (NaN or infinity)");
  if (image_width <= 0 || image_height <= 0)
    fail("image_width/image_height", "expected positive integers");
  // The principal point, where the mirror's axis meets the image, lies in
  // the image (which spans -0.5 to size - 0.5 around the pixel centres): a
  // value beyond it is a typo, which later fails as a calibration that
  // tracks nothing, with no parameter named.
  auto check_centre = [&](double c, int size, const std::string& key) {
    if (c >= -0.5 && c <= size - 0.5) return;
    char text[96];
    std::snprintf(text, sizeof(text), "expected the principal point inside the image (-0.5 to %g px), got %g",
                  size - 0.5, c);
    fail(key, text);
  };
  check_centre(p.cx, image_width, "cx");
  check_centre(p.cy, image_height, "cy");
  if (!(p.focal_px > 0.0)) fail("focal_px", "expected a positive focal length in pixels");
  if (!(p.aspect > 0.0)) fail("aspect", "expected a positive aspect ratio");
  if (p.unified != (model == MirrorModel::kUnified))
    fail("model", "internal: the parameters' profile does not match the model");
  if (p.unified) {
    CheckUnified(p, fail);
  } else if (!(p.curvature_radius > 0.0)) {
    fail(model == MirrorModel::kSphere ? "mirror_radius" : "curvature_radius",
         "expected a positive mirror radius");
  } else if (!(p.vertex_distance > 0.0)) {
    fail(model == MirrorModel::kSphere ? "mirror_distance" : "vertex_distance",
         model == MirrorModel::kSphere
             ? "expected mirror_distance > mirror_radius (the mirror must not reach the pinhole)"
             : "expected the mirror's vertex above the pinhole");
  }
  const RigFaults<double>& f = faults;
  const double fault_vals[] = {f.mirror_offset[0], f.mirror_offset[1], f.camera_tilt[0], f.camera_tilt[1],
                               f.p1, f.p2, f.k3, f.sensor_tilt[0], f.sensor_tilt[1], f.skew};
  for (double v : fault_vals)
    if (!std::isfinite(v)) fail("faults", "not a finite number (NaN or infinity)");
  const double kMaxTilt = 0.5;  // radians: beyond it the model of a small fault no longer describes the rig
  for (int i = 0; i < 2; ++i) {
    if (!(std::abs(f.camera_tilt[i]) <= kMaxTilt)) fail("camera_tilt", "expected angles within +-0.5 rad (28.6 degrees)");
    if (!(std::abs(f.sensor_tilt[i]) <= kMaxTilt)) fail("sensor_tilt", "expected angles within +-0.5 rad (28.6 degrees)");
  }
  // A shear of a tenth of the focal length is far past any sensor's.
  if (!(std::abs(f.skew) <= 0.1 * std::abs(p.focal_px)))
    fail("skew", "expected a shear within a tenth of focal_px");
  if (!p.unified && !(std::hypot(f.mirror_offset[0], f.mirror_offset[1]) < p.curvature_radius))
    fail("mirror_offset", "expected an offset smaller than the mirror's radius");
  if (p.rim_radius < 0.0) fail("rim_radius", "expected a non-negative rim radius");
  if (model != MirrorModel::kAsphere && (p.asphere_a4 != 0.0 || p.asphere_a6 != 0.0))
    fail("asphere_a4/asphere_a6", "even-asphere terms need model asphere");
  const double m_max = MaxNormalizedRadius(p);
  if (!std::isfinite(m_max) || !(m_max > 0.0))
    fail("rim_radius", p.unified ? "the unified profile sees to infinity; give its rim_radius (a normalised radius)"
                                 : "the mirror has no limb; give its rim_radius");
  if (!IsConicProfile(p) && !ConvexProfile(p, m_max))
    fail("asphere_a4/asphere_a6", "the mirror's profile is not convex where the camera sees it");
}

bool Sensor::project(const Eigen::Vector3d& ps, Eigen::Vector2d* pixel) const {
  double u, v;
  if (aligned()) {
    if (!pano::project(params, ps.data(), &u, &v)) return false;
  } else if (!pano::ProjectGeneral(general(), ps.data(), &u, &v)) {
    return false;
  }
  *pixel = {u, v};
  return true;
}

bool Sensor::backproject(const Eigen::Vector2d& pixel, Eigen::Vector3d* origin,
                         Eigen::Vector3d* direction) const {
  if (aligned()) return pano::backproject(params, pixel.x(), pixel.y(), origin->data(), direction->data());
  return pano::BackprojectGeneral(general(), pixel.x(), pixel.y(), origin->data(), direction->data());
}

bool Sensor::image_radius(double D, double Z, double* radius) const {
  return pano::ImageRadius(params, D, Z, radius);
}

bool Sensor::inverse_image_radius(double radius, double Z, double* D) const {
  return pano::InverseImageRadius(params, radius, Z, D);
}

void Sensor::to_polar(double u, double v, double* radius, double* azimuth) const {
  const double du = u - params.cx, dv = (v - params.cy) / params.aspect;
  *radius = std::sqrt(du * du + dv * dv);
  *azimuth = FastAtan2(dv, du);
}

Eigen::Vector2d Sensor::from_polar(double radius, double azimuth) const {
  return {params.cx + radius * std::cos(azimuth),
          params.cy + params.aspect * radius * std::sin(azimuth)};
}

bool Sensor::inside_image(const Eigen::Vector2d& px, double margin) const {
  return px.x() >= -0.5 + margin && px.y() >= -0.5 + margin &&
         px.x() <= image_width - 0.5 - margin && px.y() <= image_height - 0.5 - margin;
}

Sensor MakeSphereSensor(int width, int height, double focal_px, double cx, double cy,
                        double aspect, double mirror_radius, double mirror_distance,
                        double azimuth_offset) {
  Sensor s;
  s.model = MirrorModel::kSphere;
  s.image_width = width;
  s.image_height = height;
  s.params.focal_px = focal_px;
  s.params.cx = cx;
  s.params.cy = cy;
  s.params.aspect = aspect;
  s.params.azimuth_offset = azimuth_offset;
  SetSphereMirror(&s.params, mirror_radius, mirror_distance);
  return s;
}

Sensor ScaledSensor(const Sensor& sensor, double scale) {
  const int w = static_cast<int>(std::lround(sensor.image_width * scale));
  const int h = static_cast<int>(std::lround(sensor.image_height * scale));
  if (!(scale > 0) || w < 1 || h < 1) throw Error("scale " + std::to_string(scale) + ": no pixel left");
  const double sx = static_cast<double>(w) / sensor.image_width, sy = static_cast<double>(h) / sensor.image_height;
  Sensor out = sensor;
  out.image_width = w;
  out.image_height = h;
  out.params.focal_px = sensor.params.focal_px * sx;
  out.params.aspect = sensor.params.aspect * sy / sx;
  out.params.cx = (sensor.params.cx + 0.5) * sx - 0.5;
  out.params.cy = (sensor.params.cy + 0.5) * sy - 0.5;
  out.faults.skew = sensor.faults.skew * sx;
  return out;
}

}  // namespace pano

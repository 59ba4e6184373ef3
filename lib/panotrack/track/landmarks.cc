#include "panotrack/track/landmarks.h"

#include <algorithm>
#include <cmath>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"

namespace pano {

void PredictionOptions::Check() const {
  if (!(min_radius_fraction >= 0.0 && min_radius_fraction < 1.0))
    throw Error("prediction: min_radius_fraction: expected 0..1");
  if (!(max_radius_margin >= 0.0) || !(image_margin >= 0.0) || !(min_edge_px > 0.0))
    throw Error("prediction: margins: expected non-negative values");
  if (!(min_contrast >= 0.0)) throw Error("prediction: min_contrast: expected >= 0");
}

std::vector<Landmark> LandmarksFromMap(const Map& map) {
  std::vector<Landmark> out;
  int object = 0;
  for (const MapRectangle& r : map.rectangles) {
    const Eigen::Vector3d fb(r.from.x(), r.from.y(), r.z0), ft(r.from.x(), r.from.y(), r.z1);
    const Eigen::Vector3d tb(r.to.x(), r.to.y(), r.z0), tt(r.to.x(), r.to.y(), r.z1);
    auto add = [&](const char* name, const Eigen::Vector3d& c, const Eigen::Vector3d& h,
                   const Eigen::Vector3d& v) {
      Landmark l;
      l.id = r.id + "/" + name;
      l.corner = c;
      l.h_end = h;
      l.v_end = v;
      l.shade = r.shade;
      l.object = object;
      out.push_back(l);
    };
    add("from-bottom", fb, tb, ft);
    add("from-top", ft, tt, fb);
    add("to-bottom", tb, fb, tt);
    add("to-top", tt, ft, tb);
    ++object;
  }
  for (const MapBox& b : map.boxes) {
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j)
        for (int k = 0; k < 2; ++k)
          for (int axis = 0; axis < 2; ++axis) {
            const double x = i ? b.max.x() : b.min.x(), y = j ? b.max.y() : b.min.y();
            const double z = k ? b.max.z() : b.min.z(), z_other = k ? b.min.z() : b.max.z();
            Landmark l;
            l.box = true;
            l.shade = b.shade;
            l.object = object;
            l.corner = {x, y, z};
            l.v_end = {x, y, z_other};
            const Eigen::Vector2d nx(i ? 1.0 : -1.0, 0.0), ny(0.0, j ? 1.0 : -1.0);
            if (axis == 0) {  // horizontal edge along x, on the face y = const
              l.h_end = {i ? b.min.x() : b.max.x(), y, z};
              l.face_normal = ny;
              l.other_face_normal = nx;
            } else {
              l.h_end = {x, j ? b.min.y() : b.max.y(), z};
              l.face_normal = nx;
              l.other_face_normal = ny;
            }
            l.id = b.id + "/" + (i ? "x1" : "x0") + (j ? "y1" : "y0") + (k ? "-top" : "-bottom") +
                   (axis == 0 ? "-x" : "-y");
            out.push_back(l);
          }
    ++object;
  }
  return out;
}

namespace {

int Sign(double v) { return v > 0 ? 1 : (v < 0 ? -1 : 0); }

// Shade seen (map reflectance) looking from `eye` at world point `target`,
// a little beyond the landmark's face.
double ShadeTowards(const Scene& scene, const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d d = target - eye;
  const RayHit hit = scene.Intersect(eye, d.normalized());
  return hit.hit() ? hit.shade : 0.0;
}

}  // namespace

std::vector<PredictedLandmark> PredictLandmarks(const std::vector<Landmark>& landmarks,
                                                const Map& map, const Scene& scene,
                                                const Sensor& sensor, const RadiusTable& table,
                                                const Pose2& pose, const PredictionOptions& opt) {
  std::vector<PredictedLandmark> out;
  out.reserve(landmarks.size());
  const double limb = sensor.limb_radius();
  const double r_lo = opt.min_radius_fraction * limb, r_hi = limb - opt.max_radius_margin;
  // The mirror's vertex approximates where the scene is seen from.
  const Eigen::Vector3d eye(pose.x, pose.y, map.sensor_height + sensor.params.vertex_distance);
  const Eigen::Vector2d cam(pose.x, pose.y);
  for (size_t idx = 0; idx < landmarks.size(); ++idx) {
    const Landmark& l = landmarks[idx];
    if (l.box) {
      const Eigen::Vector2d to_cam = cam - l.corner.head<2>();
      if (!(to_cam.dot(l.face_normal) > 0.0) || to_cam.dot(l.other_face_normal) > 0.0) continue;
    }
    PredictedLandmark p;
    p.index = static_cast<int>(idx);
    p.landmark = &l;
    const Eigen::Vector3d c = sensor_from_world(pose, map.sensor_height, l.corner);
    const Eigen::Vector3d h = sensor_from_world(pose, map.sensor_height, l.h_end);
    const Eigen::Vector3d v = sensor_from_world(pose, map.sensor_height, l.v_end);
    p.distance = c.head<2>().norm();
    if (!(p.distance > 0.0) || !table.radius(p.distance, c.z(), &p.corner_radius)) continue;
    if (p.corner_radius < r_lo || p.corner_radius > r_hi) continue;
    p.azimuth = sensor.image_azimuth(std::atan2(c.y(), c.x()));
    p.corner_px = sensor.from_polar(p.corner_radius, p.azimuth);
    if (!sensor.inside_image(p.corner_px, opt.image_margin)) continue;
    const double dist3 = (l.corner - eye).norm();
    if (scene.Occluded(eye, l.corner, 1e-3 * dist3 + 1e-6)) continue;
    // Vertical edge: radial, from the corner to the other end (clamped to the
    // usable annulus).
    double rv;
    if (!table.radius(p.distance, v.z(), &rv)) rv = v.z() > c.z() ? r_hi : r_lo;
    p.v_radius = std::clamp(rv, r_lo, r_hi);
    if (std::abs(p.v_radius - p.corner_radius) < opt.min_edge_px) continue;
    // Horizontal edge: its line's closest point to the axis (Eqn 4).
    const Eigen::Vector2d c2 = c.head<2>(), dir = (h - c).head<2>();
    const double len2 = dir.squaredNorm();
    if (!(len2 > 0.0)) continue;
    const Eigen::Vector2d foot = c2 - (c2.dot(dir) / len2) * dir;
    const double d_main = foot.norm();
    p.h_height = c.z();
    if (!(d_main > 0.0) || !table.radius(d_main, p.h_height, &p.r_main)) continue;
    p.theta_main = sensor.image_azimuth(std::atan2(foot.y(), foot.x()));
    p.h_end_azimuth = sensor.image_azimuth(std::atan2(h.y(), h.x()));
    const double dtheta_edge = wrap_angle(p.h_end_azimuth - p.azimuth);
    if (std::abs(dtheta_edge) * p.corner_radius < opt.min_edge_px) continue;
    p.inside_azimuth_sign = dtheta_edge > 0 ? 1 : -1;
    p.inside_radius_sign = v.z() > c.z() ? 1 : -1;
    // Expected polarities from the map: the landmark's shade against what
    // lies just beyond each edge.
    const double eps = std::max(0.01 * dist3, 0.5);
    const Eigen::Vector3d out_h = (l.corner - l.h_end).normalized();
    const Eigen::Vector3d out_v = (l.corner - l.v_end).normalized();
    const double beyond_v = ShadeTowards(scene, eye, l.corner + eps * out_h + 0.5 * (l.v_end - l.corner));
    const double beyond_h = ShadeTowards(scene, eye, l.corner + eps * out_v + 0.5 * (l.h_end - l.corner));
    // An unknown shade (NaN) on either side: either polarity (0); known
    // shades without contrast: not a usable edge.
    const double dv = l.shade - beyond_v, dh = l.shade - beyond_h;
    if (std::abs(dv) < opt.min_contrast || std::abs(dh) < opt.min_contrast) continue;
    p.v_polarity = p.map_v_polarity = std::isnan(dv) ? 0 : Sign(dv);
    p.h_polarity = p.map_h_polarity = std::isnan(dh) ? 0 : Sign(dh);
    out.push_back(p);
  }
  return out;
}

void SetImageMotion(const Map& map, const Sensor& sensor, const RadiusTable& table,
                    const Pose2& previous, double fraction, std::vector<PredictedLandmark>* predicted) {
  for (PredictedLandmark& p : *predicted) {
    const Eigen::Vector3d c = sensor_from_world(previous, map.sensor_height, p.landmark->corner);
    const double azimuth = sensor.image_azimuth(std::atan2(c.y(), c.x()));
    double radius;
    if (!table.radius(c.head<2>().norm(), c.z(), &radius)) radius = p.corner_radius;
    p.full_tangential_motion_px = std::abs(wrap_angle(p.azimuth - azimuth)) * p.corner_radius;
    p.tangential_motion_px = fraction * p.full_tangential_motion_px;
    p.radial_motion_px = fraction * std::abs(p.corner_radius - radius);
  }
}

std::vector<PredictedLandmark> SelectSpread(std::vector<PredictedLandmark> all, int max_count) {
  if (max_count <= 0 || static_cast<int>(all.size()) <= max_count) return all;
  // Nearest first: a near landmark pins the position down most.
  std::stable_sort(all.begin(), all.end(), [](const PredictedLandmark& a, const PredictedLandmark& b) {
    return a.distance < b.distance;
  });
  std::vector<PredictedLandmark> out;
  std::vector<char> taken(all.size(), 0), sector_used(max_count, 0);
  for (size_t i = 0; i < all.size(); ++i) {
    int sector = static_cast<int>((all[i].azimuth + M_PI) / (2 * M_PI) * max_count);
    sector = std::clamp(sector, 0, max_count - 1);
    if (sector_used[sector]) continue;
    sector_used[sector] = 1;
    taken[i] = 1;
    out.push_back(all[i]);
  }
  for (size_t i = 0; i < all.size() && static_cast<int>(out.size()) < max_count; ++i)
    if (!taken[i]) {
      taken[i] = 1;
      out.push_back(all[i]);
    }
  // The rest follow, nearest first: the caller tracks them only if needed.
  for (size_t i = 0; i < all.size(); ++i)
    if (!taken[i]) out.push_back(all[i]);
  return out;
}

}  // namespace pano

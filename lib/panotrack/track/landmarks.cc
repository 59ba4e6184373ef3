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
  if (!(surface_tolerance >= 0.0) || !std::isfinite(surface_tolerance))
    throw Error("prediction: surface_tolerance: expected a length >= 0");
  if (!(min_distance_mirrors >= 0.0) || !std::isfinite(min_distance_mirrors))
    throw Error("prediction: min_distance_mirrors: expected >= 0");
  if (!(min_line_distance_mirrors >= 0.0) || !std::isfinite(min_line_distance_mirrors))
    throw Error("prediction: min_line_distance_mirrors: expected >= 0");
  if (!(spread_line_distance_mirrors >= 0.0) || !std::isfinite(spread_line_distance_mirrors))
    throw Error("prediction: spread_line_distance_mirrors: expected >= 0");
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
      l.survey_sigma = map.RectangleSurveySigma(static_cast<size_t>(object));
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
            l.survey_sigma = map.BoxSurveySigma(static_cast<size_t>(object) - map.rectangles.size());
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

// The point nearest the origin on the line through `point` along `dir`
// (not zero): a horizontal edge's D_main foot (Eqn 4) seen from the axis.
Eigen::Vector2d LineFoot(const Eigen::Vector2d& point, const Eigen::Vector2d& dir) {
  return point - (point.dot(dir) / dir.squaredNorm()) * dir;
}

// Shade seen (map reflectance) looking from `eye` at world point `target`,
// a little beyond the landmark's face.
double ShadeTowards(const Scene& scene, const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d d = target - eye;
  const RayHit hit = scene.Intersect(eye, d.normalized());
  return hit.hit() ? hit.shade : 0.0;
}

}  // namespace

internal::PredictionContext::PredictionContext(const Map& map, const Sensor& sensor, const Pose2& pose,
                                               const PredictionOptions& opt)
    : eye(pose.x, pose.y, map.sensor_height + sensor.params.vertex_distance),
      cam(pose.x, pose.y),
      cos_sin(std::cos(pose.theta), std::sin(pose.theta)) {
  const double limb = sensor.limb_radius();
  r_lo = opt.min_radius_fraction * limb;
  r_hi = limb - opt.max_radius_margin;
}

namespace {

using internal::PredictionContext;

// The geometry in two steps: where the corner lies (its distance and
// azimuth; a box's corner seen from behind its faces fails) ...
bool PredictPlacement(const Landmark& l, int idx, const Map& map, const Sensor& sensor, const Pose2& pose,
                      const PredictionContext& ctx, PredictedLandmark* out) {
  if (l.box) {
    const Eigen::Vector2d to_cam = ctx.cam - l.corner.head<2>();
    if (!(to_cam.dot(l.face_normal) > 0.0) || to_cam.dot(l.other_face_normal) > 0.0) return false;
  }
  PredictedLandmark& p = *out;
  p.index = idx;
  p.landmark = &l;
  const Eigen::Vector3d c = SensorFromWorld(pose, ctx.cos_sin, map.sensor_height, l.corner);
  p.distance = c.head<2>().norm();
  if (!(p.distance > 0.0)) return false;
  p.azimuth = sensor.image_azimuth(FastAtan2(c.y(), c.x()));
  return true;
}

// ... then its image (the table's radii, inside the annulus and the image,
// both edges long enough), after PredictPlacement.
bool PredictImage(const Map& map, const Sensor& sensor, const RadiusTable& table, const Pose2& pose,
                  const PredictionOptions& opt, const PredictionContext& ctx, PredictedLandmark* out) {
  PredictedLandmark& p = *out;
  const Landmark& l = *p.landmark;
  const Eigen::Vector3d c = SensorFromWorld(pose, ctx.cos_sin, map.sensor_height, l.corner);
  const Eigen::Vector3d h = SensorFromWorld(pose, ctx.cos_sin, map.sensor_height, l.h_end);
  const Eigen::Vector3d v = SensorFromWorld(pose, ctx.cos_sin, map.sensor_height, l.v_end);
  if (p.distance < opt.min_distance_mirrors * sensor.mirror_distance()) return false;
  if (!table.radius(p.distance, c.z(), &p.corner_radius)) return false;
  if (p.corner_radius < ctx.r_lo || p.corner_radius > ctx.r_hi) return false;
  p.corner_px = sensor.from_polar(p.corner_radius, p.azimuth);
  if (!sensor.inside_image(p.corner_px, opt.image_margin)) return false;
  // Vertical edge: radial, from the corner to the other end (clamped to the
  // usable annulus).
  double rv;
  if (!table.radius(p.distance, v.z(), &rv)) rv = v.z() > c.z() ? ctx.r_hi : ctx.r_lo;
  p.v_radius = std::clamp(rv, ctx.r_lo, ctx.r_hi);
  if (std::abs(p.v_radius - p.corner_radius) < opt.min_edge_px) return false;
  // Horizontal edge: its line's closest point to the axis (Eqn 4).
  const Eigen::Vector2d c2 = c.head<2>(), dir = (h - c).head<2>();
  if (!(dir.squaredNorm() > 0.0)) return false;
  const Eigen::Vector2d foot = LineFoot(c2, dir);
  const double d_main = foot.norm();
  p.h_height = c.z();
  if (!(d_main > 0.0) || d_main < opt.min_line_distance_mirrors * sensor.mirror_distance() ||
      !table.radius(d_main, p.h_height, &p.r_main))
    return false;
  p.theta_main = sensor.image_azimuth(FastAtan2(foot.y(), foot.x()));
  p.h_end_azimuth = sensor.image_azimuth(FastAtan2(h.y(), h.x()));
  const double dtheta_edge = WrapAngle(p.h_end_azimuth - p.azimuth);
  if (std::abs(dtheta_edge) * p.corner_radius < opt.min_edge_px) return false;
  p.inside_azimuth_sign = dtheta_edge > 0 ? 1 : -1;
  p.inside_radius_sign = v.z() > c.z() ? 1 : -1;
  return true;
}

bool PredictGeometry(const Landmark& l, int idx, const Map& map, const Sensor& sensor, const RadiusTable& table,
                     const Pose2& pose, const PredictionOptions& opt, const PredictionContext& ctx,
                     PredictedLandmark* out) {
  return PredictPlacement(l, idx, map, sensor, pose, ctx, out) &&
         PredictImage(map, sensor, table, pose, opt, ctx, out);
}

// ... and the scene's ray casts (most of the cost): not hidden by map
// surfaces, and the polarities from the shades beyond each edge.
bool PredictVisibility(const Scene& scene, const PredictionOptions& opt, const Eigen::Vector3d& eye,
                       PredictedLandmark* p) {
  const Landmark& l = *p->landmark;
  const double dist3 = (l.corner - eye).norm();
  if (scene.Occluded(eye, l.corner, 1e-3 * dist3 + 1e-6, opt.surface_tolerance)) return false;
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
  if (std::abs(dv) < opt.min_contrast || std::abs(dh) < opt.min_contrast) return false;
  p->v_polarity = p->map_v_polarity = std::isnan(dv) ? 0 : Sign(dv);
  p->h_polarity = p->map_h_polarity = std::isnan(dh) ? 0 : Sign(dh);
  return true;
}

// SelectSpread's azimuth sector.
int SpreadSector(const PredictedLandmark& p, int max_count) {
  const int sector = static_cast<int>((p.azimuth + M_PI) / (2 * M_PI) * max_count);
  return std::clamp(sector, 0, max_count - 1);
}

}  // namespace

std::vector<PredictedLandmark> PredictLandmarks(const std::vector<Landmark>& landmarks,
                                                const Map& map, const Scene& scene,
                                                const Sensor& sensor, const RadiusTable& table,
                                                const Pose2& pose, const PredictionOptions& opt,
                                                const WantedLandmark& wanted) {
  std::vector<PredictedLandmark> out;
  out.reserve(landmarks.size());
  const PredictionContext ctx(map, sensor, pose, opt);
  for (size_t idx = 0; idx < landmarks.size(); ++idx) {
    PredictedLandmark p;
    if (PredictGeometry(landmarks[idx], static_cast<int>(idx), map, sensor, table, pose, opt, ctx, &p) &&
        (!wanted || wanted(p, out)) && PredictVisibility(scene, opt, ctx.eye, &p))
      out.push_back(p);
  }
  return out;
}

SpreadPrediction::SpreadPrediction(const std::vector<Landmark>& landmarks, const Map& map, const Scene& scene,
                                   const Sensor& sensor, const RadiusTable& table, const Pose2& pose,
                                   const PredictionOptions& opt, int max_count, int partners)
    : map_(map),
      scene_(scene),
      sensor_(sensor),
      table_(table),
      pose_(pose),
      opt_(opt),
      max_count_(max_count),
      ctx_(map, sensor, pose, opt) {
  // Where each corner lies, for the order; the rest of its geometry (table
  // look-ups scattered through memory) only for those that Visible tests.
  candidates_.reserve(landmarks.size());
  for (size_t idx = 0; idx < landmarks.size(); ++idx) {
    PredictedLandmark p;
    if (PredictPlacement(landmarks[idx], static_cast<int>(idx), map, sensor, pose, ctx_, &p)) candidates_.push_back(p);
  }
  state_.assign(candidates_.size(), kUnknown);
  if (max_count_ <= 0) return;
  // SelectSpread's order: nearest first (ties in landmark order), then one
  // per sector; a landmark the scene rules out simply does not take part.
  by_distance_.resize(candidates_.size());
  for (size_t i = 0; i < by_distance_.size(); ++i) by_distance_[i] = static_cast<int>(i);
  std::stable_sort(by_distance_.begin(), by_distance_.end(),
                   [&](int a, int b) { return candidates_[a].distance < candidates_[b].distance; });
  taken_.assign(candidates_.size(), 0);
  std::vector<char> sector_used(static_cast<size_t>(max_count_), 0);
  near_line_.resize(candidates_.size());
  for (size_t i = 0; i < candidates_.size(); ++i) {
    // The horizontal distance to the line of the horizontal edge (D_main).
    const Landmark& l = *candidates_[i].landmark;
    const Eigen::Vector2d dir = (l.h_end - l.corner).head<2>();
    near_line_[i] = dir.squaredNorm() > 0.0 && LineFoot(l.corner.head<2>() - ctx_.cam, dir).norm() <
                                                   opt_.spread_line_distance_mirrors * sensor_.mirror_distance();
  }
  for (int i : by_distance_) {
    if (NearLine(i)) {
      if (Visible(i)) near_lines_.push_back(i);
      continue;
    }
    const int sector = SpreadSector(candidates_[i], max_count_);
    if (sector_used[sector] || !Visible(i)) continue;
    sector_used[sector] = 1;
    taken_[i] = 1;
    spread_.push_back(i);
  }
  for (size_t k = 0; k < by_distance_.size() && static_cast<int>(spread_.size()) < max_count_; ++k) {
    const int i = by_distance_[k];
    if (!taken_[i] && !NearLine(i) && Visible(i)) {
      taken_[i] = 1;
      spread_.push_back(i);
    }
  }
  // More than max_count visible: the spread order; else (all of them seen by
  // now) landmark order, as SelectSpread leaves a short list.
  more_ = false;
  if (static_cast<int>(spread_.size()) == max_count_)
    for (int i : by_distance_)
      if (!taken_[i] && !NearLine(i) && Visible(i)) {
        more_ = true;
        break;
      }
  if (!more_) near_lines_.clear();  // First() holds them
  if (more_ && partners > 0) FindPartners(partners);
}

void SpreadPrediction::FindPartners(int partners) {
  std::vector<int> chosen = spread_;
  std::stable_sort(chosen.begin(), chosen.end(),
                   [&](int a, int b) { return candidates_[a].distance < candidates_[b].distance; });
  for (int i : chosen) {
    if (static_cast<int>(partners_.size()) == partners) break;
    // The other end of its vertical edge (not a corner of another rectangle
    // at the same place, whose bearing error is not independent).
    const Eigen::Vector3d& other_end = candidates_[i].landmark->v_end;
    for (int j : by_distance_) {
      if (taken_[j] || (candidates_[j].landmark->corner - other_end).squaredNorm() >= 1e-12) continue;
      if (std::find(partners_.begin(), partners_.end(), j) != partners_.end() || !Visible(j)) continue;
      partners_.push_back(j);
      break;
    }
  }
}

std::vector<PredictedLandmark> SpreadPrediction::Partners() const {
  std::vector<PredictedLandmark> out;
  for (int i : partners_) out.push_back(candidates_[i]);
  return out;
}

bool SpreadPrediction::Visible(int i) {
  if (state_[i] == kUnknown) {
    PredictedLandmark& p = candidates_[i];
    state_[i] = PredictImage(map_, sensor_, table_, pose_, opt_, ctx_, &p) && PredictVisibility(scene_, opt_, ctx_.eye, &p)
                    ? kVisible
                    : kHidden;
  }
  return state_[i] == kVisible;
}

std::vector<PredictedLandmark> SpreadPrediction::First() {
  std::vector<PredictedLandmark> out;
  if (max_count_ > 0 && more_) {
    for (int i : spread_) out.push_back(candidates_[i]);
    return out;
  }
  // The whole list, in landmark order (every candidate has been tested by
  // now when max_count > 0).
  for (size_t i = 0; i < candidates_.size(); ++i)
    if (Visible(static_cast<int>(i))) out.push_back(candidates_[i]);
  return out;
}

std::vector<PredictedLandmark> SpreadPrediction::Rest() {
  std::vector<PredictedLandmark> out;
  if (max_count_ <= 0 || !more_) return out;
  for (int i : by_distance_)
    if (!taken_[i] && !NearLine(i) && Visible(i)) out.push_back(candidates_[i]);
  return out;
}

std::vector<PredictedLandmark> SpreadPrediction::NearLines() const {
  std::vector<PredictedLandmark> out;
  for (int i : near_lines_) out.push_back(candidates_[i]);
  return out;
}

void SetImageMotion(const Map& map, const Sensor& sensor, const RadiusTable& table,
                    const Pose2& previous, double fraction, std::vector<PredictedLandmark>* predicted) {
  for (PredictedLandmark& p : *predicted) {
    const Eigen::Vector3d c = SensorFromWorld(previous, map.sensor_height, p.landmark->corner);
    const double azimuth = sensor.image_azimuth(FastAtan2(c.y(), c.x()));
    double radius;
    if (!table.radius(c.head<2>().norm(), c.z(), &radius)) radius = p.corner_radius;
    p.full_tangential_motion_px = std::abs(WrapAngle(p.azimuth - azimuth)) * p.corner_radius;
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
    const int sector = SpreadSector(all[i], max_count);
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

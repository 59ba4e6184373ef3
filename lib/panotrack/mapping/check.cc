#include "panotrack/mapping/check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/pose/triangulate.h"
#include "panotrack/track/edge_profile.h"

namespace pano {

void MapCheckOptions::Check() const {
  prediction.Check();
  if (!(search_px > 0) || !(min_window_px > 0) || !(sample_spacing_px > 0) || !(corner_gap_px >= 0) || max_samples < 3)
    throw Error("map check: search_px, sample spacing and max_samples (>= 3) must be positive");
  if (!(min_step > 0)) throw Error("map check: min_step: expected > 0 grey levels");
  if (!(min_sample_fraction > 0 && min_sample_fraction <= 1))
    throw Error("map check: min_sample_fraction: expected 0..1");
  if (min_visible_frames < 1 || min_found_frames_for_bias < 2)
    throw Error("map check: min_visible_frames >= 1 and min_found_frames_for_bias >= 2 expected");
  if (!(min_found_fraction >= 0 && min_found_fraction <= 1) ||
      !(min_polarity_agreement >= 0 && min_polarity_agreement <= 1))
    throw Error("map check: min_found_fraction and min_polarity_agreement: expected 0..1");
  if (!(bias_sigmas > 0) || !(bias_floor_deg >= 0) || !(hold_out_outlier > 0) || !(bias_survey_sigmas >= 0))
    throw Error("map check: bias_sigmas, hold_out_outlier (> 0), bias_floor_deg and bias_survey_sigmas (>= 0) "
                "expected");
  unmapped.Check();
}

const char* MapFindingName(MapFinding f) {
  switch (f) {
    case MapFinding::kNeverFound: return "never found";
    case MapFinding::kWrongPolarity: return "wrong polarity";
    case MapFinding::kBiased: return "biased";
    case MapFinding::kNotInMap: return "not in map";
  }
  return "?";
}

namespace {

// A corner within three of the map's survey sigmas of a wall (behind it,
// as measured) is not hidden by that wall.
double OnSurfaceTolerance(const Map& map) {
  return std::isfinite(map.survey_sigma) ? 3.0 * map.survey_sigma : 0.0;
}

constexpr double kDeg = 180.0 / M_PI;
constexpr double kSampleStep = 0.5;  // px between the points of a linear sample

// The edge a landmark's vertical edge belongs to: "<object>/<end>", the
// landmark id up to the corner's height ("door/from-bottom" -> "door/from",
// "crate/x0y1-top-x" -> "crate/x0y1").
std::string EdgeKey(const std::string& landmark_id) {
  const size_t slash = landmark_id.rfind('/');
  const size_t dash = landmark_id.find('-', slash == std::string::npos ? 0 : slash);
  return landmark_id.substr(0, dash);
}

struct Step {
  double offset_px = 0.0;  // from the centre of the sample, along it
  int polarity = 0;        // +1: brighter along the sample's direction
  Eigen::Vector2d px{0, 0};
  double before = 0.0, after = 0.0;  // mean grey at the sample's two ends
};

// The strongest step of either polarity on a linear sample through `centre`
// along `dir` (a unit of aspect-free image length), within `half` px of it.
bool StrongestStep(const cv::Mat& grey, const Eigen::Vector2d& centre, const Eigen::Vector2d& dir, double half,
                   double min_step, Step* out) {
  const double reach = half + 3.5;
  const int n = 2 * static_cast<int>(std::ceil(reach / kSampleStep)) + 1;
  if (n > 512) return false;
  const double half_n = (n - 1) / 2;
  const Eigen::Vector2d start = centre - half_n * kSampleStep * dir;
  float profile[512];
  if (!SampleLine(grey, start, kSampleStep * dir, n, profile)) return false;
  const int baseline = static_cast<int>(std::lround(2.0 / kSampleStep));
  StepEdge rise, fall;
  const bool has_rise = FindStep(profile, n, +1, baseline, min_step, &rise);
  const bool has_fall = FindStep(profile, n, -1, baseline, min_step, &fall);
  if (!has_rise && !has_fall) return false;
  const bool use_rise = has_rise && (!has_fall || std::abs(rise.strength) >= std::abs(fall.strength));
  const StepEdge& e = use_rise ? rise : fall;
  out->offset_px = (e.location - half_n) * kSampleStep;
  if (std::abs(out->offset_px) > half) return false;
  out->polarity = use_rise ? 1 : -1;
  out->px = start + e.location * kSampleStep * dir;
  out->before = (profile[0] + profile[1] + profile[2]) / 3.0;
  out->after = (profile[n - 1] + profile[n - 2] + profile[n - 3]) / 3.0;
  return true;
}

// The steps of one edge's samples that agree: the majority polarity, within
// 1.5 px of their median offset. Returns their indices (empty: not found).
std::vector<int> AgreeingSteps(const std::vector<Step>& steps, int attempted, double min_fraction,
                               int* polarity) {
  int balance = 0;
  for (const Step& s : steps) balance += s.polarity;
  *polarity = balance >= 0 ? 1 : -1;
  std::vector<double> offsets;
  for (const Step& s : steps)
    if (s.polarity == *polarity) offsets.push_back(s.offset_px);
  if (offsets.empty()) return {};
  std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
  const double median = offsets[offsets.size() / 2];
  std::vector<int> in;
  for (size_t i = 0; i < steps.size(); ++i)
    if (steps[i].polarity == *polarity && std::abs(steps[i].offset_px - median) <= 1.5)
      in.push_back(static_cast<int>(i));
  const int needed = std::max(3, static_cast<int>(std::ceil(min_fraction * attempted)));
  if (static_cast<int>(in.size()) < needed) return {};
  return in;
}

double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

std::vector<EdgeCheck> MapEdges(const std::vector<Landmark>& landmarks, std::vector<int>* edge_of_landmark) {
  std::vector<EdgeCheck> edges;
  std::map<std::string, int> index;
  edge_of_landmark->assign(landmarks.size(), -1);
  for (size_t i = 0; i < landmarks.size(); ++i) {
    const Landmark& l = landmarks[i];
    const std::string key = EdgeKey(l.id);
    auto it = index.find(key);
    if (it == index.end()) {
      EdgeCheck e;
      e.id = key;
      e.object = key.substr(0, key.rfind('/'));
      e.box = l.box;
      e.position = l.corner.head<2>();
      e.shade = l.shade;
      it = index.emplace(key, static_cast<int>(edges.size())).first;
      edges.push_back(e);
    }
    (*edge_of_landmark)[i] = it->second;
  }
  return edges;
}

FrameChecker::FrameChecker(const Calibration& calib, const Map& map, std::shared_ptr<const RadiusTable> table,
                           const MapCheckOptions& options)
    : calib_(calib), map_(map), scene_(Scene::FromMap(map, false)), table_(std::move(table)), opt_(options) {
  opt_.Check();
  landmarks_ = LandmarksFromMap(map_);
  edges_ = MapEdges(landmarks_, &edge_of_landmark_);
}

// Each vertical edge is searched no further than 0.45 of the way to the
// nearest other predicted vertical edge beside it: a window holding two
// edges (a rectangle seen at a grazing angle, two neighbours) measures
// whichever is stronger.
double FrameChecker::WindowPx(const PredictedLandmark& p, const std::vector<PredictedLandmark>& predicted) const {
  const int e = edge_of_landmark_[p.index];
  const double lo = std::min(p.corner_radius, p.v_radius), hi = std::max(p.corner_radius, p.v_radius);
  double half = opt_.search_px;
  for (const PredictedLandmark& q : predicted) {
    if (edge_of_landmark_[q.index] == e) continue;
    if (std::max(q.corner_radius, q.v_radius) < lo || std::min(q.corner_radius, q.v_radius) > hi) continue;
    half = std::min(half, 0.45 * std::abs(WrapAngle(q.azimuth - p.azimuth)) * p.corner_radius);
  }
  return half;
}

// Tangential samples along the vertical edge's radial segment, on the part
// of it the map leaves in sight, `half` px either side; false when fewer
// than 3 could be tried (too little of the edge in sight to judge it).
bool FrameChecker::MeasureVerticalEdge(const cv::Mat& grey, const Pose2& pose, const PredictedLandmark& p,
                                       double half, EdgeFrameMeasurement* m) const {
  const Sensor& s = calib_.sensor;
  const Landmark& l = *p.landmark;
  const Eigen::Vector3d eye(pose.x, pose.y, map_.sensor_height + s.params.vertex_distance);
  const Eigen::Vector3d c = SensorFromWorld(pose, map_.sensor_height, l.corner);
  const double len = std::abs(p.v_radius - p.corner_radius);
  const double spacing = std::max(opt_.sample_spacing_px, (len - 2 * opt_.corner_gap_px) / opt_.max_samples);
  const double cs = std::cos(p.azimuth), sn = std::sin(p.azimuth), a = s.params.aspect;
  const Eigen::Vector2d tangent(-sn, a * cs);
  std::vector<Step> steps;
  int attempted = 0;
  // Points of the edge in the world, `spacing` apart in the image, on
  // the part of it the map leaves in sight (a nearer surface may hide
  // part of an edge whose corner is seen).
  const Eigen::Vector3d v = SensorFromWorld(pose, map_.sensor_height, l.v_end);
  double last_r = p.corner_radius;
  constexpr int kHeights = 400;
  for (int k = 1; k < kHeights && attempted < opt_.max_samples; ++k) {
    const double f = double(k) / kHeights;
    double r;
    if (!table_->radius(p.distance, c.z() + f * (v.z() - c.z()), &r)) continue;
    if (std::abs(r - p.corner_radius) < opt_.corner_gap_px || std::abs(r - last_r) < spacing) continue;
    if ((r - p.v_radius) * (p.corner_radius - p.v_radius) <= 0 || std::abs(r - p.v_radius) < opt_.corner_gap_px)
      break;  // past the usable end of the edge
    last_r = r;
    if (scene_.Occluded(eye, l.corner + f * (l.v_end - l.corner), 1e-3 * (l.corner - eye).norm() + 1e-6,
                        OnSurfaceTolerance(map_)))
      continue;
    ++attempted;
    Step st;
    if (StrongestStep(grey, s.from_polar(r, p.azimuth), tangent, half, opt_.min_step, &st)) steps.push_back(st);
  }
  if (attempted < 3) return false;
  int polarity = 0;
  const std::vector<int> in = AgreeingSteps(steps, attempted, opt_.min_sample_fraction, &polarity);
  if (in.empty()) return true;
  m->found = true;
  m->measured_polarity = polarity * p.inside_azimuth_sign;
  double sum = 0.0;
  for (int i : in) {
    double r, az;
    s.to_polar(steps[i].px.x(), steps[i].px.y(), &r, &az);
    sum += WrapAngle(az - p.azimuth);
  }
  m->measured_azimuth = WrapAngle(p.azimuth + sum / in.size());
  // The face's brightness against what lies beyond, at both ends of
  // the samples (increasing azimuth is "after").
  std::vector<double> ratios;
  for (int i : in) {
    const double inside = p.inside_azimuth_sign > 0 ? steps[i].after : steps[i].before;
    const double outside = p.inside_azimuth_sign > 0 ? steps[i].before : steps[i].after;
    if (outside > 1.0) ratios.push_back(inside / outside);
  }
  if (!ratios.empty()) m->brightness_ratio = Median(ratios);
  return true;
}

// The horizontal edge at this corner: radial samples at azimuths along its
// nearer half, each centred on the edge's predicted radius there; its curve
// goes to m->h_curves. True with the median radial offset when enough agree.
bool FrameChecker::MeasureHorizontalEdge(const cv::Mat& grey, const Pose2& pose, const PredictedLandmark& p,
                                         EdgeFrameMeasurement* m, double* radial_offset) const {
  const Sensor& s = calib_.sensor;
  const Landmark& l = *p.landmark;
  const Eigen::Vector3d eye(pose.x, pose.y, map_.sensor_height + s.params.vertex_distance);
  const Eigen::Vector3d c = SensorFromWorld(pose, map_.sensor_height, l.corner);
  const Eigen::Vector3d h = SensorFromWorld(pose, map_.sensor_height, l.h_end);
  const Eigen::Vector3d dir = h - c;
  std::vector<Eigen::Vector2d> curve;
  for (int k = 0; k <= 16; ++k) {
    const Eigen::Vector3d q = c + (k / 16.0) * dir;
    double r;
    if (table_->radius(q.head<2>().norm(), q.z(), &r))
      curve.push_back(s.from_polar(r, s.image_azimuth(std::atan2(q.y(), q.x()))));
  }
  m->h_curves.push_back(curve);
  const double span = WrapAngle(p.h_end_azimuth - p.azimuth);
  const double step_angle = opt_.sample_spacing_px / p.corner_radius;
  const double gap_angle = opt_.corner_gap_px / p.corner_radius;
  std::vector<Step> steps;
  int attempted = 0;
  for (double da = gap_angle; da < 0.5 * std::abs(span) && attempted < opt_.max_samples; da += step_angle) {
    const double az = WrapAngle(p.azimuth + (span > 0 ? da : -da));
    const double b = s.bearing_of_azimuth(az);
    // The point of the edge's line on this bearing.
    const double den = dir.x() * std::sin(b) - dir.y() * std::cos(b);
    if (std::abs(den) < 1e-12) continue;
    const double t = (c.y() * std::cos(b) - c.x() * std::sin(b)) / den;
    const Eigen::Vector3d q = c + t * dir;
    double r;
    if (!table_->radius(q.head<2>().norm(), q.z(), &r)) continue;
    const Eigen::Vector3d world = l.corner + t * (l.h_end - l.corner);
    if (scene_.Occluded(eye, world, 1e-3 * (world - eye).norm() + 1e-6, OnSurfaceTolerance(map_))) continue;
    ++attempted;
    const double ca = std::cos(az), sa = std::sin(az);
    Step st;
    if (StrongestStep(grey, s.from_polar(r, az), Eigen::Vector2d(ca, s.params.aspect * sa), opt_.search_px,
                      opt_.min_step, &st))
      steps.push_back(st);
  }
  int polarity = 0;
  const std::vector<int> in = AgreeingSteps(steps, attempted, opt_.min_sample_fraction, &polarity);
  if (in.empty()) return false;
  std::vector<double> offsets;
  for (int i : in) offsets.push_back(steps[i].offset_px);
  *radial_offset = Median(offsets);
  return true;
}

FrameCheck FrameChecker::Measure(const cv::Mat& grey, int frame, const Pose2& pose) const {
  const Sensor& s = calib_.sensor;
  FrameCheck fc;
  fc.frame = frame;
  fc.has_pose = true;
  fc.pose = pose;
  const std::vector<PredictedLandmark> predicted =
      PredictLandmarks(landmarks_, map_, scene_, s, *table_, pose, opt_.prediction);
  // The mirror's vertex approximates where the scene is seen from (as in PredictLandmarks).
  const Eigen::Vector3d eye(pose.x, pose.y, map_.sensor_height + s.params.vertex_distance);
  std::vector<int> slot(edges_.size(), -1);  // this frame's measurement of each edge
  std::vector<std::vector<double>> radial(edges_.size());
  for (const PredictedLandmark& p : predicted) {
    const int e = edge_of_landmark_[p.index];
    const Landmark& l = *p.landmark;
    if (slot[e] < 0) {
      EdgeFrameMeasurement m;
      m.edge = e;
      m.landmark = p.index;
      m.expected_polarity = p.v_polarity;
      m.predicted_azimuth = p.azimuth;
      m.distance = p.distance;
      m.corner_px = p.corner_px;
      m.v_end_px = s.from_polar(p.v_radius, p.azimuth);
      {
        // What the map shows just beyond the vertical edge (as PredictLandmarks
        // judges its polarity), for the shade a wrong polarity suggests.
        const double dist3 = (l.corner - eye).norm();
        const Eigen::Vector3d target = l.corner + std::max(0.01 * dist3, 0.5) * (l.corner - l.h_end).normalized() +
                                       0.5 * (l.v_end - l.corner);
        const RayHit hit = scene_.Intersect(eye, (target - eye).normalized());
        m.beyond_shade = hit.hit() ? hit.shade : 0.0;
      }
      const double half = WindowPx(p, predicted);
      if (half < opt_.min_window_px) continue;  // too close to another edge to tell them apart
      if (!MeasureVerticalEdge(grey, pose, p, half, &m)) continue;
      slot[e] = static_cast<int>(fc.edges.size());
      fc.edges.push_back(m);
    }
    double offset;
    if (slot[e] >= 0 && MeasureHorizontalEdge(grey, pose, p, &fc.edges[slot[e]], &offset)) radial[e].push_back(offset);
  }
  for (EdgeFrameMeasurement& m : fc.edges)
    if (!radial[m.edge].empty()) {
      m.horizontal_found = true;
      m.radial_residual_px =
          std::accumulate(radial[m.edge].begin(), radial[m.edge].end(), 0.0) / radial[m.edge].size();
    }
  return fc;
}

void FrameChecker::SetResiduals(FrameCheck* fc) const {
  for (EdgeFrameMeasurement& m : fc->edges)
    if (m.found) {
      m.has_residual = true;
      m.bearing_residual = WrapAngle(m.measured_azimuth - m.predicted_azimuth);
    }
}

void FrameChecker::SetHeldOutResiduals(FrameCheck* fc) const {
  const Sensor& s = calib_.sensor;
  std::vector<BearingObservation> all;
  std::vector<const EdgeFrameMeasurement*> of;
  for (const EdgeFrameMeasurement& m : fc->edges)
    if (m.found) {
      BearingObservation o;
      o.landmark = edges_[m.edge].position;
      o.bearing = s.bearing_of_azimuth(m.measured_azimuth);
      o.id = m.edge;
      all.push_back(o);
      of.push_back(&m);
    }
  TriangulationOptions topt;
  topt.outlier_threshold = opt_.hold_out_outlier;
  std::map<std::string, Pose2> solved;  // per object
  std::map<std::string, bool> solved_ok;
  for (EdgeFrameMeasurement& m : fc->edges) {
    if (!m.found) continue;
    const std::string& object = edges_[m.edge].object;
    if (!solved_ok.count(object)) {
      std::vector<BearingObservation> others;
      for (size_t i = 0; i < all.size(); ++i)
        if (edges_[of[i]->edge].object != object) others.push_back(all[i]);
      const TriangulationResult tri = Triangulate(others, fc->pose, topt);
      solved_ok[object] = tri.ok && static_cast<int>(tri.inliers.size()) >= 4;
      solved[object] = tri.pose;
    }
    if (!solved_ok[object]) continue;
    const Eigen::Vector3d c =
        SensorFromWorld(solved[object], map_.sensor_height,
                        Eigen::Vector3d(edges_[m.edge].position.x(), edges_[m.edge].position.y(), 0.0));
    const double predicted = s.image_azimuth(std::atan2(c.y(), c.x()));
    m.has_residual = true;
    m.bearing_residual = WrapAngle(m.measured_azimuth - predicted);
  }
}

namespace {

std::string Fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// The shade seen (the face's brightness against what lies beyond, times
// the map's shade there); without it, the map's mirrored about what lies
// beyond (the same contrast, the other sign).
double SuggestedShade(const EdgeCheck& e) {
  if (e.seen_shade >= 0) return std::clamp(e.seen_shade, 0.02, 0.98);
  return std::clamp(2.0 * e.beyond_shade - e.shade, 0.05, 0.95);
}

// The values within max(3 robust sigmas (1.4826 MAD), `floor`) of their
// median: frames where another edge was taken for this one are left out.
std::vector<double> Trimmed(const std::vector<double>& v, double floor) {
  if (v.size() < 3) return v;
  const double median = Median(v);
  std::vector<double> dev;
  for (double x : v) dev.push_back(std::abs(x - median));
  const double limit = std::max(3.0 * 1.4826 * Median(dev), floor);
  std::vector<double> out;
  for (double x : v)
    if (std::abs(x - median) <= limit) out.push_back(x);
  return out;
}

}  // namespace

namespace {

// The survey sigma of the edge's object (NaN when the map does not state one).
double ObjectSurveySigma(const Map& map, const EdgeCheck& e) {
  if (e.box) {
    for (size_t k = 0; k < map.boxes.size(); ++k)
      if (map.boxes[k].id == e.object) return map.BoxSurveySigma(k);
  } else {
    for (size_t k = 0; k < map.rectangles.size(); ++k)
      if (map.rectangles[k].id == e.object) return map.RectangleSurveySigma(k);
  }
  return std::nan("");
}

}  // namespace

MapCheckReport SummarizeMapCheck(const Map& map, std::vector<EdgeCheck> edges,
                                 const std::vector<FrameCheck>& frames, const MapCheckOptions& options) {
  MapCheckReport rep;
  rep.units = map.units;
  rep.frames = static_cast<int>(frames.size());
  std::vector<std::vector<double>> residuals(edges.size()), radials(edges.size()), distances(edges.size()),
      beyond(edges.size()), ratios(edges.size());
  // Each edge's polarity as seen on most frames: a frame whose step has the
  // other sign found something else (a neighbouring edge) and gives no residual.
  std::vector<int> polarity_balance(edges.size(), 0);
  for (const FrameCheck& fc : frames)
    for (const EdgeFrameMeasurement& m : fc.edges)
      if (m.found) polarity_balance[m.edge] += m.measured_polarity;
  for (const FrameCheck& fc : frames) {
    rep.frames_with_pose += fc.has_pose;
    rep.frames_with_landmarks += !fc.edges.empty();
    for (const EdgeFrameMeasurement& m : fc.edges) {
      EdgeCheck& e = edges[m.edge];
      ++e.visible;
      distances[m.edge].push_back(m.distance);
      beyond[m.edge].push_back(m.beyond_shade);
      if (!m.found) continue;
      ++e.found;
      e.polarity_agree += m.measured_polarity == m.expected_polarity;
      const int usual = polarity_balance[m.edge] >= 0 ? 1 : -1;
      if (m.has_residual && m.measured_polarity == usual) residuals[m.edge].push_back(m.bearing_residual * kDeg);
      if (m.brightness_ratio > 0) ratios[m.edge].push_back(m.brightness_ratio);
      if (m.horizontal_found) {
        ++e.radial_found;
        radials[m.edge].push_back(m.radial_residual_px);
      }
    }
  }
  rep.min_visible_frames = std::max(1, std::min(options.min_visible_frames, rep.frames_with_pose));
  auto mean_std = [](const std::vector<double>& v, double* mean, double* sd) {
    *mean = *sd = 0.0;
    if (v.empty()) return;
    *mean = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    double ss = 0.0;
    for (double x : v) ss += (x - *mean) * (x - *mean);
    *sd = v.size() > 1 ? std::sqrt(ss / (v.size() - 1)) : 0.0;
  };
  for (size_t i = 0; i < edges.size(); ++i) {
    EdgeCheck& e = edges[i];
    e.found_fraction = e.visible ? double(e.found) / e.visible : 0.0;
    e.polarity_fraction = e.found ? double(e.polarity_agree) / e.found : 0.0;
    const std::vector<double> kept = Trimmed(residuals[i], 0.2);
    e.residual_frames = static_cast<int>(kept.size());
    mean_std(kept, &e.mean_residual_deg, &e.std_residual_deg);
    mean_std(radials[i], &e.mean_radial_px, &e.std_radial_px);
    double unused;
    mean_std(distances[i], &e.mean_distance, &unused);
    mean_std(beyond[i], &e.beyond_shade, &unused);
    if (!ratios[i].empty()) e.seen_shade = std::clamp(Median(ratios[i]) * e.beyond_shade, 0.0, 1.0);
    if (e.visible < rep.min_visible_frames) continue;
    if (e.found_fraction < options.min_found_fraction) {
      e.findings.push_back(MapFinding::kNeverFound);
      continue;
    }
    if (e.polarity_fraction < options.min_polarity_agreement) e.findings.push_back(MapFinding::kWrongPolarity);
    if (e.residual_frames >= options.min_found_frames_for_bias) {
      const double m = std::abs(e.mean_residual_deg);
      const double se = e.std_residual_deg / std::sqrt(double(e.residual_frames));
      const double off = m / kDeg * e.mean_distance;  // across the line of sight, map units
      const double sigma = ObjectSurveySigma(map, e);
      const bool beyond_survey = !(sigma > 0.0) || off > options.bias_survey_sigmas * sigma;
      if (m > options.bias_sigmas * se && m > options.bias_floor_deg && beyond_survey)
        e.findings.push_back(MapFinding::kBiased);
    }
  }
  // One finding of each kind per object, in map order.
  std::vector<std::string> objects;
  for (const EdgeCheck& e : edges)
    if (std::find(objects.begin(), objects.end(), e.object) == objects.end()) objects.push_back(e.object);
  for (const std::string& object : objects) {
    for (MapFinding kind : {MapFinding::kNeverFound, MapFinding::kWrongPolarity, MapFinding::kBiased}) {
      std::string detail;
      int judged = 0, hit = 0;
      const EdgeCheck* first = nullptr;
      for (const EdgeCheck& e : edges) {
        if (e.object != object) continue;
        judged += e.visible >= rep.min_visible_frames;
        if (std::find(e.findings.begin(), e.findings.end(), kind) == e.findings.end()) continue;
        ++hit;
        if (!first) first = &e;
        if (kind == MapFinding::kBiased) {
          const double off_units = std::abs(e.mean_residual_deg / kDeg) * e.mean_distance;
          detail += (detail.empty() ? "" : "; ") + e.id + " predicted bearing off by " +
                    Fixed(e.mean_residual_deg, 2) + " deg (+- " +
                    Fixed(e.std_residual_deg / std::sqrt(double(e.residual_frames)), 2) + "), about " +
                    Fixed(off_units, 1) + " " + map.units + " at its distance " + Fixed(e.mean_distance, 0) + " " +
                    map.units;
        }
      }
      if (!hit) continue;
      ObjectFinding f;
      // An object with an edge that is not there: its other edges' figures
      // come from whatever lies near them, so they add nothing.
      if (kind != MapFinding::kNeverFound && !rep.findings.empty() && rep.findings.back().object == object &&
          rep.findings.back().kind == MapFinding::kNeverFound)
        continue;
      f.object = object;
      f.kind = kind;
      if (kind == MapFinding::kNeverFound) {
        f.message = object + ": never found (" + std::to_string(hit) + " of " + std::to_string(judged) +
                    " edges in view not found): not in the room or moved: check it exists / re-measure it";
      } else if (kind == MapFinding::kWrongPolarity) {
        f.message = object + ": shade looks inverted (map " + Fixed(first->shade, 2) + " against " +
                    Fixed(first->beyond_shade, 2) + " beyond its edges, the image shows the opposite): set shade to about " +
                    Fixed(SuggestedShade(*first), 2) + " or remove it";
      } else {
        f.message = object + ": corner mis-measured: " + detail + "; re-measure or run panomap refine";
      }
      rep.findings.push_back(f);
    }
  }
  rep.edges = std::move(edges);
  return rep;
}

namespace {

// How a rectangle found in the images relates to a mapped one.
enum class Match { kNone, kSame, kShifted };

// `found` against `mapped`, either way round: the same when both ends are
// within `tol`; shifted when both ends moved by one vector (within `tol`)
// no longer than `max_shift`, which is returned in `shift`.
Match MatchRectangle(const MapRectangle& found, const MapRectangle& mapped, double tol, double max_shift,
                     Eigen::Vector2d* shift) {
  Match best = Match::kNone;
  for (bool swap : {false, true}) {
    const Eigen::Vector2d& a = swap ? mapped.to : mapped.from;
    const Eigen::Vector2d& b = swap ? mapped.from : mapped.to;
    const Eigen::Vector2d da = found.from - a, db = found.to - b;
    if (da.norm() < tol && db.norm() < tol) return Match::kSame;
    const Eigen::Vector2d mean = 0.5 * (da + db);
    if ((da - db).norm() < tol && mean.norm() <= max_shift && best == Match::kNone) {
      best = Match::kShifted;
      *shift = mean;
    }
  }
  return best;
}

std::string PointText(const Eigen::Vector2d& p) { return "(" + Fixed(p.x(), 1) + ", " + Fixed(p.y(), 1) + ")"; }

int FrameViews(const MapBuildResult& built, const BuiltRectangle& r) {
  const size_t from = static_cast<size_t>(r.edge_from), to = static_cast<size_t>(r.edge_to);
  return std::max(built.edges[from].views, built.edges[to].views);
}

}  // namespace

void AddUnmappedFindings(const Map& map, const MapBuildResult& built, MapCheckReport* report) {
  Eigen::Vector2d lo, hi;
  double top;
  map.Extent(&lo, &hi, &top);
  const double size = std::max(hi.x() - lo.x(), hi.y() - lo.y());
  double tol = 0.01 * size;
  if (std::isfinite(map.survey_sigma)) tol = std::max(tol, 3.0 * map.survey_sigma);
  int unmapped = 0;
  std::vector<std::string> placed;  // objects whose finding already says where they stand
  for (const BuiltRectangle& b : built.rectangles) {
    const MapRectangle& found = b.rectangle;
    bool known = false;
    for (const MapRectangle& m : map.rectangles) {
      Eigen::Vector2d shift = Eigen::Vector2d::Zero();
      const Match match = MatchRectangle(found, m, tol, 0.1 * size, &shift);
      if (match == Match::kSame) known = true;
      if (match != Match::kShifted) continue;
      // Only a mapped rectangle the check found wrong is taken to be moved.
      if (std::find(placed.begin(), placed.end(), m.id) != placed.end()) continue;
      for (ObjectFinding& f : report->findings) {
        if (f.object != m.id || f.kind == MapFinding::kWrongPolarity) continue;
        f.message += "; a rectangle of its size stands " + Fixed(shift.norm(), 1) + " " + map.units +
                     " from it, from " + PointText(found.from) + " to " + PointText(found.to) +
                     ": it was moved there";
        placed.push_back(m.id);
        known = true;
        break;
      }
    }
    if (known) continue;
    ObjectFinding f;
    f.object = "unmapped-" + std::to_string(++unmapped);
    f.kind = MapFinding::kNotInMap;
    f.message = f.object + ": not in the map: a rectangle from " + PointText(found.from) + " to " +
                PointText(found.to) + ", z " + Fixed(found.z0, 0) + " to " + Fixed(found.z1, 0) + " " + map.units +
                ", seen in " + std::to_string(FrameViews(built, b)) +
                " frames: add it (panomap build adds such rectangles)";
    report->findings.push_back(f);
  }
}

namespace {

std::string EdgeStatus(const EdgeCheck& e, int min_visible) {
  if (e.visible == 0) return "not in view";
  if (e.visible < min_visible) return "too few frames";
  if (e.findings.empty()) return "ok";
  std::string s;
  for (MapFinding f : e.findings) s += (s.empty() ? "" : ", ") + std::string(MapFindingName(f));
  return s;
}

}  // namespace

std::string FormatMapCheckTable(const MapCheckReport& report) {
  std::string out;
  char line[256];
  std::snprintf(line, sizeof line, "%-22s %7s %6s %6s %6s %8s %7s %7s %8s  %s\n", "edge", "visible", "found", "found%",
                "polar%", "bias_deg", "std_deg", "rad_px", "distance", "status");
  out += line;
  for (const EdgeCheck& e : report.edges) {
    const bool judged = e.visible > 0;
    std::snprintf(line, sizeof line, "%-22s %7d %6d %6s %6s %8s %7s %7s %8s  %s\n", e.id.c_str(), e.visible, e.found,
                  judged ? Fixed(100 * e.found_fraction, 0).c_str() : "-",
                  e.found ? Fixed(100 * e.polarity_fraction, 0).c_str() : "-",
                  e.residual_frames ? Fixed(e.mean_residual_deg, 3).c_str() : "-",
                  e.residual_frames > 1 ? Fixed(e.std_residual_deg, 3).c_str() : "-",
                  e.radial_found ? Fixed(e.mean_radial_px, 2).c_str() : "-",
                  judged ? Fixed(e.mean_distance, 1).c_str() : "-", EdgeStatus(e, report.min_visible_frames).c_str());
    out += line;
  }
  std::snprintf(line, sizeof line, "%d frames, %d with a pose, %d with landmarks in view; %zu finding%s\n",
                report.frames, report.frames_with_pose, report.frames_with_landmarks, report.findings.size(),
                report.findings.size() == 1 ? "" : "s");
  out += line;
  for (const ObjectFinding& f : report.findings) out += "  " + f.message + "\n";
  return out;
}

}  // namespace pano

#include "track/junction_tracker.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "hough/tracking.h"
#include "track/edge_profile.h"

namespace pano {

void JunctionOptions::Check() const {
  if (!(sample_spacing_px > 0) || !(sample_step_px > 0) || !(corner_gap_px >= 0) || max_samples < 3 ||
      max_horizontal_samples < 3)
    throw Error("junction tracker: sample spacing, step, gap and count must be positive");
  if (!(min_step > 0)) throw Error("junction tracker: min_step: expected > 0 grey levels");
  if (!(truncation_px > 0) || !(junction_tolerance_px > 0))
    throw Error("junction tracker: truncation_px and junction_tolerance_px must be positive");
  if (min_vertical_points < 2 || min_horizontal_points < 2)
    throw Error("junction tracker: at least 2 points per edge");
}

JunctionTracker::JunctionTracker(const Sensor& sensor, std::shared_ptr<PhTableCache> ph_tables,
                                 const JunctionOptions& options)
    : sensor_(sensor), ph_tables_(std::move(ph_tables)), opt_(options) {
  opt_.Check();
}

namespace {

struct Step {
  double radius, azimuth, strength;
  Eigen::Vector2d px;
};

// A linear sample of half-length `half` px through (radius, azimuth) along
// the tangential (`radial` false) or radial direction, searched for a step of
// `polarity` along increasing azimuth / radius.
bool LinearStep(const cv::Mat& grey, const Sensor& s, const JunctionOptions& o, double radius,
                double azimuth, double half, int polarity, bool radial, Step* out) {
  const int n = 2 * static_cast<int>(std::ceil(half / o.sample_step_px)) + 1;
  if (n > 256) return false;
  const double c = std::cos(azimuth), sn = std::sin(azimuth), a = s.params.aspect;
  // Direction in pixels of one unit of (aspect-free) image length.
  const Eigen::Vector2d dir = radial ? Eigen::Vector2d(c, a * sn) : Eigen::Vector2d(-sn, a * c);
  const Eigen::Vector2d centre = s.from_polar(radius, azimuth);
  const double half_n = (n - 1) / 2;
  const Eigen::Vector2d start = centre - half_n * o.sample_step_px * dir;
  float profile[256];
  if (!SampleLine(grey, start, o.sample_step_px * dir, n, profile)) return false;
  StepEdge e;
  const int baseline = std::max(2, static_cast<int>(std::lround(2.0 / o.sample_step_px)));
  if (!FindStep(profile, n, polarity, baseline, o.min_step, &e)) return false;
  out->px = start + e.location * o.sample_step_px * dir;
  s.to_polar(out->px.x(), out->px.y(), &out->radius, &out->azimuth);
  out->strength = e.strength;
  return true;
}

}  // namespace

LandmarkMeasurement JunctionTracker::Measure(const PredictedLandmark& p, double search_px) const {
  LandmarkMeasurement m;
  const cv::Mat& g = grey_;
  const JunctionOptions& o = opt_;
  const double half = std::max(search_px, 2.0);

  // --- Vertical edge: tangential samples along the radial segment.
  const int v_dir = p.v_radius > p.corner_radius ? 1 : -1;
  const double v_len = std::abs(p.v_radius - p.corner_radius);
  const int v_pol = p.v_polarity * p.inside_azimuth_sign;
  const double v_spacing = std::max(o.sample_spacing_px, (v_len - 2 * o.corner_gap_px) / o.max_samples);
  std::vector<Step> v_steps;
  for (double d = o.corner_gap_px; d < v_len - o.corner_gap_px && static_cast<int>(v_steps.size()) < o.max_samples;
       d += v_spacing) {
    Step st;
    if (LinearStep(g, sensor_, o, p.corner_radius + v_dir * d, p.azimuth, half, v_pol, false, &st))
      v_steps.push_back(st);
  }
  if (static_cast<int>(v_steps.size()) < o.min_vertical_points) {
    m.why = "vertical edge not found";
    return m;
  }
  // Truncated median: the contiguous steps near the median azimuth.
  std::vector<double> offsets;  // tangential offsets from the prediction, px
  for (const Step& st : v_steps) offsets.push_back(wrap_angle(st.azimuth - p.azimuth) * st.radius);
  std::vector<double> sorted = offsets;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  double sum_dtheta = 0.0;
  int n_in = 0;
  const Step* nearest_v = nullptr;  // the found step nearest the junction
  for (size_t k = 0; k < v_steps.size(); ++k) {
    if (std::abs(offsets[k] - median) > o.truncation_px) continue;
    sum_dtheta += wrap_angle(v_steps[k].azimuth - p.azimuth);
    ++n_in;
    if (!nearest_v) nearest_v = &v_steps[k];
    m.edge_points.push_back(v_steps[k].px);
  }
  if (n_in < o.min_vertical_points) {
    m.why = "vertical edge not contiguous";
    return m;
  }
  const double theta_v = wrap_angle(p.azimuth + sum_dtheta / n_in);

  // --- Horizontal edge: radial samples along the predicted PH curve, voting
  // in the PH transform's tracking mode.
  const std::shared_ptr<const PhTable> ph = ph_tables_->Get(p.h_height);
  const int h_sgn = p.inside_azimuth_sign;
  const int h_pol = p.h_polarity * p.inside_radius_sign;
  const double arc = std::abs(wrap_angle(p.h_end_azimuth - p.azimuth));
  const double h_spacing = std::max(o.sample_spacing_px / p.corner_radius,
                                    (arc - 2 * o.corner_gap_px / p.corner_radius) / o.max_horizontal_samples);
  std::vector<TrackingVote> votes;
  std::vector<Step> h_steps;
  for (double dt = o.corner_gap_px / p.corner_radius;
       dt < arc - o.corner_gap_px / p.corner_radius && static_cast<int>(votes.size()) < o.max_horizontal_samples;
       dt += h_spacing) {
    const double theta = wrap_angle(p.azimuth + h_sgn * dt);
    double r_pred;
    if (!ph->Curve(p.r_main, wrap_angle(theta - p.theta_main), &r_pred)) continue;
    Step st;
    if (!LinearStep(g, sensor_, o, r_pred, theta, half, h_pol, true, &st)) continue;
    votes.push_back({st.radius, theta, 1.0});
    h_steps.push_back(st);
  }
  if (static_cast<int>(votes.size()) < o.min_horizontal_points) {
    m.why = "horizontal edge not found";
    return m;
  }
  TrackingWindow w;
  w.r_main = p.r_main;
  w.theta_main = p.theta_main;
  w.r_halfwidth = half + 1.0;
  w.r_bin = 0.5;
  // theta_main moves with the robot's turn (predicted by the compass) and,
  // for a near line, with its translation: about as far as the edge itself.
  w.theta_bin = std::max(1.0 / p.r_main, 0.05 * M_PI / 180);
  w.theta_halfwidth = std::min(60.0 * M_PI / 180, (half + 1.0) / p.r_main);
  // The horizontal edge validates the junction; a few robust steps suffice.
  w.refine_iterations = 3;
  const TrackingResult tr = TrackHorizontalLine(*ph, w, votes);
  if (!tr.found || tr.score < o.min_ph_score || tr.n_inliers < o.min_horizontal_points) {
    m.why = "no PH peak for the horizontal edge";
    return m;
  }
  m.r_main = tr.r_main;
  m.theta_main = tr.theta_main;
  for (const Step& st : h_steps) m.edge_points.push_back(st.px);

  // --- The junction: the horizontal curve at the vertical edge's azimuth.
  double r_junction;
  if (!ph->Curve(tr.r_main, wrap_angle(theta_v - tr.theta_main), &r_junction)) {
    m.why = "junction off the PH table";
    return m;
  }
  // End points by bisection between the last sample that found a step and
  // one beyond the junction that must not.
  const double probe = 2.5;  // px half-length of the probing samples
  const double ext = o.corner_gap_px + 1.5;
  auto v_has_step = [&](double r) {
    Step st;
    return LinearStep(g, sensor_, o, r, theta_v, probe, v_pol, false, &st);
  };
  double r_in = nearest_v->radius, r_out = r_junction - v_dir * ext;
  if (v_has_step(r_out)) {
    m.why = "vertical edge runs past the junction";
    return m;
  }
  for (int k = 0; k < o.bisection_steps; ++k) {
    const double mid = 0.5 * (r_in + r_out);
    (v_has_step(mid) ? r_in : r_out) = mid;
  }
  const double r_vertical_end = 0.5 * (r_in + r_out);
  auto h_has_step = [&](double theta) {
    double r;
    Step st;
    return ph->Curve(tr.r_main, wrap_angle(theta - tr.theta_main), &r) &&
           LinearStep(g, sensor_, o, r, theta, probe, h_pol, true, &st);
  };
  double t_in = h_steps.front().azimuth, t_out = wrap_angle(theta_v - h_sgn * ext / r_junction);
  if (h_has_step(t_out)) {
    m.why = "horizontal edge runs past the junction";
    return m;
  }
  for (int k = 0; k < o.bisection_steps; ++k) {
    const double mid = wrap_angle(t_in + 0.5 * wrap_angle(t_out - t_in));
    (h_has_step(mid) ? t_in : t_out) = mid;
  }
  const double t_horizontal_end = wrap_angle(t_in + 0.5 * wrap_angle(t_out - t_in));
  if (std::abs(r_vertical_end - r_junction) > o.junction_tolerance_px ||
      std::abs(wrap_angle(t_horizontal_end - theta_v)) * r_junction > o.junction_tolerance_px) {
    m.why = "edges do not meet";
    return m;
  }
  m.found = true;
  m.azimuth = theta_v;
  m.radius = r_junction;
  m.weight = 1.0;
  return m;
}

}  // namespace pano

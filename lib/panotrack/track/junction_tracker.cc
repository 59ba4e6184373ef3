#include "panotrack/track/junction_tracker.h"

#include <algorithm>
#include <cmath>

#include "panotrack/core/error.h"
#include "panotrack/hough/tracking.h"
#include "panotrack/track/edge_profile.h"

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
  // The step detector's rise is taken over 2 px.
  step_baseline_ = std::max(2, static_cast<int>(std::lround(2.0 / opt_.sample_step_px)));
}

namespace {

// Ramps narrower than the step detector's 2 px baseline need no allowance:
// allowing for them only lets marginal edges through.
double RampAllowance(double ramp_px) { return ramp_px < 2.0 ? 0.0 : ramp_px; }

// How many of the positions first, first + spacing, ... lie below `end`,
// accumulated as the edge searches step through them.
int PositionsBelow(double first, double spacing, double end) {
  int n = 0;
  for (double d = first; d < end; d += spacing) ++n;
  return n;
}

struct Step {
  double radius, azimuth, strength, width_px;
  Eigen::Vector2d px;
};

// cos and sin of an azimuth, for the samples along an edge at one azimuth.
struct Heading {
  explicit Heading(double azimuth) : c(std::cos(azimuth)), s(std::sin(azimuth)) {}
  double c, s;
};

// A linear sample through (radius, azimuth) along the tangential (`radial`
// false) or radial direction, searched for a step of `polarity` along
// increasing azimuth / radius within `half` px of the centre; the step may be
// a ramp up to `ramp_px` wide (motion blur). The sample reaches beyond `half`
// by the ramp and the plateaus the step detector needs either side.
// `baseline`: the step detector's (samples).

bool LinearStep(const cv::Mat& grey, const Sensor& s, const JunctionOptions& o, int baseline, double radius,
                const Heading& heading, double half, int polarity, bool radial, Step* out,
                double ramp_px = 0.0) {
  const double reach = half + 0.5 * ramp_px + 3.5;
  const int n = 2 * static_cast<int>(std::ceil(reach / o.sample_step_px)) + 1;
  if (n > 512) return false;
  const double c = heading.c, sn = heading.s, a = s.params.aspect;
  // Direction in pixels of one unit of (aspect-free) image length.
  const Eigen::Vector2d dir = radial ? Eigen::Vector2d(c, a * sn) : Eigen::Vector2d(-sn, a * c);
  const Eigen::Vector2d centre(s.params.cx + radius * c, s.params.cy + a * radius * sn);  // from_polar
  const double half_n = (n - 1) / 2;
  const Eigen::Vector2d start = centre - half_n * o.sample_step_px * dir;
  float profile[512];
  if (!SampleLine(grey, start, o.sample_step_px * dir, n, profile)) return false;
  StepEdge e;
  if (!FindStep(profile, n, polarity, baseline, o.min_step, &e, ramp_px / o.sample_step_px)) return false;
  if (std::abs(e.location - half_n) * o.sample_step_px > half + 0.5 * ramp_px) return false;
  out->px = start + e.location * o.sample_step_px * dir;
  s.to_polar(out->px.x(), out->px.y(), &out->radius, &out->azimuth);
  out->strength = e.strength;
  out->width_px = e.width * o.sample_step_px;
  return true;
}

}  // namespace

struct JunctionTracker::VerticalEdge {
  double azimuth = 0.0;         // truncated-median azimuth of the edge
  double nearest_radius = 0.0;  // radius of its found step nearest the junction
  int direction = 1;            // +1: the edge runs outwards from the junction
  int polarity = 1;             // step polarity along increasing azimuth
  double ramp_px = 0.0;         // widest motion blur across it at the corner (px)
  int n_points = 0;             // steps near the median
  double contrast = 0.0;        // their median step (grey levels)
};

struct JunctionTracker::HorizontalEdge {
  TrackingResult fit;            // (R_main, theta_main) of the PH peak
  double nearest_azimuth = 0.0;  // azimuth of its sample nearest the junction
  int side = 1;                  // the edge runs towards +side azimuth from the junction
  int polarity = 1;              // step polarity along increasing radius
  double ramp_px = 0.0;          // widest motion blur across it (px)
  double along_blur_px = 0.0;    // ... and along it: its ends smear this far
  double contrast = 0.0;         // median step of its samples (grey levels)
};

namespace {

// Reorders v.
double Median(std::vector<double>* v) {
  if (v->empty()) return 0.0;
  std::nth_element(v->begin(), v->begin() + v->size() / 2, v->end());
  return (*v)[v->size() / 2];
}

// The edge searches' working lists, kept per thread from one landmark to
// the next: a few small allocations per edge otherwise.
struct EdgeScratch {
  std::vector<Step> steps;
  std::vector<double> offsets, sorted, values;
  std::vector<TrackingVote> votes;
};
EdgeScratch& ThreadScratch() {
  thread_local EdgeScratch scratch;
  return scratch;
}

}  // namespace

bool JunctionTracker::FindVerticalEdge(const PredictedLandmark& p, double half, int polarity,
                                       VerticalEdge* edge, LandmarkMeasurement* m) const {
  const JunctionOptions& o = opt_;
  // Tangential samples along the radial segment.
  edge->direction = p.v_radius > p.corner_radius ? 1 : -1;
  edge->polarity = polarity * p.inside_azimuth_sign;
  edge->ramp_px = RampAllowance(p.tangential_motion_px);
  const double v_len = std::abs(p.v_radius - p.corner_radius);
  const double v_spacing = std::max(o.sample_spacing_px, (v_len - 2 * o.corner_gap_px) / o.max_samples);
  EdgeScratch& scratch = ThreadScratch();
  std::vector<Step>& v_steps = scratch.steps;
  v_steps.clear();
  const Heading heading(p.azimuth);
  // Once too few positions remain to find enough steps, the edge is lost.
  const double v_end = v_len - o.corner_gap_px;
  const int n_positions = PositionsBelow(o.corner_gap_px, v_spacing, v_end);
  int position = 0;
  for (double d = o.corner_gap_px; d < v_end && static_cast<int>(v_steps.size()) < o.max_samples;
       d += v_spacing, ++position) {
    if (static_cast<int>(v_steps.size()) + n_positions - position < o.min_vertical_points) break;
    Step st;
    const double r = p.corner_radius + edge->direction * d;
    // Tangential motion grows with the radius under rotation.
    const double ramp = edge->ramp_px * r / p.corner_radius;
    if (LinearStep(grey_, sensor_, o, step_baseline_, r, heading, half, edge->polarity, false, &st, ramp))
      v_steps.push_back(st);
  }
  if (static_cast<int>(v_steps.size()) < o.min_vertical_points) {
    m->why = "vertical edge not found";
    return false;
  }
  // Truncated median: the contiguous steps near the median azimuth.
  std::vector<double>& offsets = scratch.offsets;  // tangential offsets from the prediction, px
  offsets.clear();
  for (const Step& st : v_steps) offsets.push_back(WrapAngle(st.azimuth - p.azimuth) * st.radius);
  std::vector<double>& sorted = scratch.sorted;
  sorted = offsets;
  const double median = Median(&sorted);
  double sum_dtheta = 0.0;
  int n_in = 0;
  std::vector<double>& strengths = scratch.values;
  strengths.clear();
  m->edge_points.reserve(m->edge_points.size() + v_steps.size());
  // A blurred edge is located less precisely: widen the truncation with it.
  const double truncation = o.truncation_px + 0.1 * edge->ramp_px;
  for (size_t k = 0; k < v_steps.size(); ++k) {
    if (std::abs(offsets[k] - median) > truncation) continue;
    sum_dtheta += WrapAngle(v_steps[k].azimuth - p.azimuth);
    strengths.push_back(v_steps[k].strength);
    if (n_in++ == 0) edge->nearest_radius = v_steps[k].radius;
    m->edge_points.push_back(v_steps[k].px);
  }
  if (n_in < o.min_vertical_points) {
    m->why = "vertical edge not contiguous";
    return false;
  }
  edge->azimuth = WrapAngle(p.azimuth + sum_dtheta / n_in);
  edge->n_points = n_in;
  edge->contrast = Median(&strengths);
  std::vector<double>& widths = scratch.values;
  widths.clear();
  for (const Step& st : v_steps) widths.push_back(st.width_px);
  m->edge_width_px = Median(&widths);
  return true;
}

namespace {

// |dr / ds| of the predicted PH curve at `theta`, s the arc length (px).
double RadialSlope(const PhTable& ph, const PredictedLandmark& p, double theta) {
  const double dt = 0.25 / p.corner_radius;
  double ra, rb;
  if (!ph.Curve(p.r_main, WrapAngle(theta - dt - p.theta_main), &ra) ||
      !ph.Curve(p.r_main, WrapAngle(theta + dt - p.theta_main), &rb))
    return 0.0;
  return std::abs(rb - ra) / (2.0 * dt * p.corner_radius);
}

}  // namespace

bool JunctionTracker::FindHorizontalEdge(const PredictedLandmark& p, double half, const PhTable& ph,
                                         int polarity, HorizontalEdge* edge, LandmarkMeasurement* m) const {
  const JunctionOptions& o = opt_;
  // Radial samples along the predicted PH curve, voting in the PH
  // transform's tracking mode.
  edge->side = p.inside_azimuth_sign;
  edge->polarity = polarity * p.inside_radius_sign;
  edge->along_blur_px = RampAllowance(p.tangential_motion_px);
  const double arc = std::abs(WrapAngle(p.h_end_azimuth - p.azimuth));
  const double gap = o.corner_gap_px / p.corner_radius;
  const double h_spacing =
      std::max(o.sample_spacing_px / p.corner_radius, (arc - 2 * gap) / o.max_horizontal_samples);
  EdgeScratch& scratch = ThreadScratch();
  std::vector<TrackingVote>& votes = scratch.votes;
  std::vector<Step>& h_steps = scratch.steps;
  votes.clear();
  h_steps.clear();
  const int n_positions = PositionsBelow(gap, h_spacing, arc - gap);
  int position = 0;
  for (double dt = gap; dt < arc - gap && static_cast<int>(votes.size()) < o.max_horizontal_samples;
       dt += h_spacing, ++position) {
    if (static_cast<int>(votes.size()) + n_positions - position < o.min_horizontal_points) break;
    const double theta = WrapAngle(p.azimuth + edge->side * dt);
    double r_pred;
    if (!ph.Curve(p.r_main, WrapAngle(theta - p.theta_main), &r_pred)) continue;
    // A tangential smear moves a curved edge radially by its slope (no
    // smear: no slope needed).
    const double along = edge->along_blur_px > 0.0 ? RadialSlope(ph, p, theta) * edge->along_blur_px : 0.0;
    const double ramp = RampAllowance(p.radial_motion_px + along);
    edge->ramp_px = std::max(edge->ramp_px, ramp);
    Step st;
    if (!LinearStep(grey_, sensor_, o, step_baseline_, r_pred, Heading(theta), half, edge->polarity, true, &st, ramp)) continue;
    votes.push_back({st.radius, theta, 1.0});
    h_steps.push_back(st);
  }
  if (static_cast<int>(votes.size()) < o.min_horizontal_points) {
    m->why = "horizontal edge not found";
    return false;
  }
  edge->fit = TrackHorizontalLine(ph, HorizontalWindow(p, half), votes);
  if (!edge->fit.found || edge->fit.score < o.min_ph_score || edge->fit.n_inliers < o.min_horizontal_points) {
    m->why = "no PH peak for the horizontal edge";
    return false;
  }
  m->r_main = edge->fit.r_main;
  m->theta_main = edge->fit.theta_main;
  std::vector<double>& strengths = scratch.values;
  strengths.clear();
  m->edge_points.reserve(m->edge_points.size() + h_steps.size());
  for (const Step& st : h_steps) {
    m->edge_points.push_back(st.px);
    strengths.push_back(st.strength);
  }
  edge->contrast = Median(&strengths);
  edge->nearest_azimuth = h_steps.front().azimuth;
  return true;
}

TrackingWindow JunctionTracker::HorizontalWindow(const PredictedLandmark& p, double half) {
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
  return w;
}

namespace {

// Bisection for an edge's end between `in` (a step there) and `out` (none
// there), `steps` halvings, the estimate the last interval's midpoint
// (`midpoint`). Only whether that estimate lies within `tolerance` of the
// junction matters (`offset`: signed distance from it), so the halving
// stops once the whole interval lies on one side of that bound: every
// further midpoint falls inside the interval.
template <class HasStep, class Midpoint, class Offset>
bool EndWithinTolerance(double in, double out, int steps, double tolerance, const HasStep& has_step,
                        const Midpoint& midpoint, const Offset& offset) {
  for (int k = 0;; ++k) {
    const double a = offset(in), b = offset(out);
    if (std::abs(a) <= tolerance && std::abs(b) <= tolerance) return true;
    if ((a > tolerance && b > tolerance) || (a < -tolerance && b < -tolerance)) return false;
    if (k == steps) return std::abs(offset(midpoint(in, out))) <= tolerance;
    const double mid = midpoint(in, out);
    (has_step(mid) ? in : out) = mid;
  }
}

}  // namespace

// The edges' ends at the junction, by bisection between the last sample that
// found a step and one beyond the junction that must not: first along the
// vertical edge (radius),
bool JunctionTracker::VerticalEnd(const VerticalEdge& v, double r_junction, double tolerance, bool* meets,
                                  LandmarkMeasurement* m) const {
  const Heading heading(v.azimuth);
  auto has_step = [&](double r) {
    Step st;
    return LinearStep(grey_, sensor_, opt_, step_baseline_, r, heading, kProbeHalfPx, v.polarity, false, &st,
                      v.ramp_px * r / r_junction);
  };
  const double r_out = r_junction - v.direction * (opt_.corner_gap_px + 1.5);
  if (has_step(r_out)) {
    m->why = "vertical edge runs past the junction";
    return false;
  }
  *meets = EndWithinTolerance(
      v.nearest_radius, r_out, opt_.bisection_steps, tolerance, has_step,
      [](double a, double b) { return 0.5 * (a + b); }, [&](double r) { return r - r_junction; });
  return true;
}

// then along the horizontal edge (azimuth, on its PH curve); its bisection
// only where it can still matter (`needed`).
bool JunctionTracker::HorizontalEnd(const PhTable& ph, const HorizontalEdge& h, double theta_v, double r_junction,
                                    double tolerance, bool needed, bool* meets, LandmarkMeasurement* m) const {
  auto has_step = [&](double theta) {
    double r;
    Step st;
    return ph.Curve(h.fit.r_main, WrapAngle(theta - h.fit.theta_main), &r) &&
           LinearStep(grey_, sensor_, opt_, step_baseline_, r, Heading(theta), kProbeHalfPx, h.polarity, true, &st,
                      h.ramp_px);
  };
  // Motion blur smears the edge's end past the junction by up to half the
  // tangential motion.
  const double t_out =
      WrapAngle(theta_v - h.side * (opt_.corner_gap_px + 1.5 + 0.5 * h.along_blur_px) / r_junction);
  if (has_step(t_out)) {
    m->why = "horizontal edge runs past the junction";
    return false;
  }
  *meets = needed && EndWithinTolerance(
                         h.nearest_azimuth, t_out, opt_.bisection_steps, tolerance, has_step,
                         [](double a, double b) { return WrapAngle(a + 0.5 * WrapAngle(b - a)); },
                         [&](double theta) { return WrapAngle(theta - theta_v) * r_junction; });
  return true;
}

bool JunctionTracker::LocateJunction(const PhTable& ph, const VerticalEdge& v, const HorizontalEdge& h,
                                     LandmarkMeasurement* m) const {
  // The junction: the horizontal curve at the vertical edge's azimuth.
  double r_junction;
  if (!ph.Curve(h.fit.r_main, WrapAngle(v.azimuth - h.fit.theta_main), &r_junction)) {
    m->why = "junction off the PH table";
    return false;
  }
  bool vertical_meets = false, horizontal_meets = false;
  if (!VerticalEnd(v, r_junction, opt_.junction_tolerance_px + 0.5 * h.ramp_px, &vertical_meets, m) ||
      !HorizontalEnd(ph, h, v.azimuth, r_junction, opt_.junction_tolerance_px + 0.5 * h.along_blur_px,
                     vertical_meets, &horizontal_meets, m))
    return false;
  if (!vertical_meets || !horizontal_meets) {
    m->why = "edges do not meet";
    return false;
  }
  m->azimuth = v.azimuth;
  m->radius = r_junction;
  return true;
}

namespace {

// The step signs an edge of `polarity` is searched for: its own, or for an
// unknown polarity (0) either, +1 first. Returns how many.
int SearchSigns(const int& polarity, const int** signs) {
  static constexpr int kEither[2] = {1, -1};
  *signs = polarity == 0 ? kEither : &polarity;
  return polarity == 0 ? 2 : 1;
}

}  // namespace

LandmarkMeasurement JunctionTracker::MeasureAzimuth(const PredictedLandmark& p, double search_px) const {
  LandmarkMeasurement m;
  const double half = std::max(search_px, 2.0);
  const int* signs;
  const int n_signs = SearchSigns(p.v_polarity, &signs);
  VerticalEdge best;
  for (int k = 0; k < n_signs; ++k) {
    VerticalEdge edge;
    LandmarkMeasurement trial;
    if (!FindVerticalEdge(p, half, signs[k], &edge, &trial)) {
      if (!m.found) m.why = trial.why;
      continue;
    }
    // Edges of either sign at different places: which is the landmark's
    // only the junction could tell.
    if (m.found) {
      if (std::abs(WrapAngle(edge.azimuth - best.azimuth)) * p.corner_radius > opt_.junction_tolerance_px) {
        LandmarkMeasurement none;
        none.why = "ambiguous: vertical edges of either polarity";
        return none;
      }
      continue;
    }
    best = edge;
    m = trial;
    m.found = true;
    m.v_polarity = signs[k];
    m.v_contrast = edge.contrast;
  }
  if (!m.found) return m;
  m.azimuth = best.azimuth;
  m.radius = p.corner_radius;
  m.weight = 1.0;
  return m;
}

LandmarkMeasurement JunctionTracker::Measure(const PredictedLandmark& p, double search_px) const {
  LandmarkMeasurement m;
  const double half = std::max(search_px, 2.0);
  // An edge of unknown polarity (0) is searched for a step of either sign;
  // the pair that forms a junction wins.
  const int *v_signs, *h_signs;
  const int n_v_signs = SearchSigns(p.v_polarity, &v_signs), n_h_signs = SearchSigns(p.h_polarity, &h_signs);
  struct Vertical {
    VerticalEdge edge;
    LandmarkMeasurement m;
    int sign;
  };
  std::vector<Vertical> verticals;
  verticals.reserve(static_cast<size_t>(n_v_signs));
  for (int k = 0; k < n_v_signs; ++k) {
    const int sign = v_signs[k];
    Vertical v{VerticalEdge{}, LandmarkMeasurement{}, sign};
    if (FindVerticalEdge(p, half, sign, &v.edge, &v.m))
      verticals.push_back(std::move(v));
    else
      m.why = v.m.why;
  }
  if (verticals.empty()) return m;
  // The better supported edge first: more contiguous steps, then stronger.
  std::stable_sort(verticals.begin(), verticals.end(), [](const Vertical& a, const Vertical& b) {
    return a.edge.n_points != b.edge.n_points ? a.edge.n_points > b.edge.n_points
                                              : a.edge.contrast > b.edge.contrast;
  });
  const std::shared_ptr<const PhTable> ph = ph_tables_->Get(p.h_height);
  struct Horizontal {
    HorizontalEdge edge;
    LandmarkMeasurement m;
    int sign;
  };
  std::vector<Horizontal> horizontals;
  horizontals.reserve(static_cast<size_t>(n_h_signs));
  for (int k = 0; k < n_h_signs; ++k) {
    const int sign = h_signs[k];
    Horizontal h{HorizontalEdge{}, LandmarkMeasurement{}, sign};
    if (FindHorizontalEdge(p, half, *ph, sign, &h.edge, &h.m))
      horizontals.push_back(std::move(h));
    else
      m.why = h.m.why;
  }
  if (horizontals.empty()) return m;
  std::stable_sort(horizontals.begin(), horizontals.end(), [](const Horizontal& a, const Horizontal& b) {
    return a.edge.fit.score > b.edge.fit.score;
  });
  // With one polarity per edge this is the single pair. With either, every
  // pair is tried: two junctions of different vertical steps at different
  // places are ambiguous (one is another edge nearby), so none is reported.
  bool have = false;
  for (const Vertical& v : verticals)
    for (const Horizontal& h : horizontals) {
      LandmarkMeasurement trial;
      trial.edge_width_px = v.m.edge_width_px;
      if (!LocateJunction(*ph, v.edge, h.edge, &trial)) {
        if (!have) m.why = trial.why;
        continue;
      }
      if (have) {
        if (v.sign != m.v_polarity &&
            std::abs(WrapAngle(trial.azimuth - m.azimuth)) * trial.radius > opt_.junction_tolerance_px) {
          LandmarkMeasurement none;
          none.why = "ambiguous: junctions of either polarity";
          return none;
        }
        continue;
      }
      have = true;
      m = trial;
      m.edge_points.reserve(v.m.edge_points.size() + h.m.edge_points.size());
      m.edge_points = v.m.edge_points;
      m.edge_points.insert(m.edge_points.end(), h.m.edge_points.begin(), h.m.edge_points.end());
      m.r_main = h.m.r_main;
      m.theta_main = h.m.theta_main;
      m.v_polarity = v.sign;
      m.h_polarity = h.sign;
      m.v_contrast = v.edge.contrast;
      m.h_contrast = h.edge.contrast;
    }
  if (!have) return m;
  m.found = true;
  m.weight = 1.0;
  return m;
}

}  // namespace pano

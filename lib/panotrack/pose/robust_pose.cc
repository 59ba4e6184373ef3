#include "panotrack/pose/robust_pose.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"

namespace pano {

// ---------------------------------------------------------------------------
// Minimal solvers.

std::vector<Pose2> SolvePoseFrom3Bearings(const BearingObservation obs[3]) {
  const Eigen::Vector2d landmarks[3] = {obs[0].landmark, obs[1].landmark, obs[2].landmark};
  const double bearings[3] = {obs[0].bearing, obs[1].bearing, obs[2].bearing};
  Eigen::Vector3d p;
  if (SolvePoseFrom3BearingsT<double>(landmarks, bearings, &p) == 0) return {};
  return {Pose2{p.x(), p.y(), p.z()}};
}

bool SolvePoseFrom2Bearings(const BearingObservation obs[2], double heading, Pose2* pose) {
  const Eigen::Vector2d landmarks[2] = {obs[0].landmark, obs[1].landmark};
  const double bearings[2] = {obs[0].bearing, obs[1].bearing};
  Eigen::Vector3d p;
  if (!SolvePoseFrom2BearingsT<double>(landmarks, bearings, heading, &p)) return false;
  *pose = {p.x(), p.y(), p.z()};
  return true;
}

double BearingResidual(const BearingObservation& o, const Pose2& pose, Eigen::Vector3d* jacobian) {
  const double dx = o.landmark.x() - pose.x, dy = o.landmark.y() - pose.y;
  if (jacobian) {
    // d atan2(dy, dx) / d(x, y) = (dy, -dx) / r^2 (dx, dy fall as x, y rise).
    const double r2 = dx * dx + dy * dy;
    *jacobian = Eigen::Vector3d(dy / r2, -dx / r2, -1.0);
  }
  return WrapAngle(FastAtan2(dy, dx) - pose.theta - o.bearing);
}

std::vector<double> BearingLeverages(const std::vector<BearingObservation>& obs, const TriangulationResult& tri) {
  std::vector<Eigen::Vector3d> jacobians(tri.inliers.size());
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < tri.inliers.size(); ++k) {
    const BearingObservation& o = obs[static_cast<size_t>(tri.inliers[k])];
    BearingResidual(o, tri.pose, &jacobians[k]);
    info += o.weight * jacobians[k] * jacobians[k].transpose();
  }
  std::vector<double> leverages(tri.inliers.size(), 0.0);
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(info);
  if (!lu.isInvertible()) return leverages;
  const Eigen::Matrix3d inverse = lu.inverse();
  for (size_t k = 0; k < tri.inliers.size(); ++k)
    leverages[k] = obs[static_cast<size_t>(tri.inliers[k])].weight * jacobians[k].dot(inverse * jacobians[k]);
  return leverages;
}

std::vector<double> StandardizedResiduals(const std::vector<BearingObservation>& obs, const TriangulationResult& tri,
                                          double sigma, double max_leverage) {
  const std::vector<double> leverages = BearingLeverages(obs, tri);
  // Per group (an edge's corners, or a bearing of its own): weight, weighted
  // residual sum and leverage.
  struct Group {
    double weight = 0.0, weighted_residual = 0.0, leverage = 0.0;
  };
  std::map<int, Group> groups;
  for (size_t k = 0; k < tri.inliers.size(); ++k) {
    const int i = tri.inliers[k];
    const BearingObservation& o = obs[static_cast<size_t>(i)];
    Group& g = groups[BearingGroup(obs, i)];
    g.weight += o.weight;
    g.weighted_residual += o.weight * BearingResidual(o, tri.pose);
    g.leverage += leverages[k];
  }
  std::vector<double> out(tri.inliers.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t k = 0; k < tri.inliers.size(); ++k) {
    const Group& g = groups[BearingGroup(obs, tri.inliers[k])];
    // A residual of a bearing of weight W has variance sigma^2 (1 - h) / W.
    if (!(g.weight > 0.0) || !(g.leverage > 0.0) || g.leverage > max_leverage) continue;
    out[k] = g.weighted_residual / std::sqrt(g.weight) / (sigma * std::sqrt(1.0 - g.leverage));
  }
  return out;
}

double SolutionSeparation(const std::vector<BearingObservation>& obs, const TriangulationResult& tri) {
  // Per group: its normal matrix and gradient (w J^T r) at tri.pose.
  struct Group {
    Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
  };
  std::map<int, Group> groups;
  Group all;
  for (int i : tri.inliers) {
    const BearingObservation& o = obs[static_cast<size_t>(i)];
    Eigen::Vector3d j;
    const double r = BearingResidual(o, tri.pose, &j);
    Group& g = groups[BearingGroup(obs, i)];
    g.info += o.weight * j * j.transpose();
    g.gradient += o.weight * r * j;
    all.info += o.weight * j * j.transpose();
    all.gradient += o.weight * r * j;
  }
  if (groups.size() < 4) return std::numeric_limits<double>::infinity();
  double largest = 0.0;
  for (const auto& [id, g] : groups) {
    const Eigen::Matrix3d info = all.info - g.info;
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(info);
    if (!lu.isInvertible()) return std::numeric_limits<double>::infinity();
    const Eigen::Vector3d step = -lu.solve(all.gradient - g.gradient);
    largest = std::max(largest, step.head<2>().norm());
  }
  return largest;
}

// ---------------------------------------------------------------------------
// Robust consensus loop.

void RobustPoseOptions::Check() const {
  if (!(inlier_threshold > 0.0) || !(inlier_threshold < M_PI))
    throw Error("robust pose: inlier_threshold: expected an angle in (0, pi)");
  if (max_exhaustive_landmarks < 3 || max_exhaustive_landmarks > 60)
    throw Error("robust pose: max_exhaustive_landmarks: expected 3 to 60");
  if (!(success_probability > 0.0) || !(success_probability < 1.0))
    throw Error("robust pose: success_probability: expected in (0, 1)");
  if (min_samples < 1 || max_samples < min_samples)
    throw Error("robust pose: min_samples, max_samples: expected 1 <= min_samples <= max_samples");
  if (!(prior_heading_sigma >= 0.0))
    throw Error("robust pose: prior_heading_sigma: expected >= 0 (0: no heading prior)");
  if (gate_with_prior && !prior_covariance.allFinite())
    throw Error("robust pose: prior_covariance: expected finite values");
  if (!(prior_gate_confidence > 0.0) || !(prior_gate_confidence < 1.0))
    throw Error("robust pose: prior_gate_confidence: expected in (0, 1)");
  if (refine_iterations < 1) throw Error("robust pose: refine_iterations: expected at least 1");
  if (local_optimisations < 1) throw Error("robust pose: local_optimisations: expected at least 1");
}

namespace {

// A scored hypothesis: its MSAC cost over all bearings and its consensus.
struct Candidate {
  Pose2 pose;
  double cost = 0.0;
  std::vector<int> inliers;
  bool from_pair = false;
};

// MSAC cost of a pose over all bearings: each costs min(r^2, threshold^2),
// r in units of its spread.
double MsacCost(const std::vector<BearingObservation>& obs, const Pose2& pose, double threshold,
                std::vector<int>* inliers) {
  const double tau2 = threshold * threshold;
  double cost = 0.0;
  if (inliers) inliers->clear();
  for (size_t i = 0; i < obs.size(); ++i) {
    const double r = BearingResidual(obs[i], pose) / obs[i].spread;
    cost += std::min(r * r, tau2);
    if (inliers && r * r < tau2) inliers->push_back(static_cast<int>(i));
  }
  return cost;
}

// Scores hypotheses and keeps the best few with distinct consensus sets
// (many triples of one consensus give nearly the same pose; refining more
// than one set settles near-ties between a true and a coincidental one).
// Of equal costs the first is kept, so the result depends only on the order
// of generation.
class HypothesisScorer {
 public:
  HypothesisScorer(const std::vector<BearingObservation>& obs, const Pose2& prior,
                   const RobustPoseOptions& opt)
      : obs_(obs), prior_(prior), opt_(opt) {
    if (opt.gate_with_prior) gate_ = ChiSquareQuantile(opt.prior_gate_confidence, 3);
  }

  void Score(const Pose2& pose, bool from_pair, RobustTriangulationResult* out) {
    if (opt_.gate_with_prior && PoseMahalanobis2(pose, prior_, opt_.prior_covariance) > gate_) {
      ++out->hypotheses_gated;
      return;
    }
    ++out->hypotheses;
    // No better than the worst kept: it can neither enter nor replace one.
    const double cost = MsacCost(obs_, pose, opt_.inlier_threshold, nullptr);
    if (static_cast<int>(best_.size()) == opt_.local_optimisations && !(cost < best_.back().cost))
      return;
    Candidate c{pose, cost, {}, from_pair};
    MsacCost(obs_, pose, opt_.inlier_threshold, &c.inliers);
    for (Candidate& kept : best_) {
      if (kept.inliers != c.inliers) continue;
      if (c.cost < kept.cost) kept = std::move(c);
      Sort();
      return;
    }
    if (static_cast<int>(best_.size()) == opt_.local_optimisations) {
      if (!(c.cost < best_.back().cost)) return;
      best_.pop_back();
    }
    best_.push_back(std::move(c));
    Sort();
  }

  bool found() const { return !best_.empty(); }
  int best_support() const { return best_.empty() ? 0 : static_cast<int>(best_[0].inliers.size()); }
  const std::vector<Candidate>& best() const { return best_; }

 private:
  void Sort() {
    std::stable_sort(best_.begin(), best_.end(),
                     [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });
  }

  const std::vector<BearingObservation>& obs_;
  const Pose2 prior_;
  const RobustPoseOptions& opt_;
  double gate_ = std::numeric_limits<double>::infinity();
  std::vector<Candidate> best_;  // by cost, at most local_optimisations
};

void ScoreTriple(const std::vector<BearingObservation>& obs, int i, int j, int k,
                 HypothesisScorer* scorer, RobustTriangulationResult* out) {
  const BearingObservation triple[3] = {obs[i], obs[j], obs[k]};
  ++out->samples;
  for (const Pose2& pose : SolvePoseFrom3Bearings(triple)) scorer->Score(pose, false, out);
}

void ScorePair(const std::vector<BearingObservation>& obs, int i, int j, double heading,
               HypothesisScorer* scorer, RobustTriangulationResult* out) {
  const BearingObservation pair[2] = {obs[i], obs[j]};
  ++out->samples;
  Pose2 pose;
  if (SolvePoseFrom2Bearings(pair, heading, &pose)) scorer->Score(pose, true, out);
}

// Triples needed to draw an all-inlier one with the given probability.
int AdaptiveSamples(double inlier_ratio, const RobustPoseOptions& opt) {
  const double w3 = inlier_ratio * inlier_ratio * inlier_ratio;
  if (w3 >= 1.0) return opt.min_samples;
  if (w3 <= 0.0) return opt.max_samples;
  const double k = std::log(1.0 - opt.success_probability) / std::log(1.0 - w3);
  return static_cast<int>(std::clamp(std::ceil(k), double(opt.min_samples), double(opt.max_samples)));
}

// Distinct random indices. rng() % n rather than a std distribution: the
// standard libraries' distributions differ, the engine's output does not.
void DrawDistinct(std::mt19937_64* rng, int n, int count, int* idx) {
  for (int c = 0; c < count; ++c) {
    bool repeat = true;
    while (repeat) {
      idx[c] = static_cast<int>((*rng)() % static_cast<uint64_t>(n));
      repeat = std::find(idx, idx + c, idx[c]) != idx + c;
    }
  }
}

void GenerateHypotheses(const std::vector<BearingObservation>& obs, const Pose2& prior,
                        const RobustPoseOptions& opt, HypothesisScorer* scorer,
                        RobustTriangulationResult* out) {
  const int n = static_cast<int>(obs.size());
  const bool pairs = opt.prior_heading_sigma > 0.0;
  if (n <= opt.max_exhaustive_landmarks) {
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        for (int k = j + 1; k < n; ++k) ScoreTriple(obs, i, j, k, scorer, out);
    if (pairs)
      for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) ScorePair(obs, i, j, prior.theta, scorer, out);
    return;
  }
  std::mt19937_64 rng(opt.seed);
  int needed = opt.min_samples;
  for (int s = 0; s < needed; ++s) {
    int idx[3];
    DrawDistinct(&rng, n, 3, idx);
    ScoreTriple(obs, idx[0], idx[1], idx[2], scorer, out);
    if (pairs) ScorePair(obs, idx[0], idx[1], prior.theta, scorer, out);
    if (scorer->found()) needed = AdaptiveSamples(double(scorer->best_support()) / n, opt);
  }
}

// Triangulate on the subset `use`, its result re-indexed to `obs`.
TriangulationResult TriangulateSubset(const std::vector<BearingObservation>& obs,
                                      const std::vector<int>& use, const Pose2& start,
                                      const TriangulationOptions& topt) {
  std::vector<BearingObservation> sub;
  for (int i : use) sub.push_back(obs[i]);
  TriangulationResult r = Triangulate(sub, start, topt);
  if (!r.ok) return r;
  for (int& i : r.inliers) i = use[i];
  r.bearing_residuals.resize(obs.size());
  for (size_t i = 0; i < obs.size(); ++i) r.bearing_residuals[i] = BearingResidual(obs[i], r.pose);
  return r;
}

// Refine on the consensus, re-select the inliers among all bearings against
// the refined pose, refine again, until the set settles.
TriangulationResult LocalOptimisation(const std::vector<BearingObservation>& obs, const Candidate& c,
                                      const RobustPoseOptions& opt, const TriangulationOptions& topt,
                                      int* refinements) {
  Pose2 pose = c.pose;
  std::vector<int> use = c.inliers;
  TriangulationResult best;
  best.failure = "too few inliers (" + std::to_string(use.size()) + ")";
  for (int it = 0; it < opt.refine_iterations; ++it) {
    if (static_cast<int>(use.size()) < std::max(3, topt.min_landmarks)) break;
    TriangulationResult r = TriangulateSubset(obs, use, pose, topt);
    ++*refinements;
    if (!r.ok) {
      if (!best.ok) best = r;
      break;
    }
    best = r;
    pose = r.pose;
    std::vector<int> next;
    MsacCost(obs, pose, opt.inlier_threshold, &next);
    if (next == use) break;
    use = std::move(next);
  }
  return best;
}

}  // namespace

RobustTriangulationResult RobustTriangulate(const std::vector<BearingObservation>& obs,
                                            const Pose2& prior, const RobustPoseOptions& opt,
                                            const TriangulationOptions& topt) {
  opt.Check();
  topt.Check();
  RobustTriangulationResult out;
  for (const BearingObservation& o : obs) {
    if (!std::isfinite(o.bearing) || !o.landmark.allFinite() || !(o.weight > 0.0) || !(o.spread >= 1.0) ||
        !std::isfinite(o.spread)) {
      out.failure = "non-finite bearing or landmark, non-positive weight, or spread below 1";
      return out;
    }
  }
  const size_t min_needed = opt.prior_heading_sigma > 0.0 ? 2 : 3;
  if (obs.size() < std::max<size_t>(min_needed, topt.min_landmarks)) {
    out.failure = "too few landmarks (" + std::to_string(obs.size()) + ")";
    return out;
  }
  HypothesisScorer scorer(obs, prior, opt);
  GenerateHypotheses(obs, prior, opt, &scorer, &out);
  if (!scorer.found()) {
    out.failure = "no hypothesis: every minimal sample was degenerate or gated";
    return out;
  }
  // Refine each kept consensus; the refined pose with the lowest MSAC cost
  // over all bearings wins (the first of equal costs).
  TriangulationResult best;
  std::string first_failure;
  for (const Candidate& c : scorer.best()) {
    TriangulationResult r = LocalOptimisation(obs, c, opt, topt, &out.refinements);
    if (!r.ok) {
      if (first_failure.empty()) first_failure = r.failure;
      continue;
    }
    const double cost = MsacCost(obs, r.pose, opt.inlier_threshold, nullptr);
    if (best.ok && !(cost < out.best_cost)) continue;
    best = std::move(r);
    out.best_cost = cost;
    out.consensus = static_cast<int>(c.inliers.size());
    out.hypothesis = c.pose;
    out.from_heading_prior = c.from_pair;
  }
  if (!best.ok) {
    out.failure = "refinement failed: " + first_failure;
    return out;
  }
  static_cast<TriangulationResult&>(out) = best;
  return out;
}

// ---------------------------------------------------------------------------
// Chi-square distribution.

double NormalQuantile(double p) {
  if (!(p > 0.0) || !(p < 1.0)) {
    if (p == 0.0) return -std::numeric_limits<double>::infinity();
    if (p == 1.0) return std::numeric_limits<double>::infinity();
    return std::numeric_limits<double>::quiet_NaN();
  }
  // Acklam's coefficients.
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01,  -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  const double p_low = 0.02425;
  double x;
  if (p < p_low || p > 1 - p_low) {
    const double q = std::sqrt(-2 * std::log(p < p_low ? p : 1 - p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
    if (p > 1 - p_low) x = -x;
  } else {
    const double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  }
  // One Halley step on the exact CDF brings 1e-9 to rounding.
  const double e = 0.5 * std::erfc(-x / std::sqrt(2.0)) - p;
  const double u = e * std::sqrt(2 * M_PI) * std::exp(x * x / 2);
  return x - u / (1 + x * u / 2);
}

namespace {

// Regularised incomplete gamma P(a, x) (lower) or Q(a, x) (upper), each by
// the expansion that converges fast where it is used.
double IncompleteGamma(double a, double x, bool upper) {
  if (!(x > 0.0)) return upper ? 1.0 : 0.0;
  const double log_prefix = -x + a * std::log(x) - std::lgamma(a);
  const double eps = 1e-16;
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000 && std::abs(term) > eps * std::abs(sum); ++n) {
      term *= x / (a + n);
      sum += term;
    }
    const double p = sum * std::exp(log_prefix);
    return upper ? 1.0 - p : p;
  }
  // Continued fraction for Q (modified Lentz).
  const double tiny = 1e-300;
  double bb = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / bb, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    bb += 2.0;
    d = an * d + bb;
    if (std::abs(d) < tiny) d = tiny;
    c = bb + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < eps) break;
  }
  const double q = std::exp(log_prefix) * h;
  return upper ? q : 1.0 - q;
}

void CheckDof(int dof) {
  if (dof < 1) throw Error("chi-square: dof: expected at least 1");
}

}  // namespace

double ChiSquareCdf(double x, int dof) {
  CheckDof(dof);
  return IncompleteGamma(0.5 * dof, 0.5 * x, false);
}

double ChiSquareSurvival(double x, int dof) {
  CheckDof(dof);
  return IncompleteGamma(0.5 * dof, 0.5 * x, true);
}

double ChiSquareQuantileWilsonHilferty(double p, int dof) {
  CheckDof(dof);
  const double k = dof, v = 2.0 / (9.0 * k);
  const double cube = 1.0 - v + NormalQuantile(p) * std::sqrt(v);
  return cube > 0.0 ? k * cube * cube * cube : 0.0;
}

double ChiSquareQuantile(double p, int dof) {
  CheckDof(dof);
  if (!(p > 0.0) || !(p < 1.0)) throw Error("chi-square: p: expected in (0, 1)");
  // g(q) rises from -p to 1 - p; use the tail that keeps its precision.
  const bool upper = p > 0.5;
  auto g = [&](double q) {
    return upper ? (1.0 - p) - ChiSquareSurvival(q, dof) : ChiSquareCdf(q, dof) - p;
  };
  const double half_k = 0.5 * dof;
  auto pdf = [&](double q) {
    return std::exp((half_k - 1) * std::log(q) - 0.5 * q - half_k * std::log(2.0) - std::lgamma(half_k));
  };
  // Bracket, then Newton steps that stay inside it (else bisection).
  double lo = 0.0, hi = std::max(1.0, 2.0 * dof);
  while (g(hi) < 0.0) hi *= 2.0;
  double q = ChiSquareQuantileWilsonHilferty(p, dof);
  if (!(q > lo && q < hi)) q = 0.5 * (lo + hi);
  for (int it = 0; it < 200; ++it) {
    const double gq = g(q);
    if (gq == 0.0) break;
    (gq < 0.0 ? lo : hi) = q;
    double next = q - gq / pdf(q);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - q) <= 1e-15 * q) return next;
    q = next;
  }
  return q;
}

// ---------------------------------------------------------------------------
// Integrity.

void IntegrityOptions::Check() const {
  if (!(sigma_bearing > 0.0)) throw Error("integrity: sigma_bearing: expected > 0");
  if (!(confidence > 0.0) || !(confidence < 1.0)) throw Error("integrity: confidence: expected in (0, 1)");
  if (!(reference_position_std > 0.0)) throw Error("integrity: reference_position_std: expected > 0");
  if (!(reference_redundancy > 0.0)) throw Error("integrity: reference_redundancy: expected > 0");
  if (!(protection_sigmas > 0.0) || !(alert_fraction >= 0.0))
    throw Error("integrity: protection_sigmas: expected > 0, alert_fraction: expected >= 0");
  if (!(alert_margin >= 0.0) || !(alert_limit >= 0.0) || !std::isfinite(alert_margin) || !std::isfinite(alert_limit))
    throw Error("integrity: alert_margin and alert_limit: expected lengths >= 0");
}

namespace {

// Predicted covariance sigma^2 (J^T W J)^-1 at the pose, from the inliers,
// and the unit-free condition number. False when singular.
bool PredictedGeometry(const TriangulationResult& result, const std::vector<BearingObservation>& obs,
                       double sigma, IntegrityReport* rep) {
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  double sum_d2 = 0.0;
  for (int i : result.inliers) {
    Eigen::Vector3d j;
    BearingResidual(obs[i], result.pose, &j);
    info += obs[i].weight * j * j.transpose();
    sum_d2 += (obs[i].landmark - Eigen::Vector2d(result.pose.x, result.pose.y)).squaredNorm();
  }
  // Scale (x, y) by the RMS distance so the three rows are all per radian.
  const double scale = std::sqrt(sum_d2 / std::max<size_t>(1, result.inliers.size()));
  const Eigen::Vector3d s(scale, scale, 1.0);
  const Eigen::Matrix3d unit_free = s.asDiagonal() * info * s.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(unit_free);
  const double lmin = es.eigenvalues().minCoeff(), lmax = es.eigenvalues().maxCoeff();
  if (!(lmin > 1e-12 * lmax)) return false;
  rep->condition = lmax / lmin;
  const Eigen::Matrix3d cov = sigma * sigma * info.inverse();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> pos(cov.topLeftCorner<2, 2>());
  rep->position_std = std::sqrt(pos.eigenvalues().maxCoeff());
  rep->heading_std = std::sqrt(cov(2, 2));
  return true;
}

}  // namespace

IntegrityReport IntegrityCheck(const TriangulationResult& result,
                               const std::vector<BearingObservation>& obs,
                               const IntegrityOptions& opt) {
  opt.Check();
  IntegrityReport rep;
  rep.observations = static_cast<int>(obs.size());
  if (!result.ok) return rep;
  rep.inliers = static_cast<int>(result.inliers.size());
  rep.dof = DistinctBearings(obs, result.inliers) - 3;
  rep.testable = rep.dof >= 1;
  const double sigma2 = opt.sigma_bearing * opt.sigma_bearing;
  for (int i : result.inliers) {
    const double r = BearingResidual(obs[i], result.pose);
    rep.chi2 += obs[i].weight * r * r / sigma2;
  }
  if (rep.testable) {
    rep.chi2_threshold = ChiSquareQuantile(opt.confidence, rep.dof);
    rep.p_value = ChiSquareSurvival(rep.chi2, rep.dof);
    rep.consistent = rep.chi2 <= rep.chi2_threshold;
  }
  if (!PredictedGeometry(result, obs, opt.sigma_bearing, &rep)) {
    rep.consistent = false;
    rep.position_std = rep.heading_std = rep.condition = std::numeric_limits<double>::infinity();
    return rep;  // quality 0
  }
  if (opt.alert_fraction > 0 || opt.alert_limit > 0) {
    double distance = 0.0;
    for (int i : result.inliers) distance += (obs[i].landmark - Eigen::Vector2d(result.pose.x, result.pose.y)).norm();
    rep.alert_limit = opt.alert_limit > 0 ? opt.alert_limit
                                          : opt.alert_fraction * distance / std::max<size_t>(1, result.inliers.size()) +
                                                opt.alert_margin;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> pos(result.covariance.topLeftCorner<2, 2>());
    rep.protection_level = opt.protection_sigmas * std::sqrt(std::max(0.0, pos.eigenvalues().maxCoeff()));
    rep.within_alert_limit = rep.protection_level <= rep.alert_limit;
  }
  const double fraction = rep.observations > 0 ? double(rep.inliers) / rep.observations : 0.0;
  const double redundancy = rep.dof > 0 ? rep.dof / (rep.dof + opt.reference_redundancy) : 0.0;
  const double consistency = std::min(1.0, rep.p_value / (1.0 - opt.confidence));
  const double ratio = rep.position_std / opt.reference_position_std;
  rep.quality = fraction * redundancy * consistency / (1.0 + ratio * ratio);
  return rep;
}

double PoseMahalanobis2(const Pose2& pose, const Pose2& predicted, const Eigen::Matrix3d& covariance) {
  const Eigen::Vector3d e(pose.x - predicted.x, pose.y - predicted.y,
                          WrapAngle(pose.theta - predicted.theta));
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
  if (llt.info() != Eigen::Success || !covariance.allFinite())
    return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d z = llt.matrixL().solve(e);
  return z.squaredNorm();
}

}  // namespace pano

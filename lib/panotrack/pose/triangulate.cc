#include "panotrack/pose/triangulate.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"

namespace pano {

void TriangulationOptions::Check() const {
  if (min_landmarks < 2) throw Error("triangulation: min_landmarks: expected at least 2");
  if (!(huber > 0.0) || !(outlier_threshold > 0.0) || !(bearing_sigma > 0.0))
    throw Error("triangulation: huber, outlier_threshold, bearing_sigma: expected positive angles");
  if (!(degenerate_eigen > 0.0)) throw Error("triangulation: degenerate_eigen: expected > 0");
}

namespace {

// Bearing line of observation o for heading h: a x + b y + c = 0 with (a, b)
// the unit normal of the direction bearing + h.
inline void Line(const BearingObservation& o, double h, double* a, double* b, double* c) {
  const double phi = o.bearing + h;
  *a = std::sin(phi);
  *b = -std::cos(phi);
  *c = -(*a * o.landmark.x() + *b * o.landmark.y());
}

double SumDist2(const std::vector<BearingObservation>& obs, double h) {
  Eigen::Vector2d p;
  double s;
  if (!PositionFromBearings(obs, h, &p, &s)) return std::numeric_limits<double>::infinity();
  return s;
}

}  // namespace

bool PositionFromBearings(const std::vector<BearingObservation>& obs, double heading,
                          Eigen::Vector2d* position, double* sum_dist2) {
  // The lines once for both sums (their sin and cos are most of the cost).
  thread_local std::vector<Eigen::Vector3d> lines;
  lines.resize(obs.size());
  double saa = 0, sbb = 0, sab = 0, sac = 0, sbc = 0;
  for (size_t i = 0; i < obs.size(); ++i) {
    const BearingObservation& o = obs[i];
    Eigen::Vector3d& line = lines[i];
    Line(o, heading, &line.x(), &line.y(), &line.z());
    const double a = line.x(), b = line.y(), c = line.z();
    const double w = o.weight;
    saa += w * a * a;
    sbb += w * b * b;
    sab += w * a * b;
    sac += w * a * c;
    sbc += w * b * c;
  }
  const double det = saa * sbb - sab * sab;  // Eqn 1's denominator
  const double scale = (saa + sbb) * (saa + sbb);
  if (!(det > 1e-12 * scale)) return false;
  const double x = (-sbb * sac + sbc * sab) / det;  // Eqn 1
  const double y = -(saa * sbc - sac * sab) / det;
  *position = {x, y};
  // Eqn 2, evaluated as the sum of squared distances it expands: the
  // expanded form cancels catastrophically near the minimum.
  double sum = 0.0;
  for (size_t i = 0; i < obs.size(); ++i) {
    const double d = lines[i].x() * x + lines[i].y() * y + lines[i].z();
    sum += obs[i].weight * d * d;
  }
  *sum_dist2 = sum;
  return true;
}

bool HeadingNewtonRaphson(const std::vector<BearingObservation>& obs, double heading0,
                          double* heading) {
  double h = heading0;
  const double eps = 1e-5;
  for (int it = 0; it < 50; ++it) {
    const double f0 = SumDist2(obs, h), fp = SumDist2(obs, h + eps), fm = SumDist2(obs, h - eps);
    if (!std::isfinite(f0) || !std::isfinite(fp) || !std::isfinite(fm)) return false;
    const double d1 = (fp - fm) / (2 * eps), d2 = (fp - 2 * f0 + fm) / (eps * eps);
    // Newton step on F'(h) = 0; where F is not convex, step downhill.
    double step = d2 > 0 ? -d1 / d2 : (d1 > 0 ? -0.05 : 0.05);
    step = std::clamp(step, -0.2, 0.2);
    // Keep the step only if it does not increase F (halve otherwise).
    double hn = h + step;
    for (int k = 0; k < 20 && SumDist2(obs, hn) > f0; ++k) {
      step *= 0.5;
      hn = h + step;
    }
    h = hn;
    if (std::abs(step) < 1e-12) break;
  }
  *heading = WrapAngle(h);
  return true;
}

namespace {

// Gauss-Newton on r_i = wrap(atan2(ly - y, lx - x) - theta - bearing_i), with
// Huber weights. Returns false if the normal matrix is singular.
bool RefineOnBearings(const std::vector<BearingObservation>& obs, const std::vector<int>& use,
                      const TriangulationOptions& opt, Pose2* pose, Eigen::Matrix3d* info,
                      double* min_eig) {
  for (int it = 0; it < 30; ++it) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    Eigen::Matrix3d H_plain = Eigen::Matrix3d::Zero();
    double weighted_d2 = 0.0, weights = 0.0;
    for (int i : use) {
      const BearingObservation& o = obs[i];
      const double dx = o.landmark.x() - pose->x, dy = o.landmark.y() - pose->y;
      const double r2 = dx * dx + dy * dy;
      if (!(r2 > 0)) return false;
      const double r = WrapAngle(FastAtan2(dy, dx) - pose->theta - o.bearing);
      // d atan2(dy, dx) / d(x, y) = (dy, -dx) / r2
      const Eigen::Vector3d J(dy / r2, -dx / r2, -1.0);
      const double rn = std::abs(r) / o.spread;
      const double w_huber = rn <= opt.huber ? 1.0 : opt.huber / rn;
      const double w = o.weight * w_huber;
      H += w * J * J.transpose();
      H_plain += o.weight * J * J.transpose();
      g += w * J * r;
      weighted_d2 += o.weight * r2;
      weights += o.weight;
    }
    // Normalise the position rows by a typical landmark distance so the
    // eigenvalue test does not depend on the units: unscaled, a position
    // row is the heading's over the distance, and a room measured in
    // centimetres with landmarks metres away looked degenerate however
    // well spread its bearings were.
    const double typical = std::sqrt(weighted_d2 / weights);
    const Eigen::Vector3d scale(typical, typical, 1.0);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(scale.asDiagonal() * H_plain * scale.asDiagonal());
    const double lmax = es.eigenvalues().maxCoeff();
    *min_eig = lmax > 0 ? es.eigenvalues().minCoeff() / lmax : 0.0;
    if (!(*min_eig > opt.degenerate_eigen)) return false;
    const Eigen::Vector3d delta = -H.ldlt().solve(g);
    if (!delta.allFinite()) return false;
    pose->x += delta.x();
    pose->y += delta.y();
    pose->theta = WrapAngle(pose->theta + delta.z());
    *info = H_plain;
    if (delta.head<2>().norm() < 1e-10 && std::abs(delta.z()) < 1e-12) break;
  }
  return true;
}

}  // namespace

int DistinctBearings(const std::vector<BearingObservation>& obs, const std::vector<int>& use) {
  std::vector<int> groups;
  int single = 0;
  for (int i : use) {
    if (obs[static_cast<size_t>(i)].group < 0)
      ++single;
    else
      groups.push_back(obs[static_cast<size_t>(i)].group);
  }
  std::sort(groups.begin(), groups.end());
  return single + static_cast<int>(std::unique(groups.begin(), groups.end()) - groups.begin());
}

TriangulationResult Triangulate(const std::vector<BearingObservation>& obs, const Pose2& prior,
                                const TriangulationOptions& opt) {
  opt.Check();
  TriangulationResult res;
  for (const BearingObservation& o : obs) {
    if (!std::isfinite(o.bearing) || !o.landmark.allFinite() || !(o.weight > 0.0) || !(o.spread >= 1.0) ||
        !std::isfinite(o.spread)) {
      res.failure = "non-finite bearing or landmark, non-positive weight, or spread below 1";
      return res;
    }
  }
  if (static_cast<int>(obs.size()) < opt.min_landmarks) {
    res.failure = "too few landmarks (" + std::to_string(obs.size()) + " < " +
                  std::to_string(opt.min_landmarks) + ")";
    return res;
  }
  // Paper section 2: heading by Newton-Raphson on Eqn 2, then Eqn 1.
  double heading;
  Eigen::Vector2d position;
  double s;
  if (!HeadingNewtonRaphson(obs, prior.theta, &heading) ||
      !PositionFromBearings(obs, heading, &position, &s)) {
    res.failure = "degenerate geometry: the bearing lines are (nearly) parallel";
    return res;
  }
  Pose2 pose{position.x(), position.y(), heading};
  std::vector<int> use(obs.size());
  for (size_t i = 0; i < obs.size(); ++i) use[i] = static_cast<int>(i);
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  double min_eig = 0.0;
  if (opt.refine) {
    while (true) {
      Pose2 trial = pose;
      if (!RefineOnBearings(obs, use, opt, &trial, &info, &min_eig)) {
        res.failure = "degenerate geometry: landmarks nearly in line with the camera";
        return res;
      }
      pose = trial;
      // Drop the worst outlier, if any, and solve again.
      int worst = -1;
      double worst_r = opt.outlier_threshold;
      for (size_t k = 0; k < use.size(); ++k) {
        const BearingObservation& o = obs[use[k]];
        const double r = std::abs(WrapAngle(
            FastAtan2(o.landmark.y() - pose.y, o.landmark.x() - pose.x) - pose.theta - o.bearing)) / o.spread;
        if (r > worst_r) {
          worst_r = r;
          worst = static_cast<int>(k);
        }
      }
      if (worst < 0) break;
      if (static_cast<int>(use.size()) <= opt.min_landmarks) {
        res.failure = "inconsistent bearings: an outlier remains with only " +
                      std::to_string(use.size()) + " landmarks";
        return res;
      }
      use.erase(use.begin() + worst);
    }
  } else {
    // Degeneracy check for the paper's solve alone.
    std::vector<BearingObservation> sub = obs;
    Pose2 trial = pose;
    TriangulationOptions o2 = opt;
    if (!RefineOnBearings(sub, use, o2, &trial, &info, &min_eig)) {
      res.failure = "degenerate geometry: landmarks nearly in line with the camera";
      return res;
    }
  }
  // Every landmark must lie in front along its bearing (not behind the
  // camera: the bearing lines alone cannot tell).
  for (int i : use) {
    const BearingObservation& o = obs[i];
    const double phi = o.bearing + pose.theta;
    if ((o.landmark.x() - pose.x) * std::cos(phi) + (o.landmark.y() - pose.y) * std::sin(phi) <= 0) {
      res.failure = "no consistent pose: a landmark would lie behind its bearing";
      return res;
    }
  }
  res.ok = true;
  res.pose = pose;
  res.inliers = use;
  res.bearing_residuals.resize(obs.size());
  double sum_d2 = 0.0, sum_r2 = 0.0, sum_w = 0.0;
  for (size_t i = 0; i < obs.size(); ++i) {
    const BearingObservation& o = obs[i];
    res.bearing_residuals[i] = WrapAngle(
        FastAtan2(o.landmark.y() - pose.y, o.landmark.x() - pose.x) - pose.theta - o.bearing);
  }
  for (int i : use) {
    double a, b, c;
    Line(obs[i], pose.theta, &a, &b, &c);
    const double d = a * pose.x + b * pose.y + c;
    sum_d2 += d * d;
    sum_r2 += obs[i].weight * res.bearing_residuals[i] * res.bearing_residuals[i];
    sum_w += obs[i].weight;
  }
  res.residual = std::sqrt(sum_d2 / use.size());
  res.rms_bearing = std::sqrt(sum_r2 / sum_w);
  // First-order covariance: sigma^2 (J^T W J)^-1, sigma from the residuals
  // when there are spare degrees of freedom, else the configured sigma.
  const int dof = DistinctBearings(obs, use) - 3;
  const double sigma2 = dof >= 2 ? sum_r2 / dof : opt.bearing_sigma * opt.bearing_sigma;
  res.covariance = sigma2 * info.inverse();
  res.variance_factor = sigma2;
  return res;
}

}  // namespace pano

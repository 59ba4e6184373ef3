// Robust pose from landmark bearings, layered like PoseLib: minimal solvers,
// a consensus loop over their hypotheses, the existing least-squares solve
// (pose/triangulate.h) as the refinement, and an integrity check of the
// result (chi-square of the bearing residuals, geometric strength, quality).
//
// Conventions as pose/triangulate.h: a robot at (x, y, theta) sees landmark L
// at the sensor-frame bearing b = atan2(Ly - y, Lx - x) - theta.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "panotrack/core/angles.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/pose/triangulate.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

// ---------------------------------------------------------------------------
// Minimal solvers.
//
// Three bearings, heading unknown (resection). In the sensor frame the
// landmark is Ls = R(-theta) L + t with t = -R(-theta) p, and it lies along
// e = (cos b, sin b): cross(Ls, e) = 0. Written out,
//   cos(theta) (Lx sin b - Ly cos b) + sin(theta) (Lx cos b + Ly sin b)
//     + tx sin b - ty cos b = 0,
// which is LINEAR and homogeneous in (cos theta, sin theta, tx, ty). Three
// bearings give a 3 x 4 system whose null vector (the 3 x 3 minors) is the
// solution up to scale; cos^2 + sin^2 = 1 fixes the scale up to sign, and the
// sign (theta or theta + pi: the same lines, reversed rays) is the one that
// puts every landmark in front along its bearing. So there is at most one
// pose: the classic result that the camera is the second intersection of two
// circles through the landmarks (inscribed angles). The system loses rank
// when the camera is on the circle through the three landmarks (the "danger
// circle", where every point of the circle sees the same angles) or when the
// landmarks and the camera are on one line; those are reported as no
// solution.
//
// Solve in coordinates centred on the landmarks and scaled to unit spread,
// so that the minors are well scaled whatever the map units.

// Relative size below which the minors of the normalised system count as
// zero (degenerate configuration).
constexpr double kMinimalDegenerateTol = 1e-9;

// Templated core: landmarks, bearings (radians), the pose (x, y, theta).
// Returns the number of solutions written (0 or 1).
template <typename T>
int SolvePoseFrom3BearingsT(const Eigen::Matrix<T, 2, 1> landmarks[3], const T bearings[3],
                            Eigen::Matrix<T, 3, 1>* pose, T degenerate_tol = T(kMinimalDegenerateTol));

// Two bearings and a known heading: the position is where the two bearing
// lines meet (a 2 x 2 solve). False when the lines are (nearly) parallel or
// a landmark would lie behind its bearing.
template <typename T>
bool SolvePoseFrom2BearingsT(const Eigen::Matrix<T, 2, 1> landmarks[2], const T bearings[2],
                             T heading, Eigen::Matrix<T, 3, 1>* pose,
                             T degenerate_tol = T(kMinimalDegenerateTol));

// Double front ends on the toolkit's types. The vector holds every solution
// (at most one, see above); empty when degenerate.
std::vector<Pose2> SolvePoseFrom3Bearings(const BearingObservation obs[3]);
bool SolvePoseFrom2Bearings(const BearingObservation obs[2], double heading, Pose2* pose);

// Bearing residual wrap(atan2(Ly - y, Lx - x) - theta - b) and, when
// `jacobian` is given, its derivative by (x, y, theta).
double BearingResidual(const BearingObservation& o, const Pose2& pose,
                       Eigen::Vector3d* jacobian = nullptr);

// The leverage of each of tri.inliers (in that order) on the weighted
// least-squares pose at tri.pose: the diagonal of the hat matrix, the share
// of its own error a bearing's residual loses to the fit (they sum to 3; 0
// each where the pose is not determined). Huber's down-weighting is not in it.
std::vector<double> BearingLeverages(const std::vector<BearingObservation>& obs, const TriangulationResult& tri);

// Baarda's w-statistic of each of tri.inliers (in that order): its residual
// over the standard deviation a residual of that bearing has (a bearing of
// unit weight has standard deviation `sigma`, radians; the fit absorbs the
// share of it its leverage says). The corners of one edge (one group) are
// one bearing: each gets the statistic of their weighted mean. Unlike the
// residual itself it finds a bearing that pulled the pose towards itself
// (one the pose rests on almost alone leaves a small residual). NaN where
// the fit absorbs nearly all of a bearing's error (a leverage above
// max_leverage: its error cannot be seen) or the pose is not determined.
std::vector<double> StandardizedResiduals(const std::vector<BearingObservation>& obs, const TriangulationResult& tri,
                                          double sigma, double max_leverage = 0.95);

// Solution separation: the largest shift of the position (map units) when
// one distinct bearing (a group, or a bearing of its own) of tri.inliers is
// left out, each subset's pose one Gauss-Newton step from tri.pose (weighted,
// Huber's down-weighting not in it). One wrong bearing among a few pulls the
// full pose by about the shift its removal undoes, however well the rest
// absorbs its residual. Infinite where a subset's pose is not determined
// (fewer than three distinct bearings left, or a degenerate geometry).
double SolutionSeparation(const std::vector<BearingObservation>& obs, const TriangulationResult& tri);

// ---------------------------------------------------------------------------
// Robust consensus loop.

struct RobustPoseOptions {
  // Bearings within this of a hypothesis support it (MSAC: each bearing
  // costs min(r^2, threshold^2)). Ten times a good tracker's 0.05 degree
  // noise, and well below the few degrees of a wrong junction.
  double inlier_threshold = 0.5 * M_PI / 180;
  // Up to this many observations every triple is tried (12 gives 220),
  // beyond it random triples.
  int max_exhaustive_landmarks = 12;
  // Random sampling: stop once the chance of never having drawn an all-
  // inlier triple, at the best inlier ratio so far, is below
  // 1 - success_probability; between min_samples and max_samples triples.
  double success_probability = 0.9999;
  int min_samples = 50;
  int max_samples = 2000;
  uint64_t seed = 0x5eed;
  // > 0: prior.theta is a heading measurement (motion model, compass) with
  // this standard deviation, and every pair of bearings with that heading
  // is a hypothesis too (useful when few landmarks are left).
  double prior_heading_sigma = 0.0;
  // When set, hypotheses whose squared Mahalanobis distance from the prior
  // (with prior_covariance) exceeds the chi-square quantile (3 dof) at
  // prior_gate_confidence are discarded. Off unless the caller asks: a
  // wrong prior must not veto the right pose.
  bool gate_with_prior = false;
  Eigen::Matrix3d prior_covariance = Eigen::Matrix3d::Identity();
  double prior_gate_confidence = 0.999;
  // Refine on the consensus set, re-select the inliers among all bearings
  // against the refined pose, and refine again, up to this many times.
  int refine_iterations = 2;
  // So many best hypotheses with distinct consensus sets are refined; the
  // refined pose of lowest MSAC cost wins. More than one settles near-ties
  // between the true consensus and a coincidental one (an outlier that fits
  // a wrong pose with some inliers).
  int local_optimisations = 3;
  void Check() const;
};

struct RobustTriangulationResult : TriangulationResult {
  int hypotheses = 0;         // minimal solutions scored
  int hypotheses_gated = 0;   // discarded by the prior gate
  int samples = 0;            // minimal samples drawn (triples and pairs)
  // Of the hypothesis whose refinement won:
  double best_cost = 0.0;     // MSAC cost of the refined pose (rad^2)
  int consensus = 0;          // its inliers before refinement
  bool from_heading_prior = false;  // it came from a pair and the prior heading
  Pose2 hypothesis;           // the minimal solution, before refinement
  int refinements = 0;        // Triangulate calls made, all hypotheses
};

// Deterministic for a given input and options. On success `inliers` and
// `bearing_residuals` index `obs` (all of them); the pose, covariance and
// residual columns are those of Triangulate on the final inlier set.
RobustTriangulationResult RobustTriangulate(
    const std::vector<BearingObservation>& obs, const Pose2& prior,
    const RobustPoseOptions& options = RobustPoseOptions(),
    const TriangulationOptions& triangulation = TriangulationOptions());

// ---------------------------------------------------------------------------
// Chi-square distribution (no Boost in the toolkit's dependencies).

// Standard normal quantile (Acklam's rational approximation and one Halley
// step: relative error near 1e-15).
double NormalQuantile(double p);
// P(X <= x) and P(X > x) for X ~ chi-square(dof), via the regularised
// incomplete gamma function (series below a + 1, continued fraction above).
double ChiSquareCdf(double x, int dof);
double ChiSquareSurvival(double x, int dof);
// Wilson-Hilferty: chi-square(k) ~ k (1 - 2/(9k) + z sqrt(2/(9k)))^3.
// In the upper tail (0.95 to 0.999) within 3 % at 1 dof, 0.3 % from 20
// dof: good enough to seed the exact solve, not to replace it.
double ChiSquareQuantileWilsonHilferty(double p, int dof);
// The quantile, Wilson-Hilferty polished by safeguarded Newton on the CDF.
double ChiSquareQuantile(double p, int dof);

// ---------------------------------------------------------------------------
// Integrity.

struct IntegrityOptions {
  double sigma_bearing = 0.05 * M_PI / 180;  // expected bearing noise (rad)
  double confidence = 0.999;                  // of the chi-square test
  // Predicted position std (map units) at which the geometry factor of the
  // quality is one half.
  double reference_position_std = 1.0;
  // Spare inliers (beyond the 3 a pose needs) at which the redundancy
  // factor of the quality is one half.
  double reference_redundancy = 3.0;
  // Protection: the pose's error bound, protection_sigmas times the largest
  // position std of its own covariance (from its residuals), must be within
  // the alert limit, alert_fraction of the mean distance to its inlier
  // landmarks. A pose resting on a weak geometry or a few noisy bearings is
  // then not reported, however well its residuals fit. 0 switches it off.
  double protection_sigmas = 5.0;
  double alert_fraction = 0.01;
  // Added to that limit (map units): the error the map itself allows.
  double alert_margin = 0.0;
  // Above 0: the alert limit itself (map units), instead of the two above.
  double alert_limit = 0.0;
  void Check() const;
};

struct IntegrityReport {
  int observations = 0;
  int inliers = 0;
  int dof = 0;               // distinct inlier bearings (DistinctBearings) - 3
  bool testable = false;     // dof >= 1: the residuals can be checked at all
  double chi2 = 0.0;         // sum w_i r_i^2 / sigma^2 over the inliers
  double chi2_threshold = 0.0;  // quantile at `confidence`, dof
  double p_value = 1.0;      // P(chi-square(dof) > chi2)
  bool consistent = false;   // testable and chi2 <= chi2_threshold
  // Predicted from sigma_bearing at the pose (first order): the largest
  // position std (sqrt of the largest eigenvalue of the position block) and
  // the heading std; the normal matrix's condition number with the position
  // rows scaled by the RMS landmark distance (unit free).
  double position_std = 0.0;
  double heading_std = 0.0;
  double condition = 0.0;
  // protection_sigmas x the largest position std of the result's covariance,
  // and alert_fraction x the mean inlier landmark distance (map units).
  double protection_level = 0.0;
  double alert_limit = 0.0;
  bool within_alert_limit = true;
  // Quality in [0, 1] for the pose CSV: the product of
  //   inlier fraction     inliers / observations,
  //   redundancy          dof / (dof + reference_redundancy),
  //   consistency         min(1, p_value / (1 - confidence)): 1 whenever the
  //                       test passes, falling to 0 as it fails harder,
  //   geometry            1 / (1 + (position_std / reference_position_std)^2).
  // Each factor is non-decreasing in the evidence (more inliers, smaller
  // residuals, stronger geometry), so is the product; 0 when not ok or
  // degenerate.
  double quality = 0.0;
};

IntegrityReport IntegrityCheck(const TriangulationResult& result,
                               const std::vector<BearingObservation>& obs,
                               const IntegrityOptions& options = IntegrityOptions());

// Squared Mahalanobis distance of `pose` from `predicted` with covariance
// (x, y, theta), the heading difference wrapped to (-pi, pi]: compare with
// ChiSquareQuantile(confidence, 3) to gate an innovation. Infinite when the
// covariance is not positive definite.
double PoseMahalanobis2(const Pose2& pose, const Pose2& predicted, const Eigen::Matrix3d& covariance);

// ---------------------------------------------------------------------------
// Template definitions.

namespace robust_pose_detail {

template <typename T>
T Det3(const Eigen::Matrix<T, 3, 3>& m) {
  return m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1)) -
         m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0)) +
         m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
}

}  // namespace robust_pose_detail

template <typename T>
int SolvePoseFrom3BearingsT(const Eigen::Matrix<T, 2, 1> landmarks[3], const T bearings[3],
                            Eigen::Matrix<T, 3, 1>* pose, T degenerate_tol) {
  using std::abs;
  using std::atan2;
  using std::cos;
  using std::sin;
  using std::sqrt;
  using Vec2 = Eigen::Matrix<T, 2, 1>;
  // Centre and scale the landmarks (conditioning, units).
  const Vec2 centre = (landmarks[0] + landmarks[1] + landmarks[2]) / T(3);
  T spread = T(0);
  for (int i = 0; i < 3; ++i) spread += (landmarks[i] - centre).squaredNorm();
  spread = sqrt(spread / T(3));
  if (!(spread > T(0))) return 0;
  Vec2 local[3];
  Eigen::Matrix<T, 3, 4> m;
  for (int i = 0; i < 3; ++i) {
    local[i] = (landmarks[i] - centre) / spread;
    const T cb = cos(bearings[i]), sb = sin(bearings[i]);
    const T lx = local[i].x(), ly = local[i].y();
    m.row(i) << lx * sb - ly * cb, lx * cb + ly * sb, sb, -cb;
    m.row(i) /= m.row(i).norm();  // each row is at least (sb, -cb): norm >= 1
  }
  // Null vector of m: the signed 3 x 3 minors (generalised cross product).
  Eigen::Matrix<T, 4, 1> n;
  for (int k = 0; k < 4; ++k) {
    Eigen::Matrix<T, 3, 3> minor;
    for (int c = 0, col = 0; c < 4; ++c)
      if (c != k) minor.col(col++) = m.col(c);
    n[k] = (k % 2 == 0 ? T(1) : T(-1)) * robust_pose_detail::Det3(minor);
  }
  const T rot_norm = sqrt(n[0] * n[0] + n[1] * n[1]);
  if (!(rot_norm > degenerate_tol)) return 0;
  n /= rot_norm;
  // Sign: every landmark in front along its bearing, e . Ls > 0.
  T front[3];
  T sum_front = T(0);
  for (int i = 0; i < 3; ++i) {
    const T c = n[0], s = n[1];
    const Vec2 ls(c * local[i].x() + s * local[i].y() + n[2], -s * local[i].x() + c * local[i].y() + n[3]);
    front[i] = cos(bearings[i]) * ls.x() + sin(bearings[i]) * ls.y();
    sum_front += front[i];
  }
  if (sum_front < T(0)) {
    n = -n;
    for (T& f : front) f = -f;
  }
  for (const T& f : front)
    if (!(f > T(0))) return 0;
  // p = -R(theta) t, back to world units.
  const T c = n[0], s = n[1];
  const Vec2 p_local(-(c * n[2] - s * n[3]), -(s * n[2] + c * n[3]));
  const Vec2 p = centre + spread * p_local;
  *pose << p.x(), p.y(), atan2(s, c);
  return 1;
}

template <typename T>
bool SolvePoseFrom2BearingsT(const Eigen::Matrix<T, 2, 1> landmarks[2], const T bearings[2],
                             T heading, Eigen::Matrix<T, 3, 1>* pose, T degenerate_tol) {
  using std::abs;
  using std::cos;
  using std::sin;
  using Vec2 = Eigen::Matrix<T, 2, 1>;
  // p = L_i - lambda_i d_i with lambda_i > 0 (the range along the ray):
  // lambda_0 d_0 - lambda_1 d_1 = L_0 - L_1.
  const Vec2 d0(cos(bearings[0] + heading), sin(bearings[0] + heading));
  const Vec2 d1(cos(bearings[1] + heading), sin(bearings[1] + heading));
  const T det = -d0.x() * d1.y() + d1.x() * d0.y();  // = -sin(b1 - b0)
  if (!(abs(det) > degenerate_tol)) return false;
  const Vec2 rhs = landmarks[0] - landmarks[1];
  const T lambda0 = (-rhs.x() * d1.y() + d1.x() * rhs.y()) / det;
  const T lambda1 = (d0.x() * rhs.y() - d0.y() * rhs.x()) / det;
  if (!(lambda0 > T(0)) || !(lambda1 > T(0))) return false;
  const Vec2 p = landmarks[0] - lambda0 * d0;
  *pose << p.x(), p.y(), WrapAngle(heading);
  return true;
}

}  // namespace pano

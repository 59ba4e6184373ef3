#include "panotrack/mapping/refine.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "panotrack/core/angles.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/scene/scene.h"
#include "panotrack/sensor/catadioptric.h"
#include "panotrack/video/frame_source.h"

namespace pano {

const std::array<const char*, kRectangleParams> kRectangleParamNames = {"from_x", "from_y", "to_x",
                                                                       "to_y",   "z0",     "z1"};

void RefineOptions::Check() const {
  if (!(map_sigma > 0.0) || !std::isfinite(map_sigma)) throw Error("map_sigma: expected a positive number");
  if (passes < 1 || passes > 10) throw Error("passes: expected 1..10");
  if (!(search_px > 0.0) || !(refine_search_px > 0.0)) throw Error("search_px: expected positive widths");
  if (min_corners_per_frame < 2) throw Error("min_corners_per_frame: expected at least 2");
  if (!(pose_sigma >= 0.0) || !std::isfinite(pose_sigma))
    throw Error("pose_sigma: expected 0 (none) or a positive number");
  if (!(loss_sigmas > 0.0)) throw Error("loss_sigmas: expected a positive number");
  if (!(reject_sigmas > loss_sigmas)) throw Error("reject_sigmas: expected more than loss_sigmas");
  if (!(min_edge_gap_px >= 0.0)) throw Error("min_edge_gap_px: expected 0 or more");
  if (!(radius_systematic_px >= 0.0) || !std::isfinite(radius_systematic_px))
    throw Error("radius_systematic_px: expected 0 or a positive number");
  if (!(initial_azimuth_sigma > 0.0) || !(initial_radius_sigma > 0.0))
    throw Error("initial sigmas: expected positive numbers");
  if (max_iterations < 1) throw Error("max_iterations: expected at least 1");
  CheckThreadCount(num_threads, "--threads (num_threads)");
  tracking.Check();
}

std::array<double, kRectangleParams> RectangleParams(const MapRectangle& r) {
  return {r.from.x(), r.from.y(), r.to.x(), r.to.y(), r.z0, r.z1};
}

void SetRectangleParams(const std::array<double, kRectangleParams>& p, MapRectangle* r) {
  r->from = {p[0], p[1]};
  r->to = {p[2], p[3]};
  r->z0 = p[4];
  r->z1 = p[5];
}

namespace {

// Landmarks of rectangle k are 4k..4k+3 in LandmarksFromMap's order:
// from-bottom, from-top, to-bottom, to-top.
int CornerEnd(int landmark) { return (landmark % 4) / 2; }    // 0 from, 1 to
int CornerLevel(int landmark) { return landmark % 2; }        // 0 z0, 1 z1

// The measurement a corner at world `X` gives from `pose` with the pinhole
// `h` above the floor: the image azimuth (radius false) or the image radius.
template <typename T>
bool PredictMeasurement(const SensorParams<double>& sensor, const T* pose, const T* X, const T& h,
                        bool radius, T* out) {
  using std::atan2;
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T dx = X[0] - pose[0], dy = X[1] - pose[1];
  const T c = cos(pose[2]), s = sin(pose[2]);
  const T xs = c * dx + s * dy, ys = -s * dx + c * dy;
  if (!radius) {
    *out = atan2(ys, xs) + T(sensor.azimuth_offset);
    return true;
  }
  const T D = sqrt(xs * xs + ys * ys);
  return ImageRadius(sensor.cast<T>(), D, T(X[2] - h), out);
}

template <typename T>
T Residual(const T& predicted, double measured, bool radius, double sigma) {
  T d = predicted - T(measured);
  if (!radius) d -= T(2.0 * M_PI * std::round(ScalarValue(d) / (2.0 * M_PI)));
  return d / T(sigma);
}

// A corner of a rectangle being adjusted.
struct RectangleCornerCost {
  SensorParams<double> sensor;
  int end = 0, level = 0;
  bool radius = false;
  double measured = 0.0, sigma = 1.0;
  template <typename T>
  bool operator()(const T* pose, const T* rect, const T* height, T* residual) const {
    const T X[3] = {rect[2 * end], rect[2 * end + 1], rect[4 + level]};
    T predicted;
    if (!PredictMeasurement(sensor, pose, X, height[0], radius, &predicted)) return false;
    residual[0] = Residual(predicted, measured, radius, sigma);
    return true;
  }
};

// A box corner: fixed in the map, it still ties the poses and the height.
struct FixedCornerCost {
  SensorParams<double> sensor;
  Eigen::Vector3d corner;
  bool radius = false;
  double measured = 0.0, sigma = 1.0;
  template <typename T>
  bool operator()(const T* pose, const T* height, T* residual) const {
    const T X[3] = {T(corner.x()), T(corner.y()), T(corner.z())};
    T predicted;
    if (!PredictMeasurement(sensor, pose, X, height[0], radius, &predicted)) return false;
    residual[0] = Residual(predicted, measured, radius, sigma);
    return true;
  }
};

// The survey: each rectangle parameter at its surveyed value, sigma map_sigma.
struct PriorCost {
  std::array<double, kRectangleParams> surveyed;
  double sigma = 1.0;
  template <typename T>
  bool operator()(const T* rect, T* residual) const {
    for (int i = 0; i < kRectangleParams; ++i) residual[i] = (rect[i] - T(surveyed[i])) / T(sigma);
    return true;
  }
};

// An absolute reference: the pose's position at its CSV value.
struct PosePriorCost {
  double x = 0.0, y = 0.0, sigma = 1.0;
  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    residual[0] = (pose[0] - T(x)) / T(sigma);
    residual[1] = (pose[1] - T(y)) / T(sigma);
    return true;
  }
};

// 1.4826 x the median absolute value: the noise sigma of residuals with outliers.
double RobustSigma(std::vector<double> v, double fallback) {
  if (v.size() < 8) return fallback;
  for (double& x : v) x = std::abs(x);
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  const double s = 1.4826 * v[v.size() / 2];
  return s > 0.0 ? s : fallback;
}

// The adjustment's unknowns in one buffer: the rectangles, the poses, then
// the sensor height. Ceres's covariance orders the parameter blocks by their
// addresses: in separate allocations that order (and the deviations' last
// digits) would change from run to run with where the allocator put them.
class Unknowns {
 public:
  Unknowns(const Map& surveyed, const std::vector<Pose2>& poses)
      : n_rects_(surveyed.rectangles.size()), values_(n_rects_ * kRectangleParams + 3 * poses.size() + 1) {
    for (size_t k = 0; k < n_rects_; ++k) {
      const std::array<double, kRectangleParams> r = RectangleParams(surveyed.rectangles[k]);
      std::copy(r.begin(), r.end(), rect(k));
    }
    for (size_t f = 0; f < poses.size(); ++f) {
      pose(f)[0] = poses[f].x;
      pose(f)[1] = poses[f].y;
      pose(f)[2] = poses[f].theta;
    }
    *height() = surveyed.sensor_height;
  }
  size_t n_rects() const { return n_rects_; }
  size_t n_poses() const { return (values_.size() - 1 - n_rects_ * kRectangleParams) / 3; }
  double* rect(size_t k) { return &values_[k * kRectangleParams]; }
  const double* rect(size_t k) const { return &values_[k * kRectangleParams]; }
  std::array<double, kRectangleParams> RectArray(size_t k) const {
    std::array<double, kRectangleParams> r;
    std::copy(rect(k), rect(k) + kRectangleParams, r.begin());
    return r;
  }
  double* pose(size_t f) { return &values_[n_rects_ * kRectangleParams + 3 * f]; }
  const double* pose(size_t f) const { return &values_[n_rects_ * kRectangleParams + 3 * f]; }
  double* height() { return &values_.back(); }
  double height_value() const { return values_.back(); }

 private:
  size_t n_rects_;
  std::vector<double> values_;
};

// Raw (unscaled) residuals of every observation at `u`: azimuth and radius.
void RawResiduals(const SensorParams<double>& sensor, const std::vector<Landmark>& landmarks, const Unknowns& u,
                  const std::vector<CornerObservation>& obs, std::vector<double>* az, std::vector<double>* rad) {
  az->clear();
  rad->clear();
  const int n_rect_landmarks = static_cast<int>(u.n_rects()) * 4;
  for (const CornerObservation& o : obs) {
    double X[3];
    if (o.landmark < n_rect_landmarks) {
      const double* r = u.rect(static_cast<size_t>(o.landmark / 4));
      X[0] = r[2 * CornerEnd(o.landmark)];
      X[1] = r[2 * CornerEnd(o.landmark) + 1];
      X[2] = r[4 + CornerLevel(o.landmark)];
    } else {
      const Eigen::Vector3d& c = landmarks[static_cast<size_t>(o.landmark)].corner;
      X[0] = c.x();
      X[1] = c.y();
      X[2] = c.z();
    }
    const double* pose = u.pose(static_cast<size_t>(o.frame));
    double a, r;
    PredictMeasurement(sensor, pose, X, u.height_value(), false, &a);
    az->push_back(WrapAngle(a - o.azimuth));
    rad->push_back(PredictMeasurement(sensor, pose, X, u.height_value(), true, &r) ? r - o.radius : std::nan(""));
  }
}

std::vector<double> Finite(const std::vector<double>& v, const std::vector<char>* keep = nullptr) {
  std::vector<double> out;
  for (size_t i = 0; i < v.size(); ++i)
    if (std::isfinite(v[i]) && (!keep || (*keep)[i])) out.push_back(v[i]);
  return out;
}

// The gauge's covariance from the priors alone: the survey's coordinates
// (sigma map_sigma each) and the poses' positions (sigma pose_sigma). The
// gauge moves a point p (about the corners' centroid c, height above the
// sensor dz) by (tx - w (y - cy) + s (x - cx), ty + w (x - cx) + s (y - cy),
// s dz): shift, turn and, with a free height, scale.
void GaugeUncertainty(const Map& surveyed, const std::vector<std::array<double, 3>>& prior_poses,
                      const RefineOptions& opt, RefineResult* res) {
  const int n = opt.free_height ? 4 : 3;
  std::vector<Eigen::Vector3d> corners;
  for (const MapRectangle& r : surveyed.rectangles)
    for (int c = 0; c < 4; ++c)
      corners.push_back({(c / 2 ? r.to : r.from).x(), (c / 2 ? r.to : r.from).y(),
                         (c % 2 ? r.z1 : r.z0) - surveyed.sensor_height});
  if (corners.empty()) return;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3d& p : corners) centre += p.head<2>();
  centre /= static_cast<double>(corners.size());
  auto rows = [&](double x, double y, double dz, Eigen::MatrixXd* J) {
    J->setZero(3, n);
    (*J)(0, 0) = 1.0;
    (*J)(0, 2) = -(y - centre.y());
    (*J)(1, 1) = 1.0;
    (*J)(1, 2) = x - centre.x();
    if (n == 4) {
      (*J)(0, 3) = x - centre.x();
      (*J)(1, 3) = y - centre.y();
      (*J)(2, 3) = dz;
    }
  };
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(n, n), J;
  const double wm = 1.0 / (opt.map_sigma * opt.map_sigma);
  for (const MapRectangle& r : surveyed.rectangles) {
    for (const Eigen::Vector2d& e : {r.from, r.to}) {
      rows(e.x(), e.y(), 0.0, &J);
      info += wm * J.topRows(2).transpose() * J.topRows(2);
    }
    for (int level = 0; level < 2; ++level) {
      if (level == 0 && opt.hold_floor_contacts && r.z0 == 0.0) continue;  // held, no prior
      rows(0.0, 0.0, (level ? r.z1 : r.z0) - surveyed.sensor_height, &J);
      info += wm * J.row(2).transpose() * J.row(2);
    }
  }
  if (opt.pose_sigma > 0.0)
    for (const auto& p : prior_poses) {
      rows(p[0], p[1], 0.0, &J);
      info += J.topRows(2).transpose() * J.topRows(2) / (opt.pose_sigma * opt.pose_sigma);
    }
  const Eigen::MatrixXd cov = info.inverse();
  res->gauge_shift_std = std::sqrt(0.5 * (cov(0, 0) + cov(1, 1)));
  res->gauge_turn_std = std::sqrt(cov(2, 2));
  res->gauge_scale_std = n == 4 ? std::sqrt(cov(3, 3)) : 0.0;
  double sum = 0.0;
  for (const Eigen::Vector3d& p : corners) {
    rows(p.x(), p.y(), p.z(), &J);
    sum += (J * cov * J.transpose()).trace();
  }
  res->gauge_corner_rms = std::sqrt(sum / static_cast<double>(corners.size()));
}

// Each corner's radius sigma: the frame's noise plus a systematic part
// shared by all its n radius measurements (taken as fully correlated, so the
// n together weigh at most like one measurement of sigma `systematic`):
// sqrt(noise^2 + n systematic^2). The radius changes little with distance, so
// without this hundreds of frames turn a bias of a few hundredths of a pixel
// into a depth error that outweighs the azimuths' triangulation.
std::vector<double> CornerRadiusSigmas(const std::vector<CornerObservation>& obs, const std::vector<char>& use_r,
                                       const std::vector<char>& frame_used, size_t n_landmarks, double noise,
                                       double systematic) {
  std::vector<int> count(n_landmarks, 0);
  for (size_t i = 0; i < obs.size(); ++i)
    if (use_r[i] && frame_used[static_cast<size_t>(obs[i].frame)]) ++count[static_cast<size_t>(obs[i].landmark)];
  std::vector<double> sigma(n_landmarks);
  for (size_t k = 0; k < n_landmarks; ++k)
    sigma[k] = std::sqrt(noise * noise + count[k] * systematic * systematic);
  return sigma;
}

double Rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

}  // namespace

namespace {

// The refined map states how well its corners are now known, for the
// localiser: each rectangle the RMS standard deviation of its floor
// coordinates (their gauge included), the map the RMS over its rectangles;
// boxes, not refined, keep what the survey stated.
void StateRefinedSurveySigma(const Map& surveyed, RefineResult* res) {
  if (!res->covariance_ok) return;
  double sum = 0.0;
  int n = 0;
  for (size_t k = 0; k < res->landmarks.size(); ++k) {
    const auto& sd = res->landmarks[k].std;
    const double sigma = std::sqrt((sd[0] * sd[0] + sd[1] * sd[1] + sd[2] * sd[2] + sd[3] * sd[3]) / 4.0);
    if (!std::isfinite(sigma)) continue;
    res->map.rectangles[k].survey_sigma = sigma;
    sum += sigma * sigma;
    ++n;
  }
  if (n == 0) return;
  for (size_t k = 0; k < res->map.boxes.size(); ++k) res->map.boxes[k].survey_sigma = surveyed.BoxSurveySigma(k);
  res->map.survey_sigma = std::sqrt(sum / n);
}

}  // namespace

namespace {

// What enters one solve: the measurements kept, the frames used, and the
// noise sigmas the measurements are weighted by.
struct SolveInputs {
  std::vector<char> use_az, use_r, frame_used;
  double sigma_az = 0.0, sigma_r = 0.0;
};

// The problem of one solve: every kept azimuth and radius of the frames used
// (Huber loss), the poses' priors (pose_sigma), the survey's priors on the
// rectangles, floor contacts held, the height held unless free.
std::unique_ptr<ceres::Problem> BuildRefinementProblem(const SensorParams<double>& sensor, const Map& surveyed,
                                                       const std::vector<Landmark>& landmarks,
                                                       const std::vector<Pose2>& poses,
                                                       const std::vector<CornerObservation>& observations,
                                                       const SolveInputs& in, const RefineOptions& opt,
                                                       Unknowns* u) {
  const int n_rect = static_cast<int>(surveyed.rectangles.size());
  const std::vector<double> radius_sigma = CornerRadiusSigmas(observations, in.use_r, in.frame_used, landmarks.size(),
                                                              in.sigma_r, opt.radius_systematic_px);
  ceres::Problem::Options po;
  auto problem = std::make_unique<ceres::Problem>(po);
  for (size_t i = 0; i < observations.size(); ++i) {
    const CornerObservation& o = observations[i];
    if (!in.frame_used[static_cast<size_t>(o.frame)]) continue;
    double* pose = u->pose(static_cast<size_t>(o.frame));
    for (bool radius : {false, true}) {
      if (!(radius ? in.use_r[i] : in.use_az[i])) continue;
      const double sigma = radius ? radius_sigma[static_cast<size_t>(o.landmark)] : in.sigma_az;
      const double measured = radius ? o.radius : o.azimuth;
      ceres::LossFunction* loss = new ceres::HuberLoss(opt.loss_sigmas);
      if (o.landmark < 4 * n_rect) {
        auto* f = new RectangleCornerCost{sensor, CornerEnd(o.landmark), CornerLevel(o.landmark), radius,
                                          measured, sigma};
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<RectangleCornerCost, 1, 3, kRectangleParams, 1>(f), loss, pose,
            u->rect(static_cast<size_t>(o.landmark / 4)), u->height());
      } else {
        auto* f = new FixedCornerCost{sensor, landmarks[static_cast<size_t>(o.landmark)].corner, radius,
                                      measured, sigma};
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<FixedCornerCost, 1, 3, 1>(f), loss, pose,
                                  u->height());
      }
    }
  }
  for (size_t f = 0; f < poses.size(); ++f)
    if (in.frame_used[f] && opt.pose_sigma > 0.0)
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PosePriorCost, 2, 3>(
                                    new PosePriorCost{poses[f].x, poses[f].y, opt.pose_sigma}),
                                nullptr, u->pose(f));
  for (int k = 0; k < n_rect; ++k) {
    auto* prior = new PriorCost{RectangleParams(surveyed.rectangles[static_cast<size_t>(k)]), opt.map_sigma};
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PriorCost, kRectangleParams, kRectangleParams>(prior),
                              nullptr, u->rect(static_cast<size_t>(k)));
  }
  if (opt.hold_floor_contacts)
    for (int k = 0; k < n_rect; ++k)
      if (surveyed.rectangles[static_cast<size_t>(k)].z0 == 0.0)
        problem->SetManifold(u->rect(static_cast<size_t>(k)), new ceres::SubsetManifold(kRectangleParams, {4}));
  if (problem->HasParameterBlock(u->height()) && !opt.free_height) problem->SetParameterBlockConstant(u->height());
  if (opt.fix_first_pose)
    for (size_t f = 0; f < poses.size(); ++f)
      if (in.frame_used[f]) {
        problem->SetParameterBlockConstant(u->pose(f));
        break;
      }
  return problem;
}

void Solve(const RefineOptions& opt, ceres::Problem* problem) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.max_num_iterations = opt.max_iterations;
  // One Ceres thread: its threaded Schur elimination sums in an order that
  // varies from run to run, and the same poses must give the same map.
  so.num_threads = 1;
  so.function_tolerance = 1e-10;
  so.parameter_tolerance = 1e-10;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("map refinement failed: " + summary.message);
}

// Noise sigmas from the measurements kept (robust scale), then the
// measurements within reject_sigmas of them kept; returns whether that set
// changed.
bool UpdateMeasurementSet(const std::vector<double>& az, const std::vector<double>& rad, const RefineOptions& opt,
                          SolveInputs* in) {
  in->sigma_az = RobustSigma(Finite(az, &in->use_az), in->sigma_az);
  in->sigma_r = RobustSigma(Finite(rad, &in->use_r), in->sigma_r);
  bool changed = false;
  for (size_t i = 0; i < az.size(); ++i) {
    const char keep_az = std::abs(az[i]) <= opt.reject_sigmas * in->sigma_az;
    const char keep_r = std::isfinite(rad[i]) && std::abs(rad[i]) <= opt.reject_sigmas * in->sigma_r;
    changed = changed || keep_az != in->use_az[i] || keep_r != in->use_r[i];
    in->use_az[i] = keep_az;
    in->use_r[i] = keep_r;
  }
  return changed;
}

// Standard deviations of the rectangles (and the height, into
// res->sensor_height_std) from the last solve; NaN where the covariance
// cannot be computed (res->covariance_ok false).
std::vector<std::array<double, kRectangleParams>> RectangleDeviations(const RefineOptions& opt,
                                                                      ceres::Problem* problem, Unknowns* u,
                                                                      RefineResult* res) {
  std::vector<std::array<double, kRectangleParams>> stds(u->n_rects());
  for (auto& s : stds) s.fill(std::nan(""));
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.num_threads = 1;  // repeatable, as the solve
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (size_t k = 0; k < u->n_rects(); ++k) blocks.push_back({u->rect(k), u->rect(k)});
  if (opt.free_height) blocks.push_back({u->height(), u->height()});
  if (!cov.Compute(blocks, problem)) return stds;
  res->covariance_ok = true;
  for (size_t k = 0; k < u->n_rects(); ++k) {
    double c[kRectangleParams * kRectangleParams];
    cov.GetCovarianceBlock(u->rect(k), u->rect(k), c);
    for (int i = 0; i < kRectangleParams; ++i)
      stds[k][static_cast<size_t>(i)] = std::sqrt(std::max(0.0, c[i * kRectangleParams + i]));
  }
  if (opt.free_height) {
    double c;
    cov.GetCovarianceBlock(u->height(), u->height(), &c);
    res->sensor_height_std = std::sqrt(std::max(0.0, c));
  }
  return stds;
}

// One rectangle's correction: its observations, the move of each parameter
// (flagged beyond 3 survey sigmas) and of its corners.
LandmarkCorrection CorrectionOf(const MapRectangle& surveyed, const std::array<double, kRectangleParams>& refined,
                                const std::array<double, kRectangleParams>& deviation, int observations,
                                double map_sigma) {
  LandmarkCorrection lc;
  lc.id = surveyed.id;
  lc.observations = observations;
  lc.surveyed = RectangleParams(surveyed);
  lc.refined = refined;
  lc.std = deviation;
  for (int i = 0; i < kRectangleParams; ++i)
    if (std::abs(lc.refined[static_cast<size_t>(i)] - lc.surveyed[static_cast<size_t>(i)]) > 3.0 * map_sigma)
      lc.flagged = true;
  for (int c = 0; c < 4; ++c) {
    const int e = CornerEnd(c), l = CornerLevel(c);
    const double dx = lc.refined[static_cast<size_t>(2 * e)] - lc.surveyed[static_cast<size_t>(2 * e)];
    const double dy = lc.refined[static_cast<size_t>(2 * e + 1)] - lc.surveyed[static_cast<size_t>(2 * e + 1)];
    const double dz = lc.refined[static_cast<size_t>(4 + l)] - lc.surveyed[static_cast<size_t>(4 + l)];
    lc.max_corner_shift = std::max(lc.max_corner_shift, std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  return lc;
}

// The refined map, each rectangle's correction and the adjusted poses.
void CollectRefinement(const Map& surveyed, const std::vector<CornerObservation>& observations,
                       const SolveInputs& in, const std::vector<std::array<double, kRectangleParams>>& stds,
                       const RefineOptions& opt, const Unknowns& u, RefineResult* res) {
  const int n_rect = static_cast<int>(surveyed.rectangles.size());
  res->map = surveyed;
  res->map.sensor_height = u.height_value();
  std::vector<int> per_rect(static_cast<size_t>(n_rect), 0);
  for (size_t i = 0; i < observations.size(); ++i) {
    const CornerObservation& o = observations[i];
    if (o.landmark < 4 * n_rect && in.frame_used[static_cast<size_t>(o.frame)] && (in.use_az[i] || in.use_r[i]))
      ++per_rect[static_cast<size_t>(o.landmark / 4)];
  }
  for (size_t k = 0; k < static_cast<size_t>(n_rect); ++k) {
    SetRectangleParams(u.RectArray(k), &res->map.rectangles[k]);
    res->landmarks.push_back(CorrectionOf(surveyed.rectangles[k], u.RectArray(k), stds[k], per_rect[k], opt.map_sigma));
  }
  StateRefinedSurveySigma(surveyed, res);
  for (size_t f = 0; f < u.n_poses(); ++f) {
    const double* p = u.pose(f);
    res->poses.push_back({p[0], p[1], WrapAngle(p[2])});
  }
  for (char used : in.frame_used) res->frames_used += used;
}

}  // namespace

RefineResult SolveMapRefinement(const Calibration& calib, const Map& surveyed, const std::vector<Pose2>& poses,
                                const std::vector<CornerObservation>& observations, const RefineOptions& opt,
                                const std::vector<Pose2>* start) {
  opt.Check();
  if (observations.empty()) throw Error("no corner observations to refine the map from");
  if (start && start->size() != poses.size()) throw Error("SolveMapRefinement: start and poses differ in size");
  const std::vector<Landmark> landmarks = LandmarksFromMap(surveyed);
  const SensorParams<double>& sensor = calib.sensor.params;
  for (const CornerObservation& o : observations)
    if (o.frame < 0 || o.frame >= static_cast<int>(poses.size()) || o.landmark < 0 ||
        o.landmark >= static_cast<int>(landmarks.size()))
      throw Error("corner observation of frame " + std::to_string(o.frame) + ", landmark " +
                  std::to_string(o.landmark) + ": out of range");

  Unknowns u(surveyed, start ? *start : poses);
  RefineResult res;
  std::vector<double> az, rad;
  RawResiduals(sensor, landmarks, u, observations, &az, &rad);
  res.rms_azimuth_before = Rms(Finite(az));
  // Which measurements enter the solve: all at first, then those within
  // reject_sigmas of the last solution.
  const size_t n_obs = observations.size();
  SolveInputs in;
  in.use_az.assign(n_obs, 1);
  in.use_r.assign(n_obs, 1);
  in.frame_used.assign(poses.size(), 0);
  in.sigma_az = opt.initial_azimuth_sigma;
  in.sigma_r = opt.initial_radius_sigma;
  std::unique_ptr<ceres::Problem> problem;
  // The first solve with the initial noise sigmas and every measurement;
  // later ones with the sigmas measured on the last residuals and without
  // the outliers, until the set of measurements no longer changes.
  const int max_rounds = 6;
  for (int round = 0; round < max_rounds; ++round) {
    // A frame with too few azimuths left is dropped altogether (its pose
    // would be free).
    std::vector<int> azimuths(poses.size(), 0);
    for (size_t i = 0; i < n_obs; ++i) azimuths[static_cast<size_t>(observations[i].frame)] += in.use_az[i];
    for (size_t f = 0; f < poses.size(); ++f) in.frame_used[f] = azimuths[f] >= 3;
    problem = BuildRefinementProblem(sensor, surveyed, landmarks, poses, observations, in, opt, &u);
    Solve(opt, problem.get());
    RawResiduals(sensor, landmarks, u, observations, &az, &rad);
    const bool changed = UpdateMeasurementSet(az, rad, opt, &in);
    // Round 0 only measured the noise: solve at least once with it.
    if (round > 0 && !changed) break;
  }
  res.azimuth_sigma = in.sigma_az;
  res.radius_sigma = in.sigma_r;
  res.rms_azimuth_after = Rms(Finite(az, &in.use_az));
  for (size_t i = 0; i < n_obs; ++i) {
    if (!in.frame_used[static_cast<size_t>(observations[i].frame)]) continue;
    res.measurements += in.use_az[i] || in.use_r[i];
    res.rejected += !in.use_az[i] + !in.use_r[i];
  }
  std::vector<std::array<double, 3>> prior_poses;
  for (size_t f = 0; f < poses.size(); ++f)
    if (in.frame_used[f]) prior_poses.push_back({poses[f].x, poses[f].y, poses[f].theta});
  GaugeUncertainty(surveyed, prior_poses, opt, &res);
  const std::vector<std::array<double, kRectangleParams>> stds = RectangleDeviations(opt, problem.get(), &u, &res);
  CollectRefinement(surveyed, observations, in, stds, opt, u, &res);
  return res;
}

namespace {

// The frames of a video and the rows of its pose CSV must match one for one.
void CheckFrameCount(const RefineVideo& v, int frames) {
  if (static_cast<int>(v.poses.size()) != frames)
    throw Error(v.poses_path + ": " + std::to_string(v.poses.size()) + " pose rows for the " +
                std::to_string(frames) + " frames of " + v.video + " (expected one row per frame)");
}

// Drops the predicted corners whose vertical edge runs within gap_px
// (across it, where their radii overlap) of another landmark's vertical
// edge: the tracker may measure the other. Corners on one vertical edge (a
// rectangle's top and bottom) do not crowd each other. Returns how many.
int DropCrowded(double gap_px, std::vector<PredictedLandmark>* predicted) {
  if (gap_px <= 0.0) return 0;
  const auto span = [](const PredictedLandmark& p) {
    return std::make_pair(std::min(p.corner_radius, p.v_radius), std::max(p.corner_radius, p.v_radius));
  };
  std::vector<char> crowded(predicted->size(), 0);
  for (size_t a = 0; a < predicted->size(); ++a)
    for (size_t b = a + 1; b < predicted->size(); ++b) {
      const PredictedLandmark &pa = (*predicted)[a], &pb = (*predicted)[b];
      if ((pa.landmark->corner.head<2>() - pb.landmark->corner.head<2>()).norm() < 1e-9) continue;
      const auto [a0, a1] = span(pa);
      const auto [b0, b1] = span(pb);
      if (a1 + gap_px < b0 || b1 + gap_px < a0) continue;
      const double across =
          std::abs(WrapAngle(pa.azimuth - pb.azimuth)) * std::min(pa.corner_radius, pb.corner_radius);
      if (across < gap_px) crowded[a] = crowded[b] = 1;
    }
  std::vector<PredictedLandmark> kept;
  for (size_t k = 0; k < predicted->size(); ++k)
    if (!crowded[k]) kept.push_back((*predicted)[k]);
  const int dropped = static_cast<int>(predicted->size() - kept.size());
  *predicted = std::move(kept);
  return dropped;
}

}  // namespace

bool IsReferenceTrajectory(const std::vector<PoseRow>& rows) {
  for (const PoseRow& r : rows)
    if (r.status == PoseStatus::kOk)
      for (double v : r.extra)
        if (std::isfinite(v)) return false;
  return true;
}

double AutoPoseSigma(const std::vector<RefineVideo>& videos, double map_sigma) {
  if (videos.empty()) return 0.0;
  for (const RefineVideo& v : videos)
    if (!IsReferenceTrajectory(v.poses)) return 0.0;
  return 0.1 * map_sigma;
}

RefineResult RefineMap(const Calibration& calib, const Map& surveyed, const std::vector<RefineVideo>& videos,
                       const RefineOptions& opt) {
  opt.Check();
  if (videos.empty()) throw Error("no video to refine the map from");
  if (surveyed.rectangles.empty()) throw Error("the map has no rectangles to refine");
  for (const RefineVideo& v : videos) {
    const int n = FrameSource::FrameCount(v.video);
    if (n >= 0) CheckFrameCount(v, n);
    for (size_t i = 0; i < v.poses.size(); ++i)
      if (v.poses[i].frame != static_cast<int>(i))
        throw Error(v.poses_path + ": row " + std::to_string(i + 1) + " is frame " +
                    std::to_string(v.poses[i].frame) + " (expected one row per frame, in order)");
  }
  // The pose of each (video, frame) the adjustment has solved.
  std::vector<std::vector<std::optional<Pose2>>> solved(videos.size());
  for (size_t v = 0; v < videos.size(); ++v) solved[v].resize(videos[v].poses.size());
  Map current = surveyed;
  RefineResult res;
  for (int pass = 0; pass < opt.passes; ++pass) {
    const std::vector<Landmark> landmarks = LandmarksFromMap(current);
    // The walls moved out by 3 survey sigmas for the predictions: a poster
    // surveyed a little behind its wall is still looked for.
    Map predicting = current;
    if (predicting.room.present) {
      predicting.room.min.array() -= 3.0 * opt.map_sigma;
      predicting.room.max.array() += 3.0 * opt.map_sigma;
    }
    const Scene scene = Scene::FromMap(predicting, false);
    auto table = std::make_shared<RadiusTable>(
        RadiusTable::Build(calib.sensor, RangesForMap(predicting, calib.sensor), LutSize(), opt.num_threads));
    auto ph_tables = MakeTrackingPhTables(table, opt.num_threads);
    std::unique_ptr<LandmarkTracker> tracker =
        MakeTracker(TrackingMethod::kJunction, calib.sensor, table, opt.tracking, ph_tables);
    const double search = pass == 0 ? opt.search_px : opt.refine_search_px;
    const int threads = ThreadCount(opt.num_threads);

    std::vector<Pose2> poses, starts;  // the CSV's and where this round starts them
    int crowded = 0;
    std::vector<std::pair<size_t, size_t>> frame_of;  // adjustment frame -> (video, frame)
    std::vector<CornerObservation> obs;
    for (size_t v = 0; v < videos.size(); ++v) {
      const RefineVideo& rv = videos[v];
      FrameSource source(rv.video);
      cv::Mat grey;
      int i = 0;
      std::optional<Pose2> previous;
      for (; source.Read(&grey); ++i) {
        if (i >= static_cast<int>(rv.poses.size())) continue;  // counted, reported below
        const PoseRow& row = rv.poses[static_cast<size_t>(i)];
        if (row.status != PoseStatus::kOk) {
          previous.reset();
          continue;
        }
        const Pose2 pose = solved[v][static_cast<size_t>(i)].value_or(row.pose);
        std::vector<PredictedLandmark> predicted =
            PredictLandmarks(landmarks, predicting, scene, calib.sensor, *table, pose, opt.tracking.prediction);
        const Pose2 before = previous.value_or(
            Pose2{pose.x, pose.y, pose.theta - opt.tracking.unknown_turn_per_frame});
        SetImageMotion(predicting, calib.sensor, *table, before, opt.tracking.exposure_fraction, &predicted);
        previous = pose;
        crowded += DropCrowded(opt.min_edge_gap_px, &predicted);
        if (predicted.empty()) continue;
        tracker->BeginFrame(grey);
        std::vector<LandmarkMeasurement> meas(predicted.size());
        ParallelFor(
            static_cast<int>(predicted.size()),
            [&](int k) { meas[static_cast<size_t>(k)] = tracker->Measure(predicted[static_cast<size_t>(k)], search); },
            predicted.size() > 4, threads);
        std::vector<CornerObservation> found;
        for (size_t k = 0; k < predicted.size(); ++k)
          if (meas[k].found)
            found.push_back({static_cast<int>(poses.size()), predicted[k].index, meas[k].azimuth, meas[k].radius});
        if (static_cast<int>(found.size()) < opt.min_corners_per_frame) continue;
        obs.insert(obs.end(), found.begin(), found.end());
        poses.push_back(row.pose);
        starts.push_back(pose);
        frame_of.push_back({v, static_cast<size_t>(i)});
      }
      CheckFrameCount(rv, i);
    }
    if (obs.empty()) {
      std::string names;
      for (const RefineVideo& v : videos) names += (names.empty() ? "" : ", ") + v.video;
      throw Error("no landmark of the map was found in " + std::string(videos.size() > 1 ? "any of " : "") + names +
                  " (the map, the calibration or the poses do not fit the video)");
    }
    res = SolveMapRefinement(calib, surveyed, poses, obs, opt, &starts);
    res.crowded = crowded;
    for (size_t f = 0; f < frame_of.size(); ++f) solved[frame_of[f].first][frame_of[f].second] = res.poses[f];
    current = res.map;
  }
  return res;
}

std::string RefineReportTable(const RefineResult& r, const Map& surveyed, double map_sigma) {
  std::ostringstream out;
  char line[512];
  std::snprintf(line, sizeof line, "%-14s %5s  %-42s %8s  %s\n", "landmark", "obs",
                "correction +- std (from x,y  to x,y  z0 z1)", "max move", "flag");
  out << line;
  for (const LandmarkCorrection& l : r.landmarks) {
    std::string cells;
    for (int i = 0; i < kRectangleParams; ++i) {
      char cell[48];
      const size_t ii = static_cast<size_t>(i);
      std::snprintf(cell, sizeof cell, "%s%+.2f(%.2f)", i ? " " : "", l.refined[ii] - l.surveyed[ii], l.std[ii]);
      cells += cell;
    }
    std::snprintf(line, sizeof line, "%-14s %5d  %-42s %8.2f  %s\n", l.id.c_str(), l.observations, cells.c_str(),
                  l.max_corner_shift, l.flagged ? "BEYOND 3 SIGMA" : "");
    out << line;
  }
  int flagged = 0;
  for (const LandmarkCorrection& l : r.landmarks) flagged += l.flagged;
  std::snprintf(line, sizeof line,
                "%d frames, %d corner observations; noise %.3f deg azimuth, %.2f px radius; %d of %zu "
                "landmarks beyond 3 sigma (%.3g %s) of the survey\n",
                r.frames_used, r.measurements, r.azimuth_sigma * 180.0 / M_PI, r.radius_sigma, flagged,
                r.landmarks.size(), 3.0 * map_sigma, surveyed.units.c_str());
  out << line;
  std::snprintf(line, sizeof line,
                "%d measurements dropped as outliers (beyond the noise), %d corner views skipped (another edge "
                "too near)\n",
                r.rejected, r.crowded);
  out << line;
  // The floor: what the priors alone fix (the images cannot see it).
  char scale[64] = "";
  if (r.gauge_scale_std > 0.0) std::snprintf(scale, sizeof scale, ", scale +- %.3g %%", 100.0 * r.gauge_scale_std);
  std::snprintf(line, sizeof line,
                "gauge (fixed by the priors alone): shift +- %.3g %s, turn +- %.3g deg%s -> corner RMS floor %.3g %s\n",
                r.gauge_shift_std, surveyed.units.c_str(), r.gauge_turn_std * 180.0 / M_PI, scale,
                r.gauge_corner_rms, surveyed.units.c_str());
  out << line;
  if (r.sensor_height_std > 0.0) {
    std::snprintf(line, sizeof line, "sensor height %.3f +- %.3f %s (surveyed %.3f)\n", r.map.sensor_height,
                  r.sensor_height_std, surveyed.units.c_str(), surveyed.sensor_height);
    out << line;
  }
  if (!r.covariance_ok) out << "note: the covariance could not be computed (std shown as nan)\n";
  return out.str();
}

namespace {

// Corners (x, y, z - sensor height) of the rectangles of `a` and of the same
// rectangles of `b`.
void MatchedCorners(const Map& a, const Map& b, std::vector<Eigen::Vector3d>* pa, std::vector<Eigen::Vector3d>* pb) {
  if (a.rectangles.size() != b.rectangles.size()) throw Error("CornerRms: the maps have different rectangles");
  for (const MapRectangle& ra : a.rectangles) {
    auto it = std::find_if(b.rectangles.begin(), b.rectangles.end(),
                           [&](const MapRectangle& rb) { return rb.id == ra.id; });
    if (it == b.rectangles.end()) throw Error("CornerRms: rectangle '" + ra.id + "' is in one map only");
    for (int c = 0; c < 4; ++c) {
      const int e = CornerEnd(c), l = CornerLevel(c);
      const Eigen::Vector2d& xa = e ? ra.to : ra.from;
      const Eigen::Vector2d& xb = e ? it->to : it->from;
      pa->push_back({xa.x(), xa.y(), (l ? ra.z1 : ra.z0) - a.sensor_height});
      pb->push_back({xb.x(), xb.y(), (l ? it->z1 : it->z0) - b.sensor_height});
    }
  }
}

}  // namespace

double CornerRms(const Map& a, const Map& b) {
  std::vector<Eigen::Vector3d> pa, pb;
  MatchedCorners(a, b, &pa, &pb);
  double sum = 0.0;
  const Eigen::Vector3d dh(0.0, 0.0, a.sensor_height - b.sensor_height);
  for (size_t i = 0; i < pa.size(); ++i) sum += (pa[i] - pb[i] + dh).squaredNorm();
  return pa.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(pa.size()));
}

double CornerRmsAfterGauge(const Map& estimate, const Map& truth) {
  std::vector<Eigen::Vector3d> pa, pb;
  MatchedCorners(estimate, truth, &pa, &pb);
  if (pa.empty()) return 0.0;
  // x' = a x - b y + tx, y' = b x + a y + ty, z' = a z: linear in (a, b, tx, ty)
  // for the small turns a survey leaves.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * static_cast<long>(pa.size()), 4);
  Eigen::VectorXd y(3 * static_cast<long>(pa.size()));
  for (size_t i = 0; i < pa.size(); ++i) {
    const long r = 3 * static_cast<long>(i);
    A.row(r) << pa[i].x(), -pa[i].y(), 1, 0;
    A.row(r + 1) << pa[i].y(), pa[i].x(), 0, 1;
    A.row(r + 2) << pa[i].z(), 0, 0, 0;
    y.segment<3>(r) = pb[i];
  }
  const Eigen::VectorXd g = A.colPivHouseholderQr().solve(y);
  return std::sqrt((A * g - y).squaredNorm() / static_cast<double>(pa.size()));
}

}  // namespace pano

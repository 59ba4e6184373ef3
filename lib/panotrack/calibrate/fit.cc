// Step 3: Ceres fit of the sensor (and board poses) to the corners, and the
// covariance of the sensor parameters with the poses marginalised.
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/internal.h"
#include "panotrack/calibrate/limb.h"
#include "panotrack/core/error.h"

namespace pano {

using namespace calib_internal;

namespace calib_internal {

void SetRimForImage(Sensor* sensor) {
  sensor->params.rim_radius =
      RimForRadius(sensor->params, CapRadiusPx(sensor->image_width, sensor->image_height) / sensor->params.focal_px);
}

std::vector<int> FixedSensorIndices(bool poses_known, const CalibrateOptions& o) {
  std::vector<int> fixed;
  if (!o.fit_aspect) fixed.push_back(kAspect);
  if (!poses_known || !o.fit_azimuth_offset) fixed.push_back(kAzimuth);
  const int nd = o.DistortionTerms();
  if (nd < 1) fixed.push_back(kK1);
  if (nd < 2) fixed.push_back(kK2);
  if (o.model == MirrorModel::kSphere) fixed.push_back(kConic);
  if (o.model == MirrorModel::kUnified) {
    for (int k : {kRadius, kConic, kVertex}) fixed.push_back(k);
  } else {
    fixed.push_back(kXi);
  }
  fixed.push_back(kUnified);
  std::sort(fixed.begin(), fixed.end());
  return fixed;
}

std::vector<int> FixedFaultIndices(bool poses_known, const CalibrateOptions& o) {
  const FreeFaults f = o.Faults();
  // With estimated poses a tilt of the whole rig is a turn of every board.
  const bool free[kNumFaults] = {f.decentre,   f.decentre, f.camera_tilt, f.camera_tilt,
                                 f.tangential, f.tangential, f.k3,
                                 f.sensor_tilt && poses_known, f.sensor_tilt && poses_known, f.skew};
  std::vector<int> fixed;
  fixed.reserve(kNumFaults);
  for (int k = 0; k < kNumFaults; ++k)
    if (!free[k]) fixed.push_back(k);
  return fixed;
}

}  // namespace calib_internal

namespace {

bool AllFinite(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

// The fit's parameter blocks, the model they describe and which parameters
// are held.
struct FitBlocks {
  std::array<double, kNumSensor> sensor{};
  std::array<double, kNumFaults> faults{};
  std::array<double, kNumAsphere> asphere{};
  std::vector<std::array<double, 6>> poses;
  double cap = 0.0;                // image radius where the mirror is taken to end (px)
  bool general = false;            // the general model: a fault free or carried
  bool faults_free = false;
  bool asphere_model = false;      // the even-asphere terms a block of their own
  int n_free_asphere = 0;
  std::vector<int> fixed, fixed_faults;  // held sensor and fault parameters
};

FitBlocks StartBlocks(const InitialEstimate& init, bool poses_known, const CalibrateOptions& options) {
  FitBlocks b;
  b.cap = CapRadiusPx(init.sensor.image_width, init.sensor.image_height);
  b.sensor = BlockFromParams(init.sensor.params);
  b.poses = init.poses;
  b.faults = BlockFromFaults(init.sensor.faults);
  b.fixed = FixedSensorIndices(poses_known, options);
  b.fixed_faults = FixedFaultIndices(poses_known, options);
  b.faults_free = static_cast<int>(b.fixed_faults.size()) < kNumFaults;
  b.general = b.faults_free || !init.sensor.faults.IsZero();
  if (!AllFinite(b.sensor.data(), kNumSensor) || !AllFinite(b.faults.data(), kNumFaults))
    throw Error("calibration fit: the initial sensor has non-finite parameters");
  // Model asphere: its even-asphere terms are a block of their own (a6 held
  // at zero when only a4 is asked for).
  b.asphere_model = options.model == MirrorModel::kAsphere;
  b.asphere = {init.sensor.params.asphere_a4, init.sensor.params.asphere_a6};
  if (b.asphere_model && options.asphere_terms < 2) b.asphere[kA6] = 0.0;
  b.n_free_asphere = b.asphere_model ? options.asphere_terms : 0;
  return b;
}

// One corner's reprojection term through the model in use, chosen here once
// for the fit and the residuals alike: its cost (whitened by sqrt_info) and
// the parameter blocks it reads, in the functor's order.
std::unique_ptr<ceres::CostFunction> CornerTerm(FitBlocks* b, size_t view, const Eigen::Vector3d& X,
                                                const Eigen::Vector2d& obs, const Eigen::Matrix2d& sqrt_info,
                                                std::vector<double*>* blocks) {
  double* pose = b->poses[view].data();
  if (b->asphere_model && b->general) {
    *blocks = {b->sensor.data(), b->faults.data(), b->asphere.data(), pose};
    return std::make_unique<ceres::AutoDiffCostFunction<AsphereCornerCost, 2, kNumSensor, kNumFaults, kNumAsphere, 6>>(
        new AsphereCornerCost(X, obs, b->cap, sqrt_info));
  }
  if (b->asphere_model) {
    *blocks = {b->sensor.data(), b->asphere.data(), pose};
    return std::make_unique<ceres::AutoDiffCostFunction<AsphereCornerCost, 2, kNumSensor, kNumAsphere, 6>>(
        new AsphereCornerCost(X, obs, b->cap, sqrt_info));
  }
  if (b->general) {
    *blocks = {b->sensor.data(), b->faults.data(), pose};
    return std::make_unique<ceres::AutoDiffCostFunction<GeneralCornerCost, 2, kNumSensor, kNumFaults, 6>>(
        new GeneralCornerCost(X, obs, b->cap, sqrt_info));
  }
  *blocks = {b->sensor.data(), pose};
  return std::make_unique<ceres::AutoDiffCostFunction<CornerCost, 2, kNumSensor, 6>>(
      new CornerCost(X, obs, b->cap, sqrt_info));
}

// One corner's residual in pixels (unweighted); false where the model does
// not see it.
bool CornerResidual(FitBlocks* b, size_t view, const Eigen::Vector3d& X, const Eigen::Vector2d& obs, double* r) {
  std::vector<double*> blocks;
  const std::unique_ptr<ceres::CostFunction> term = CornerTerm(b, view, X, obs, Eigen::Matrix2d::Identity(), &blocks);
  return term->Evaluate(blocks.data(), r, nullptr);
}

// The sensor, fault and asphere blocks with their held parameters.
void AddModelBlocks(FitBlocks* b, ceres::Problem* problem) {
  problem->AddParameterBlock(b->sensor.data(), kNumSensor);
  if (!b->fixed.empty()) problem->SetManifold(b->sensor.data(), new ceres::SubsetManifold(kNumSensor, b->fixed));
  if (b->general) {
    problem->AddParameterBlock(b->faults.data(), kNumFaults);
    if (!b->faults_free) problem->SetParameterBlockConstant(b->faults.data());
    else if (!b->fixed_faults.empty())
      problem->SetManifold(b->faults.data(), new ceres::SubsetManifold(kNumFaults, b->fixed_faults));
  }
  if (b->asphere_model) {
    problem->AddParameterBlock(b->asphere.data(), kNumAsphere);
    if (b->n_free_asphere < kNumAsphere)
      problem->SetManifold(b->asphere.data(), new ceres::SubsetManifold(kNumAsphere, {kA6}));
  }
}

// Every corner the initial model sees, weighted (CornerWeights) under the
// options' loss; each board's pose a block (held when known). Throws when
// the initial model misses more than a tenth of the corners.
void AddCornerTerms(const std::vector<BoardView>& views, const TargetBoard& board,
                    const std::vector<Eigen::Vector3d>& pts, bool poses_known, const CalibrateOptions& options,
                    FitBlocks* b, ceres::Problem* problem) {
  size_t n_obs = 0, n_invisible = 0, n_total = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    problem->AddParameterBlock(b->poses[i].data(), 6);
    if (poses_known) problem->SetParameterBlockConstant(b->poses[i].data());
    const BoardView& bv = views[i];
    CheckBoardView(bv, board);
    const std::vector<Eigen::Matrix2d> weights = CornerWeights(bv, board, options.full_weight_px);
    n_total += bv.corners.size();
    for (size_t j = 0; j < bv.corners.size(); ++j) {
      std::vector<double*> blocks;
      std::unique_ptr<ceres::CostFunction> term = CornerTerm(b, i, pts[bv.PointId(j)], bv.corners[j], weights[j], &blocks);
      double r[2];
      if (!term->Evaluate(blocks.data(), r, nullptr)) {
        ++n_invisible;
        continue;  // not visible through the initial model: left out of the fit
      }
      ceres::LossFunction* loss = options.huber_px > 0 ? new ceres::HuberLoss(options.huber_px) : nullptr;
      problem->AddResidualBlock(term.release(), loss, blocks);
      ++n_obs;
    }
  }
  if (n_obs < n_total * 9 / 10)
    throw Error("calibration fit: the initial model cannot see " + std::to_string(n_invisible) + " of " +
                std::to_string(n_total) + " corners (initialisation failed)");
}

ceres::Solver::Summary SolveFit(bool poses_known, const CalibrateOptions& options, ceres::Problem* problem) {
  ceres::Solver::Options so;
  so.linear_solver_type = poses_known ? ceres::DENSE_QR : ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  // One Ceres thread: its threaded Schur elimination sums in an order that
  // varies from run to run, and in the conic's near-degenerate valley that
  // takes a fit to another basin (under load, one a held-out board cannot
  // be fitted through). The callers run fits side by side instead.
  so.num_threads = 1;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-12;
  // Quiet unless asked: a corner leaving the mirror in a trial step is a
  // rejected step, which Ceres would otherwise log as a warning.
  so.minimizer_progress_to_stdout = options.verbose;
  so.logging_type = options.verbose ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem, &summary);
  if (options.on_log) options.on_log(summary.BriefReport());
  return summary;
}

// The fitted sensor from the blocks; throws when it is not physical (or,
// for the asphere, not one a calibration file accepts).
Sensor FittedSensor(const Sensor& start, const FitBlocks& b) {
  Sensor sensor = start;
  sensor.params = ParamsFromBlock(b.sensor.data());
  sensor.faults = FaultsFromBlock(b.faults.data());
  sensor.params.asphere_a4 = b.asphere[kA4];
  sensor.params.asphere_a6 = b.asphere[kA6];
  if (!PlausibleParams(sensor.params)) throw Error("calibration fit: the fitted sensor is not physical");
  SetRimForImage(&sensor);
  if (b.asphere_model) {
    // Free terms may bend the profile beyond what a calibration file accepts
    // (a mirror that is not convex where the camera sees it).
    try {
      sensor.Check("fitted sensor");
    } catch (const Error& e) {
      throw Error(std::string("calibration fit: ") + e.what());
    }
  }
  return sensor;
}

// Residuals of every corner (visible or not; NaN where not), per board and
// overall RMS, and the boards' fitted poses.
void CollectResiduals(const std::vector<BoardView>& views, const std::vector<Eigen::Vector3d>& pts, FitBlocks* b,
                      CalibrationResult* res) {
  double sum2 = 0.0;
  size_t n_used = 0;
  res->views = views;
  for (size_t i = 0; i < views.size(); ++i) {
    if (!AllFinite(b->poses[i].data(), 6)) throw Error("calibration fit: a board pose became non-finite");
    BoardView& bv = res->views[i];
    UnpackPose(b->poses[i], &bv);
    std::vector<Eigen::Vector2d> rv;
    double s2 = 0.0;
    size_t n = 0;
    for (size_t j = 0; j < bv.corners.size(); ++j) {
      double r[2];
      if (!CornerResidual(b, i, pts[bv.PointId(j)], bv.corners[j], r)) {
        rv.push_back(Eigen::Vector2d(NAN, NAN));
        continue;
      }
      rv.push_back({r[0], r[1]});
      s2 += r[0] * r[0] + r[1] * r[1];
      ++n;
    }
    if (n == 0 || n < bv.corners.size() / 2)
      throw Error(bv.file + ": the fitted model cannot see the board (fit diverged)");
    res->image_rms.push_back(std::sqrt(s2 / n));
    res->residuals.push_back(rv);
    sum2 += s2;
    n_used += n;
  }
  res->rms_px = std::sqrt(sum2 / n_used);
  if (!std::isfinite(res->rms_px))
    throw Error("calibration fit: the reprojection error is not finite (fit diverged)");
}

// The free parameters' covariance (the poses marginalised) and whether the
// boards determine each one.
struct FitCovariance {
  std::vector<int> free_idx, free_fault_idx;
  Eigen::MatrixXd sensor_cov = Eigen::MatrixXd::Zero(kNumSensor, kNumSensor);
  std::vector<bool> determined = std::vector<bool>(kNumSensor, true);
  Eigen::VectorXd fault_var = Eigen::VectorXd::Zero(kNumFaults);
  std::vector<bool> fault_determined = std::vector<bool>(kNumFaults, true);
  Eigen::VectorXd asphere_var = Eigen::VectorXd::Zero(kNumAsphere);
  std::vector<bool> asphere_determined = std::vector<bool>(kNumAsphere, true);
};

// The pseudo-inverse of J^T J, J normalised column by column, scaled by the
// residual variance; a parameter with a component in the numerical null
// space is not determined. Returns (covariance, null-space weight per column).
std::pair<Eigen::MatrixXd, std::vector<double>> PseudoInverseCovariance(const ceres::CRSMatrix& jac, double cost) {
  const int P = jac.num_cols, N = jac.num_rows;
  Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(P, P);
  for (int r = 0; r < N; ++r) {
    for (int a = jac.rows[r]; a < jac.rows[r + 1]; ++a)
      for (int b = jac.rows[r]; b < jac.rows[r + 1]; ++b) JtJ(jac.cols[a], jac.cols[b]) += jac.values[a] * jac.values[b];
  }
  Eigen::VectorXd d = JtJ.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd Jn = d.asDiagonal() * JtJ * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Jn);
  const Eigen::VectorXd& ev = es.eigenvalues();
  const double ev_max = ev.maxCoeff();
  Eigen::MatrixXd cov_n = Eigen::MatrixXd::Zero(P, P);
  std::vector<double> null_weight(P, 0.0);
  for (int k = 0; k < P; ++k) {
    const Eigen::VectorXd vk = es.eigenvectors().col(k);
    if (ev(k) > 1e-12 * ev_max) {
      cov_n += vk * vk.transpose() / ev(k);
    } else {
      for (int q = 0; q < P; ++q) null_weight[q] += vk(q) * vk(q);
    }
  }
  const double dof = std::max<double>(1.0, static_cast<double>(N - P));
  const double sigma2 = 2.0 * cost / dof;
  return {sigma2 * d.asDiagonal() * cov_n * d.asDiagonal(), null_weight};
}

// Covariance: J of the weighted, non-robust residuals at the optimum, the
// sensor's free parameters first, then the free faults, the asphere's free
// terms and (estimated) the poses.
FitCovariance CovarianceOf(FitBlocks* b, bool poses_known, int threads, ceres::Problem* problem) {
  FitCovariance c;
  std::vector<double*> blocks = {b->sensor.data()};
  if (b->faults_free) blocks.push_back(b->faults.data());
  if (b->asphere_model) blocks.push_back(b->asphere.data());
  if (!poses_known)
    for (auto& p : b->poses) blocks.push_back(p.data());
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.apply_loss_function = false;
  eo.num_threads = threads;
  for (int k = 0; k < kNumSensor; ++k)
    if (!std::binary_search(b->fixed.begin(), b->fixed.end(), k)) c.free_idx.push_back(k);
  for (int k = 0; k < kNumFaults; ++k)
    if (b->faults_free && !std::binary_search(b->fixed_faults.begin(), b->fixed_faults.end(), k))
      c.free_fault_idx.push_back(k);
  ceres::CRSMatrix jac;
  double cost = 0.0;
  if (!problem->Evaluate(eo, &cost, nullptr, nullptr, &jac)) {
    for (int k : c.free_idx) c.determined[k] = false;
    for (int k : c.free_fault_idx) c.fault_determined[k] = false;
    for (int k = 0; k < b->n_free_asphere; ++k) c.asphere_determined[k] = false;
    return c;
  }
  const int P = jac.num_cols;
  const auto [cov, null_weight] = PseudoInverseCovariance(jac, cost);
  for (size_t a = 0; a < c.free_idx.size() && static_cast<int>(a) < P; ++a) {
    for (size_t q = 0; q < c.free_idx.size() && static_cast<int>(q) < P; ++q)
      c.sensor_cov(c.free_idx[a], c.free_idx[q]) = cov(a, q);
    c.determined[c.free_idx[a]] = null_weight[a] < 1e-3;
  }
  // The fault block's columns follow the sensor's free ones.
  for (size_t a = 0; a < c.free_fault_idx.size(); ++a) {
    const int col = static_cast<int>(c.free_idx.size() + a);
    if (col >= P) break;
    c.fault_var(c.free_fault_idx[a]) = cov(col, col);
    c.fault_determined[c.free_fault_idx[a]] = null_weight[col] < 1e-3;
  }
  // Then the asphere block's free columns.
  for (int k = 0; k < b->n_free_asphere; ++k) {
    const int col = static_cast<int>(c.free_idx.size() + c.free_fault_idx.size()) + k;
    if (col >= P) break;
    c.asphere_var(k) = cov(col, col);
    c.asphere_determined[k] = null_weight[col] < 1e-3;
  }
  return c;
}

void AddEstimate(const std::string& name, double value, double var, bool is_fixed, bool determined,
                 CalibrationResult* res) {
  ParameterEstimate e;
  e.name = name;
  e.value = value;
  e.fixed = is_fixed;
  e.stddev = is_fixed ? 0.0 : (determined ? std::sqrt(std::max(0.0, var)) : NAN);
  res->parameters.push_back(e);
}

// The sensor's parameters as reported: image mapping, the model's mirror
// parameters, the azimuth offset and the lens terms.
void ReportSensorParameters(const CalibrateOptions& options, const FitBlocks& b, const FitCovariance& c,
                            CalibrationResult* res) {
  const Eigen::MatrixXd& cov = c.sensor_cov;
  auto is_fixed = [&](int k) { return std::binary_search(b.fixed.begin(), b.fixed.end(), k); };
  auto add = [&](const std::string& name, double value, int k, bool fixed) {
    AddEstimate(name, value, cov(k, k), fixed, c.determined[k], res);
  };
  const SensorParams<double>& p = res->calib.sensor.params;
  add("focal_px", p.focal_px, kFocal, is_fixed(kFocal));
  add("cx", p.cx, kCx, false);
  add("cy", p.cy, kCy, false);
  add("aspect", p.aspect, kAspect, is_fixed(kAspect));
  if (options.model == MirrorModel::kSphere) {
    add("mirror_radius", p.curvature_radius, kRadius, false);
    const double var_d = cov(kRadius, kRadius) + cov(kVertex, kVertex) + 2.0 * cov(kRadius, kVertex);
    AddEstimate("mirror_distance", p.vertex_distance + p.curvature_radius, var_d, false,
                c.determined[kRadius] && c.determined[kVertex], res);
  } else if (options.model == MirrorModel::kUnified) {
    add("xi", p.xi, kXi, false);
  } else {
    add("curvature_radius", p.curvature_radius, kRadius, false);
    add("conic_constant", p.conic_constant, kConic, false);
    add("vertex_distance", p.vertex_distance, kVertex, false);
  }
  add("azimuth_offset", p.azimuth_offset, kAzimuth, is_fixed(kAzimuth));
  if (!is_fixed(kK1) || !is_fixed(kK2) || p.k1 != 0.0 || p.k2 != 0.0) {
    add("k1", p.k1, kK1, is_fixed(kK1));
    add("k2", p.k2, kK2, is_fixed(kK2));
  }
}

// Rig faults: the free ones and any carried non-zero, angles in degrees; a
// warning names those the boards leave undetermined.
void ReportFaults(bool poses_known, const CalibrateOptions& options, const FitCovariance& c, CalibrationResult* res) {
  const SensorParams<double>& p = res->calib.sensor.params;
  const RigFaults<double>& rf = res->calib.sensor.faults;
  auto fixed_fault = [&](int k) {
    return std::find(c.free_fault_idx.begin(), c.free_fault_idx.end(), k) == c.free_fault_idx.end();
  };
  constexpr double kDeg = 180.0 / M_PI;
  struct Item {
    const char* name;
    int index;
    double value, scale;  // reported value = block value * scale
    double warn_std;      // std (block units) above which it is not determined
  };
  const double len = options.fault_warning_std * p.curvature_radius, ang = options.fault_warning_std;
  const Item items[] = {{"decentre_x", kOffsetX, rf.mirror_offset[0], 1.0, len},
                        {"decentre_y", kOffsetY, rf.mirror_offset[1], 1.0, len},
                        {"camera_tilt_x_deg", kCameraTiltX, rf.camera_tilt[0], kDeg, ang},
                        {"camera_tilt_y_deg", kCameraTiltY, rf.camera_tilt[1], kDeg, ang},
                        {"p1", kP1, rf.p1, 1.0, options.fault_warning_std},
                        {"p2", kP2, rf.p2, 1.0, options.fault_warning_std},
                        {"k3", kK3, rf.k3, 1.0, options.fault_warning_std},
                        {"sensor_tilt_x_deg", kSensorTiltX, rf.sensor_tilt[0], kDeg, ang},
                        {"sensor_tilt_y_deg", kSensorTiltY, rf.sensor_tilt[1], kDeg, ang},
                        {"skew_px", kSkew, rf.skew, 1.0, options.fault_warning_std * p.focal_px}};
  std::string poor;
  for (const Item& it : items) {
    const bool fx = fixed_fault(it.index);
    if (fx && it.value == 0.0) continue;
    const double sd = std::sqrt(std::max(0.0, c.fault_var(it.index)));
    const bool det = c.fault_determined[it.index] && std::isfinite(sd) && sd <= it.warn_std;
    AddEstimate(it.name, it.value * it.scale, c.fault_var(it.index) * it.scale * it.scale, fx, det, res);
    if (!fx && !det) poor += std::string(poor.empty() ? "" : ", ") + it.name;
  }
  if (!poor.empty())
    res->warnings.push_back("rig faults not determined by these boards (covariance rank-deficient or standard "
                            "deviation too large): " + poor +
                            "; fix them (--free) or take boards at more heights and azimuths" +
                            (!poses_known && poor.find("decentre") != std::string::npos
                                 ? std::string("; with estimated board poses the mirror's offset trades against "
                                               "the principal point: measure it from a short video in a mapped "
                                               "room with `panocalib tilt --decentre`")
                                 : std::string()));
  if (options.Faults().sensor_tilt && !poses_known)
    res->warnings.push_back("sensor tilt held at zero: with estimated board poses it is a turn of every board");
}

// Even-asphere terms (model asphere): "not determined" as the faults are.
void ReportAsphereTerms(const CalibrateOptions& options, const FitBlocks& b, const FitCovariance& c,
                        CalibrationResult* res) {
  const char* names[kNumAsphere] = {"asphere_a4", "asphere_a6"};
  std::string poor;
  for (int k = 0; k < kNumAsphere; ++k) {
    const bool fx = k >= b.n_free_asphere;
    if (fx && b.asphere[k] == 0.0) continue;
    const double sd = std::sqrt(std::max(0.0, c.asphere_var(k)));
    const bool det = c.asphere_determined[k] && std::isfinite(sd) && sd <= options.fault_warning_std;
    AddEstimate(names[k], b.asphere[k], c.asphere_var(k), fx, det, res);
    if (!fx && !det) poor += std::string(poor.empty() ? "" : ", ") + names[k];
  }
  if (!poor.empty())
    res->warnings.push_back("mirror profile terms not determined by these boards (covariance rank-deficient or "
                            "standard deviation too large): " + poor +
                            "; fit the conic (--model conic) or take boards nearer the mirror's rim");
}

// Mirror size against the world: with unknown poses only parallax fixes it.
void WarnOfMirrorSize(const CalibrateOptions& options, const FitCovariance& c, CalibrationResult* res) {
  const SensorParams<double>& p = res->calib.sensor.params;
  const double var_r = c.sensor_cov(kRadius, kRadius), var_z = c.sensor_cov(kVertex, kVertex);
  const double rel = std::max(std::sqrt(std::max(0.0, var_r)) / p.curvature_radius,
                              std::sqrt(std::max(0.0, var_z)) / p.vertex_distance);
  if (!(!c.determined[kRadius] || !c.determined[kVertex] || rel > options.scale_warning_rel_std)) return;
  std::ostringstream w;
  w << "the mirror's size and distance are poorly determined (relative standard deviation ";
  if (c.determined[kRadius] && c.determined[kVertex]) w << rel * 100.0 << " %";
  else w << "unbounded";
  w << "): the boards show too little parallax (too far away, or a near single-viewpoint mirror); "
       "only the mirror's shape (ratios) and the image mapping are reliable. Take images with "
       "the board nearer the mirror, or give the board poses.";
  res->warnings.push_back(w.str());
}

}  // namespace

CalibrationResult FitCalibration(const std::vector<BoardView>& views, const TargetBoard& board,
                                 const InitialEstimate& init, bool poses_known,
                                 const CalibrateOptions& options, int threads) {
  const auto t0 = std::chrono::steady_clock::now();
  if (views.size() != init.poses.size()) throw Error("calibration fit: internal: poses/views mismatch");
  const std::vector<Eigen::Vector3d> pts = BoardPoints(board);
  FitBlocks b = StartBlocks(init, poses_known, options);
  ceres::Problem::Options popt;
  ceres::Problem problem(popt);
  AddModelBlocks(&b, &problem);
  AddCornerTerms(views, board, pts, poses_known, options, &b, &problem);
  AddLimbResiduals(&problem, init.limb, b.sensor.data(), b.faults.data());  // the mirror's limb, when measured
  const ceres::Solver::Summary summary = SolveFit(poses_known, options, &problem);
  if (summary.termination_type == ceres::FAILURE || !AllFinite(b.sensor.data(), kNumSensor) ||
      !AllFinite(b.faults.data(), kNumFaults) || !AllFinite(b.asphere.data(), kNumAsphere))
    throw Error("calibration fit: Ceres failed (" + summary.message + ")");

  CalibrationResult res;
  res.poses_known = poses_known;
  res.iterations = static_cast<int>(summary.iterations.size());
  res.fit_cost = summary.final_cost;
  res.calib.sensor = FittedSensor(init.sensor, b);
  CollectResiduals(views, pts, &b, &res);
  if (summary.termination_type == ceres::NO_CONVERGENCE && res.rms_px > 1.0)
    throw Error("calibration fit: no convergence after " + std::to_string(options.max_iterations) +
                " iterations (RMS " + std::to_string(res.rms_px) + " px)");
  const FitCovariance cov = CovarianceOf(&b, poses_known, threads > 0 ? threads : options.Threads(), &problem);
  ReportSensorParameters(options, b, cov, &res);
  ReportFaults(poses_known, options, cov, &res);
  if (b.asphere_model) ReportAsphereTerms(options, b, cov, &res);
  WarnOfMirrorSize(options, cov, &res);
  res.seconds_fit = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  res.init_summary = init.summary;
  return res;
}

}  // namespace pano

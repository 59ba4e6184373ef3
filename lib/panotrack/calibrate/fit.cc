// Step 3: Ceres fit of the sensor (and board poses) to the corners, and the
// covariance of the sensor parameters with the poses marginalised.
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
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

}  // namespace

CalibrationResult FitCalibration(const std::vector<BoardView>& views, const TargetBoard& board,
                                 const InitialEstimate& init, bool poses_known,
                                 const CalibrateOptions& options, int threads) {
  const auto t0 = std::chrono::steady_clock::now();
  if (views.size() != init.poses.size()) throw Error("calibration fit: internal: poses/views mismatch");
  const std::vector<Eigen::Vector3d> pts = BoardPoints(board);
  const double cap = CapRadiusPx(init.sensor.image_width, init.sensor.image_height);
  std::array<double, kNumSensor> s = BlockFromParams(init.sensor.params);
  std::vector<std::array<double, 6>> poses = init.poses;
  std::array<double, kNumFaults> f = BlockFromFaults(init.sensor.faults);
  const std::vector<int> fixed_faults = FixedFaultIndices(poses_known, options);
  const bool faults_free = static_cast<int>(fixed_faults.size()) < kNumFaults;
  // The general model whenever a fault is free or carried from an earlier fit.
  const bool general = faults_free || !init.sensor.faults.IsZero();
  if (!AllFinite(s.data(), kNumSensor) || !AllFinite(f.data(), kNumFaults))
    throw Error("calibration fit: the initial sensor has non-finite parameters");
  // Model asphere: its even-asphere terms are a block of their own (a6 held
  // at zero when only a4 is asked for).
  const bool asphere = options.model == MirrorModel::kAsphere;
  std::array<double, kNumAsphere> terms = {init.sensor.params.asphere_a4, init.sensor.params.asphere_a6};
  if (asphere && options.asphere_terms < 2) terms[kA6] = 0.0;
  const int n_free_asphere = asphere ? options.asphere_terms : 0;

  ceres::Problem::Options popt;
  ceres::Problem problem(popt);
  problem.AddParameterBlock(s.data(), kNumSensor);
  const std::vector<int> fixed = FixedSensorIndices(poses_known, options);
  if (!fixed.empty()) problem.SetManifold(s.data(), new ceres::SubsetManifold(kNumSensor, fixed));
  if (general) {
    problem.AddParameterBlock(f.data(), kNumFaults);
    if (!faults_free) problem.SetParameterBlockConstant(f.data());
    else if (!fixed_faults.empty())
      problem.SetManifold(f.data(), new ceres::SubsetManifold(kNumFaults, fixed_faults));
  }
  if (asphere) {
    problem.AddParameterBlock(terms.data(), kNumAsphere);
    if (n_free_asphere < kNumAsphere) problem.SetManifold(terms.data(), new ceres::SubsetManifold(kNumAsphere, {kA6}));
  }
  // One corner's residual (pixels, unweighted) through the model in use.
  auto residual = [&](const Eigen::Vector3d& X, const Eigen::Vector2d& obs, const double* pose, double* r) {
    if (asphere && general) return AsphereCornerCost(X, obs, cap)(s.data(), f.data(), terms.data(), pose, r);
    if (asphere) return AsphereCornerCost(X, obs, cap)(s.data(), terms.data(), pose, r);
    if (general) return GeneralCornerCost(X, obs, cap)(s.data(), f.data(), pose, r);
    return CornerCost(X, obs, cap)(s.data(), pose, r);
  };
  size_t n_obs = 0, n_invisible = 0, n_total = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    problem.AddParameterBlock(poses[i].data(), 6);
    if (poses_known) problem.SetParameterBlockConstant(poses[i].data());
    const BoardView& bv = views[i];
    CheckBoardView(bv, board);
    const std::vector<Eigen::Matrix2d> weights = CornerWeights(bv, board, options.full_weight_px);
    n_total += bv.corners.size();
    for (size_t j = 0; j < bv.corners.size(); ++j) {
      const Eigen::Vector3d& X = pts[bv.PointId(j)];
      double r[2];
      if (!residual(X, bv.corners[j], poses[i].data(), r)) {
        ++n_invisible;
        continue;  // not visible through the initial model: left out of the fit
      }
      ceres::LossFunction* loss = options.huber_px > 0 ? new ceres::HuberLoss(options.huber_px) : nullptr;
      if (asphere && general)
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<AsphereCornerCost, 2, kNumSensor, kNumFaults, kNumAsphere, 6>(
                new AsphereCornerCost(X, bv.corners[j], cap, weights[j])),
            loss, s.data(), f.data(), terms.data(), poses[i].data());
      else if (asphere)
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AsphereCornerCost, 2, kNumSensor, kNumAsphere, 6>(
                                     new AsphereCornerCost(X, bv.corners[j], cap, weights[j])),
                                 loss, s.data(), terms.data(), poses[i].data());
      else if (general)
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<GeneralCornerCost, 2, kNumSensor, kNumFaults, 6>(
                                     new GeneralCornerCost(X, bv.corners[j], cap, weights[j])),
                                 loss, s.data(), f.data(), poses[i].data());
      else
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerCost, 2, kNumSensor, 6>(
                                     new CornerCost(X, bv.corners[j], cap, weights[j])),
                                 loss, s.data(), poses[i].data());
      ++n_obs;
    }
  }
  if (n_obs < n_total * 9 / 10)
    throw Error("calibration fit: the initial model cannot see " + std::to_string(n_invisible) + " of " +
                std::to_string(n_total) + " corners (initialisation failed)");
  AddLimbResiduals(&problem, init.limb, s.data(), f.data());  // the mirror's limb, when measured

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
  ceres::Solve(so, &problem, &summary);
  if (options.on_log) options.on_log(summary.BriefReport());
  if (summary.termination_type == ceres::FAILURE || !AllFinite(s.data(), kNumSensor) ||
      !AllFinite(f.data(), kNumFaults) || !AllFinite(terms.data(), kNumAsphere))
    throw Error("calibration fit: Ceres failed (" + summary.message + ")");

  CalibrationResult res;
  res.poses_known = poses_known;
  res.iterations = static_cast<int>(summary.iterations.size());
  res.fit_cost = summary.final_cost;
  Sensor& sensor = res.calib.sensor;
  sensor = init.sensor;
  sensor.params = ParamsFromBlock(s.data());
  sensor.faults = FaultsFromBlock(f.data());
  sensor.params.asphere_a4 = terms[kA4];
  sensor.params.asphere_a6 = terms[kA6];
  if (!PlausibleParams(sensor.params))
    throw Error("calibration fit: the fitted sensor is not physical");
  SetRimForImage(&sensor);
  if (asphere) {
    // Free terms may bend the profile beyond what a calibration file accepts
    // (a mirror that is not convex where the camera sees it).
    try {
      sensor.Check("fitted sensor");
    } catch (const Error& e) {
      throw Error(std::string("calibration fit: ") + e.what());
    }
  }

  // Residuals of every corner (visible or not).
  double sum2 = 0.0;
  size_t n_used = 0;
  res.views = views;
  for (size_t i = 0; i < views.size(); ++i) {
    if (!AllFinite(poses[i].data(), 6)) throw Error("calibration fit: a board pose became non-finite");
    BoardView& bv = res.views[i];
    UnpackPose(poses[i], &bv);
    std::vector<Eigen::Vector2d> rv;
    double s2 = 0.0;
    size_t n = 0;
    for (size_t j = 0; j < bv.corners.size(); ++j) {
      double r[2];
      if (!residual(pts[bv.PointId(j)], bv.corners[j], poses[i].data(), r)) {
        rv.push_back(Eigen::Vector2d(NAN, NAN));
        continue;
      }
      rv.push_back({r[0], r[1]});
      s2 += r[0] * r[0] + r[1] * r[1];
      ++n;
    }
    if (n == 0 || n < bv.corners.size() / 2)
      throw Error(bv.file + ": the fitted model cannot see the board (fit diverged)");
    res.image_rms.push_back(std::sqrt(s2 / n));
    res.residuals.push_back(rv);
    sum2 += s2;
    n_used += n;
  }
  res.rms_px = std::sqrt(sum2 / n_used);
  if (!std::isfinite(res.rms_px))
    throw Error("calibration fit: the reprojection error is not finite (fit diverged)");
  if (summary.termination_type == ceres::NO_CONVERGENCE && res.rms_px > 1.0)
    throw Error("calibration fit: no convergence after " + std::to_string(options.max_iterations) +
                " iterations (RMS " + std::to_string(res.rms_px) + " px)");

  // Covariance: J of the weighted, non-robust residuals at the optimum, the
  // sensor's free parameters first, then the poses; pseudo-inverse of J^T J
  // scaled by the residual variance; a parameter with a component in the
  // numerical null space is "not determined".
  std::vector<double*> blocks = {s.data()};
  if (faults_free) blocks.push_back(f.data());
  if (asphere) blocks.push_back(terms.data());
  if (!poses_known)
    for (auto& p : poses) blocks.push_back(p.data());
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.apply_loss_function = false;
  eo.num_threads = threads > 0 ? threads : options.Threads();
  ceres::CRSMatrix jac;
  double cost = 0.0;
  std::vector<int> free_idx;
  for (int k = 0; k < kNumSensor; ++k)
    if (!std::binary_search(fixed.begin(), fixed.end(), k)) free_idx.push_back(k);
  Eigen::VectorXd sensor_std = Eigen::VectorXd::Constant(kNumSensor, 0.0);
  Eigen::MatrixXd sensor_cov = Eigen::MatrixXd::Zero(kNumSensor, kNumSensor);
  std::vector<bool> determined(kNumSensor, true);
  std::vector<int> free_fault_idx;
  for (int k = 0; k < kNumFaults; ++k)
    if (faults_free && !std::binary_search(fixed_faults.begin(), fixed_faults.end(), k)) free_fault_idx.push_back(k);
  Eigen::VectorXd fault_var = Eigen::VectorXd::Zero(kNumFaults);
  std::vector<bool> fault_determined(kNumFaults, true);
  Eigen::VectorXd asphere_var = Eigen::VectorXd::Zero(kNumAsphere);
  std::vector<bool> asphere_determined(kNumAsphere, true);
  if (problem.Evaluate(eo, &cost, nullptr, nullptr, &jac)) {
    const int P = jac.num_cols, N = jac.num_rows;
    Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(P, P);
    for (int r = 0; r < N; ++r) {
      for (int a = jac.rows[r]; a < jac.rows[r + 1]; ++a)
        for (int b = jac.rows[r]; b < jac.rows[r + 1]; ++b)
          JtJ(jac.cols[a], jac.cols[b]) += jac.values[a] * jac.values[b];
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
    const Eigen::MatrixXd cov = sigma2 * d.asDiagonal() * cov_n * d.asDiagonal();
    for (size_t a = 0; a < free_idx.size() && static_cast<int>(a) < P; ++a) {
      for (size_t b = 0; b < free_idx.size() && static_cast<int>(b) < P; ++b)
        sensor_cov(free_idx[a], free_idx[b]) = cov(a, b);
      determined[free_idx[a]] = null_weight[a] < 1e-3;
    }
    // The fault block's columns follow the sensor's free ones.
    for (size_t a = 0; a < free_fault_idx.size(); ++a) {
      const int col = static_cast<int>(free_idx.size() + a);
      if (col >= P) break;
      fault_var(free_fault_idx[a]) = cov(col, col);
      fault_determined[free_fault_idx[a]] = null_weight[col] < 1e-3;
    }
    // Then the asphere block's free columns.
    for (int k = 0; k < n_free_asphere; ++k) {
      const int col = static_cast<int>(free_idx.size() + free_fault_idx.size()) + k;
      if (col >= P) break;
      asphere_var(k) = cov(col, col);
      asphere_determined[k] = null_weight[col] < 1e-3;
    }
  } else {
    for (int k : free_idx) determined[k] = false;
    for (int k : free_fault_idx) fault_determined[k] = false;
    for (int k = 0; k < n_free_asphere; ++k) asphere_determined[k] = false;
  }
  for (int k = 0; k < kNumSensor; ++k) sensor_std(k) = std::sqrt(std::max(0.0, sensor_cov(k, k)));

  // Reported parameters.
  auto add = [&](const std::string& name, double value, double var, bool is_fixed, bool det) {
    ParameterEstimate e;
    e.name = name;
    e.value = value;
    e.fixed = is_fixed;
    e.stddev = is_fixed ? 0.0 : (det ? std::sqrt(std::max(0.0, var)) : NAN);
    res.parameters.push_back(e);
  };
  auto is_fixed = [&](int k) { return std::binary_search(fixed.begin(), fixed.end(), k); };
  const SensorParams<double>& p = sensor.params;
  add("focal_px", p.focal_px, sensor_cov(kFocal, kFocal), is_fixed(kFocal), determined[kFocal]);
  add("cx", p.cx, sensor_cov(kCx, kCx), false, determined[kCx]);
  add("cy", p.cy, sensor_cov(kCy, kCy), false, determined[kCy]);
  add("aspect", p.aspect, sensor_cov(kAspect, kAspect), is_fixed(kAspect), determined[kAspect]);
  if (options.model == MirrorModel::kSphere) {
    add("mirror_radius", p.curvature_radius, sensor_cov(kRadius, kRadius), false, determined[kRadius]);
    const double var_d = sensor_cov(kRadius, kRadius) + sensor_cov(kVertex, kVertex) +
                         2.0 * sensor_cov(kRadius, kVertex);
    add("mirror_distance", p.vertex_distance + p.curvature_radius, var_d, false,
        determined[kRadius] && determined[kVertex]);
  } else if (options.model == MirrorModel::kUnified) {
    add("xi", p.xi, sensor_cov(kXi, kXi), false, determined[kXi]);
  } else {
    add("curvature_radius", p.curvature_radius, sensor_cov(kRadius, kRadius), false, determined[kRadius]);
    add("conic_constant", p.conic_constant, sensor_cov(kConic, kConic), false, determined[kConic]);
    add("vertex_distance", p.vertex_distance, sensor_cov(kVertex, kVertex), false, determined[kVertex]);
  }
  add("azimuth_offset", p.azimuth_offset, sensor_cov(kAzimuth, kAzimuth), is_fixed(kAzimuth),
      determined[kAzimuth]);
  if (!is_fixed(kK1) || !is_fixed(kK2) || p.k1 != 0.0 || p.k2 != 0.0) {
    add("k1", p.k1, sensor_cov(kK1, kK1), is_fixed(kK1), determined[kK1]);
    add("k2", p.k2, sensor_cov(kK2, kK2), is_fixed(kK2), determined[kK2]);
  }

  // Rig faults: the free ones and any carried non-zero, angles in degrees.
  {
    const RigFaults<double>& rf = sensor.faults;
    auto fixed_fault = [&](int k) { return std::find(free_fault_idx.begin(), free_fault_idx.end(), k) == free_fault_idx.end(); };
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
      const double sd = std::sqrt(std::max(0.0, fault_var(it.index)));
      const bool det = fault_determined[it.index] && std::isfinite(sd) && sd <= it.warn_std;
      add(it.name, it.value * it.scale, fault_var(it.index) * it.scale * it.scale, fx, det);
      if (!fx && !det) poor += std::string(poor.empty() ? "" : ", ") + it.name;
    }
    if (!poor.empty())
      res.warnings.push_back("rig faults not determined by these boards (covariance rank-deficient or standard "
                             "deviation too large): " + poor +
                             "; fix them (--free) or take boards at more heights and azimuths" +
                             (!poses_known && poor.find("decentre") != std::string::npos
                                  ? std::string("; with estimated board poses the mirror's offset trades against "
                                                "the principal point: measure it from a short video in a mapped "
                                                "room with `panocalib tilt --decentre`")
                                  : std::string()));
    if (options.Faults().sensor_tilt && !poses_known)
      res.warnings.push_back("sensor tilt held at zero: with estimated board poses it is a turn of every board");
  }

  // Even-asphere terms (model asphere): "not determined" as the faults are.
  if (asphere) {
    const char* names[kNumAsphere] = {"asphere_a4", "asphere_a6"};
    std::string poor;
    for (int k = 0; k < kNumAsphere; ++k) {
      const bool fx = k >= n_free_asphere;
      if (fx && terms[k] == 0.0) continue;
      const double sd = std::sqrt(std::max(0.0, asphere_var(k)));
      const bool det = asphere_determined[k] && std::isfinite(sd) && sd <= options.fault_warning_std;
      add(names[k], terms[k], asphere_var(k), fx, det);
      if (!fx && !det) poor += std::string(poor.empty() ? "" : ", ") + names[k];
    }
    if (!poor.empty())
      res.warnings.push_back("mirror profile terms not determined by these boards (covariance rank-deficient or "
                             "standard deviation too large): " + poor +
                             "; fit the conic (--model conic) or take boards nearer the mirror's rim");
  }

  // Mirror size against the world: with unknown poses only parallax fixes it.
  {
    const double var_r = sensor_cov(kRadius, kRadius), var_z = sensor_cov(kVertex, kVertex);
    const double rel = std::max(std::sqrt(std::max(0.0, var_r)) / p.curvature_radius,
                                std::sqrt(std::max(0.0, var_z)) / p.vertex_distance);
    if (!determined[kRadius] || !determined[kVertex] || rel > options.scale_warning_rel_std) {
      std::ostringstream w;
      w << "the mirror's size and distance are poorly determined (relative standard deviation ";
      if (determined[kRadius] && determined[kVertex]) w << rel * 100.0 << " %";
      else w << "unbounded";
      w << "): the boards show too little parallax (too far away, or a near single-viewpoint mirror); "
           "only the mirror's shape (ratios) and the image mapping are reliable. Take images with "
           "the board nearer the mirror, or give the board poses.";
      res.warnings.push_back(w.str());
    }
  }

  res.seconds_fit = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  res.init_summary = init.summary;
  return res;
}

}  // namespace pano

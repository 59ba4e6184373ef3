// The motion model: an EKF over pose and velocity that beats the raw
// triangulated poses and is consistent (NEES), its Jacobians, gating, dropped
// and lost frames, heading wrap, odometry input, and the fixed-lag smoother.
#include <catch2/catch.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "test_rng.h"
#include "panotrack/track/motion_model.h"

namespace pano {
namespace {

constexpr double kDt = 0.1;  // 10 frames per second
constexpr int kSteps = 550;
constexpr int kWarmUp = 50;  // NEES and RMS over the last 500 steps

// A triangulated pose's noise: 5 cm, correlated in x and y, and 1.7 degrees.
Eigen::Matrix3d MeasurementCovariance() {
  Eigen::Matrix3d r;
  r << 0.0025, 0.001, 0.0, 0.001, 0.0025, 0.0, 0.0, 0.0, 0.03 * 0.03;
  return r;
}

Eigen::Vector3d PoseError(const MotionVector& truth, const Pose2& estimate) {
  return {estimate.x - truth(0), estimate.y - truth(1), WrapAngle(estimate.theta - truth(2))};
}

struct Run {
  std::vector<double> times;
  std::vector<MotionVector> truth;
  std::vector<PoseMeasurement> measurements;
  std::vector<bool> lost;  // frames that give no pose
};

template <typename Rng>
Eigen::VectorXd Gaussian(Rng& rng, const Eigen::MatrixXd& covariance) {
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::VectorXd z(covariance.rows());
  for (int i = 0; i < z.size(); ++i) z(i) = n01(rng);
  return covariance.llt().matrixL() * z;
}

template <typename Rng>
void AddMeasurements(Rng& rng, Run* run) {
  const Eigen::Matrix3d r = MeasurementCovariance();
  for (const MotionVector& s : run->truth) {
    const Eigen::Vector3d e = Gaussian(rng, r);
    PoseMeasurement m;
    m.pose = {s(0) + e(0), s(1) + e(1), WrapAngle(s(2) + e(2))};
    m.covariance = r;
    run->measurements.push_back(m);
  }
  run->lost.assign(run->truth.size(), false);
}

// The model's own process: white acceleration drawn from its noise.
template <typename Rng>
Run SampledRun(Rng& rng, const MotionModelOptions& options) {
  Run run;
  MotionVector s;
  s << 1.0, 2.0, 0.5, 0.3, 0.1, 0.2;
  const MotionMatrix q = ConstantVelocityNoise(kDt, options);
  for (int k = 0; k < kSteps; ++k) {
    run.times.push_back(k * kDt);
    run.truth.push_back(s);
    s = PropagateConstantVelocity(s, kDt);
    s += Gaussian(rng, q);
    s(2) = WrapAngle(s(2));
  }
  AddMeasurements(rng, &run);
  return run;
}

// Driving round a circle of 2 m at 0.5 m/s, heading along it: about two
// turns, crossing +-pi on the way.
template <typename Rng>
Run CircleRun(Rng& rng) {
  Run run;
  const double radius = 2.0, rate = 0.25;
  for (int k = 0; k < kSteps; ++k) {
    const double t = k * kDt, a = rate * t;
    MotionVector s;
    s << radius * std::cos(a), radius * std::sin(a), WrapAngle(a + M_PI / 2),
        -radius * rate * std::sin(a), radius * rate * std::cos(a), rate;
    run.times.push_back(t);
    run.truth.push_back(s);
  }
  AddMeasurements(rng, &run);
  return run;
}

struct Stats {
  double raw_rms = 0.0;       // position, over the measured frames after warm-up
  double filtered_rms = 0.0;  // over the same frames
  double smoothed_rms = 0.0;
  double heading_raw_rms = 0.0;
  double heading_filtered_rms = 0.0;
  double mean_nees = 0.0;  // 3-D pose NEES of the filtered estimate
  double mean_smoothed_nees = 0.0;
  std::vector<SmoothedState> smoothed;
  int steps = 0;
};

Stats Filter(const Run& run, const MotionModelOptions& options, int lag) {
  MotionModel model(options);
  FixedLagSmoother smoother({lag});
  Stats st;
  std::vector<MotionState> filtered;
  auto push = [&](const MotionStep& step) {
    for (const SmoothedState& s : smoother.Push(step)) st.smoothed.push_back(s);
  };
  model.Reset(run.times[0], run.measurements[0].pose, run.measurements[0].covariance, options.max_speed,
              options.max_turn_rate);
  filtered.push_back(model.state());
  push(model.step());
  for (size_t k = 1; k < run.times.size(); ++k) {
    if (run.lost[k]) {
      model.MarkLost(run.times[k]);
    } else {
      model.Predict(run.times[k]);
      model.Update(run.measurements[k]);
    }
    filtered.push_back(model.state());
    push(model.step());
  }
  for (const SmoothedState& s : smoother.Flush()) st.smoothed.push_back(s);
  REQUIRE(st.smoothed.size() == run.times.size());
  int n = 0;
  for (size_t k = kWarmUp; k < run.times.size(); ++k) {
    const Eigen::Vector3d ef = PoseError(run.truth[k], filtered[k].pose());
    const Eigen::Vector3d es = PoseError(run.truth[k], st.smoothed[k].state.pose());
    st.mean_nees += ef.dot(filtered[k].pose_covariance().ldlt().solve(ef));
    st.mean_smoothed_nees += es.dot(st.smoothed[k].state.pose_covariance().ldlt().solve(es));
    st.filtered_rms += ef.head<2>().squaredNorm();
    st.smoothed_rms += es.head<2>().squaredNorm();
    st.heading_filtered_rms += ef(2) * ef(2);
    if (!run.lost[k]) {
      const Eigen::Vector3d er = PoseError(run.truth[k], run.measurements[k].pose);
      st.raw_rms += er.head<2>().squaredNorm();
      st.heading_raw_rms += er(2) * er(2);
      ++n;
    }
    ++st.steps;
  }
  st.raw_rms = std::sqrt(st.raw_rms / n);
  st.heading_raw_rms = std::sqrt(st.heading_raw_rms / n);
  st.filtered_rms = std::sqrt(st.filtered_rms / st.steps);
  st.smoothed_rms = std::sqrt(st.smoothed_rms / st.steps);
  st.heading_filtered_rms = std::sqrt(st.heading_filtered_rms / st.steps);
  st.mean_nees /= st.steps;
  st.mean_smoothed_nees /= st.steps;
  return st;
}

// Measured over seeds 1-40 (default seed in brackets): raw / filtered
// position RMS 1.30-1.43 [1.372], filtered / smoothed 1.52-1.94 [1.659], mean
// NEES 2.62-3.23 [2.815]: the filter is consistent on its own process.
TEST_CASE("motion model: constant-velocity run: filtered beats raw, NEES consistent", "[motion_model]") {
  PANO_SEEDED_RNG(7);
  const MotionModelOptions options;
  const Run run = SampledRun(rng, options);
  const Stats st = Filter(run, options, 10);
  CAPTURE(st.raw_rms, st.filtered_rms, st.smoothed_rms, st.mean_nees, st.mean_smoothed_nees);
  REQUIRE(st.steps == 500);
  CHECK(st.raw_rms > 1.25 * st.filtered_rms);
  CHECK(st.filtered_rms > 1.4 * st.smoothed_rms);
  CHECK(st.heading_raw_rms > st.heading_filtered_rms);
  CHECK(st.mean_nees > 2.5);
  CHECK(st.mean_nees < 3.4);
  CHECK(st.mean_smoothed_nees > 2.2);
  CHECK(st.mean_smoothed_nees < 3.4);
  if (pano_test_seed == 7) {  // regression guards at the default seed
    CHECK(st.raw_rms == Approx(0.07003).margin(1e-5));
    CHECK(st.filtered_rms == Approx(0.05105).margin(1e-5));
    CHECK(st.smoothed_rms == Approx(0.03078).margin(1e-5));
    CHECK(st.mean_nees == Approx(2.8149).margin(1e-4));
    CHECK(st.mean_smoothed_nees == Approx(2.9142).margin(1e-4));
  }
}

// A circle is smoother than the white-acceleration process, so the filter is
// a little conservative: mean NEES 2.29-2.85 over seeds 1-40 [2.628].
TEST_CASE("motion model: turning run across +-pi: filtered beats raw", "[motion_model]") {
  PANO_SEEDED_RNG(11);
  const MotionModelOptions options;
  const Run run = CircleRun(rng);
  const Stats st = Filter(run, options, 10);
  CAPTURE(st.raw_rms, st.filtered_rms, st.smoothed_rms, st.mean_nees, st.mean_smoothed_nees);
  CHECK(st.raw_rms > 1.4 * st.filtered_rms);
  CHECK(st.filtered_rms > 1.5 * st.smoothed_rms);
  CHECK(st.heading_raw_rms > st.heading_filtered_rms);
  CHECK(st.mean_nees > 2.1);
  CHECK(st.mean_nees < 3.0);
  if (pano_test_seed == 11) {
    CHECK(st.raw_rms == Approx(0.07103).margin(1e-5));
    CHECK(st.filtered_rms == Approx(0.04725).margin(1e-5));
    CHECK(st.smoothed_rms == Approx(0.02771).margin(1e-5));
    CHECK(st.mean_nees == Approx(2.6275).margin(1e-4));
  }
}

// Central differences of f around x, the angle row's difference wrapped.
template <typename F, int N>
Eigen::Matrix<double, 6, N> NumericJacobian(F f, const Eigen::Matrix<double, N, 1>& x) {
  const double h = 1e-6;
  Eigen::Matrix<double, 6, N> j;
  for (int i = 0; i < N; ++i) {
    Eigen::Matrix<double, N, 1> a = x, b = x;
    a(i) += h;
    b(i) -= h;
    MotionVector d = f(a) - f(b);
    d(2) = WrapAngle(d(2));
    j.col(i) = d / (2 * h);
  }
  return j;
}

TEST_CASE("motion model: process Jacobians match finite differences", "[motion_model]") {
  OdometryIncrement inc;
  inc.dx = 0.12;
  inc.dy = -0.03;
  inc.dtheta = 0.2;
  for (const double theta : {0.3, -2.0, M_PI - 1e-3}) {
    for (const double dt : {0.0, 0.1, 0.35}) {
      MotionVector s;
      s << 1.5, -0.4, theta, 0.3, -0.2, 0.7;
      CAPTURE(theta, dt);
      const auto cv = [&](const MotionVector& x) { return PropagateConstantVelocity(x, dt); };
      CHECK((NumericJacobian<decltype(cv), 6>(cv, s) - ConstantVelocityJacobian(dt)).cwiseAbs().maxCoeff() < 1e-8);
      const auto odo = [&](const MotionVector& x) { return PropagateOdometry(x, dt, inc); };
      CHECK((NumericJacobian<decltype(odo), 6>(odo, s) - OdometryJacobian(s, dt, inc)).cwiseAbs().maxCoeff() <
            1e-8);
      const auto odo_in = [&](const Eigen::Vector3d& u) {
        OdometryIncrement v = inc;
        v.dx = u(0);
        v.dy = u(1);
        v.dtheta = u(2);
        return PropagateOdometry(s, dt, v);
      };
      CHECK((NumericJacobian<decltype(odo_in), 3>(odo_in, Eigen::Vector3d(inc.dx, inc.dy, inc.dtheta)) -
             OdometryInputJacobian(s, dt, inc))
                .cwiseAbs()
                .maxCoeff() < 1e-7);
    }
  }
}

TEST_CASE("motion model: gating rejects a 70 cm jump under a tight covariance", "[motion_model]") {
  MotionModel model;
  const Eigen::Matrix3d tight = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();  // 1 cm, 0.6 degree
  model.Reset(0.0, {1.0, 2.0, M_PI - 0.01}, tight, 0.0, 0.0);
  PoseMeasurement jump{{1.7, 2.0, M_PI - 0.01}, tight};
  // 0.7^2 / (1e-4 + 1e-4)
  CHECK(model.Innovation(jump) == Approx(2450.0).epsilon(1e-12));
  CHECK(model.Innovation(jump) > kGateChiSquare3Dof99);
  // 1 cm off, and a heading 0.02 rad away across +-pi: 0.5 + 2.
  PoseMeasurement near{{1.01, 2.0, -M_PI + 0.01}, tight};
  CHECK(model.Innovation(near) == Approx(2.5).epsilon(1e-9));
  CHECK(model.Innovation(near) < kGateChiSquare3Dof99);
  CHECK(model.HeadingInnovation(-M_PI + 0.01, 0.01) == Approx(0.02 * 0.02 / 2e-4).epsilon(1e-9));
  // The free function on the model's state gives the model's own distance.
  CHECK(PoseInnovation(near.pose, near.covariance, model.state()) == Approx(model.Innovation(near)).epsilon(1e-12));
  CHECK(PoseInnovation(jump.pose, jump.covariance, model.state()) == Approx(2450.0).epsilon(1e-12));
  // Innovation does not change the state; Update does.
  CHECK(model.pose().x == 1.0);
  model.Update(near);
  CHECK(model.pose().x == Approx(1.005).epsilon(1e-12));
  CHECK(std::abs(model.pose().theta) == Approx(M_PI).epsilon(1e-12));
  CHECK(model.step().pose_measured);
}

TEST_CASE("motion model: a pose fused with a state equals the information-weighted mean", "[motion_model]") {
  // The Kalman update of the pose alone against its information form:
  // (R^-1 + P^-1)^-1 (R^-1 z + P^-1 x), on random covariances and poses.
  PANO_SEEDED_RNG(23);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto random_covariance = [&] {
    Eigen::Matrix3d a;
    for (int k = 0; k < 9; ++k) a(k / 3, k % 3) = normal(rng);
    return Eigen::Matrix3d(a * a.transpose() + 0.1 * Eigen::Matrix3d::Identity());
  };
  for (int draw = 0; draw < 20; ++draw) {
    PoseMeasurement measured;
    measured.covariance = random_covariance();
    measured.pose = {normal(rng), normal(rng), 0.3 * normal(rng)};
    MotionState state;
    state.covariance.topLeftCorner<3, 3>() = random_covariance();
    state.mean.head<3>() << measured.pose.x + 0.5 * normal(rng), measured.pose.y + 0.5 * normal(rng),
        measured.pose.theta + 0.1 * normal(rng);
    const std::optional<PoseMeasurement> fused = FuseWithState(measured, state, 1e9);
    REQUIRE(fused);
    const Eigen::Matrix3d r_inv = measured.covariance.inverse();
    const Eigen::Matrix3d p_inv = state.pose_covariance().inverse();
    const Eigen::Matrix3d expected_cov = (r_inv + p_inv).inverse();
    const Eigen::Vector3d z(measured.pose.x, measured.pose.y, measured.pose.theta);
    const Eigen::Vector3d expected = expected_cov * (r_inv * z + p_inv * state.mean.head<3>());
    const double tol = 1e3 * std::numeric_limits<double>::epsilon();
    CHECK((Eigen::Vector3d(fused->pose.x, fused->pose.y, fused->pose.theta) - expected).norm() < tol);
    CHECK((fused->covariance - expected_cov).norm() < tol);
  }
}

TEST_CASE("motion model: fusing a pose wraps the heading and gates a disagreement", "[motion_model]") {
  PoseMeasurement measured;
  measured.pose = {0.0, 0.0, M_PI - 0.01};
  measured.covariance = Eigen::Matrix3d::Identity() * 0.01;
  MotionState state;
  state.mean.head<3>() << 0.0, 0.0, -M_PI + 0.01;
  state.covariance.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 0.01;
  // Equal weights: halfway across the wrap, at pi.
  const std::optional<PoseMeasurement> fused = FuseWithState(measured, state, kGateChiSquare3Dof99);
  REQUIRE(fused);
  CHECK(std::abs(WrapAngle(fused->pose.theta - M_PI)) < 1e-12);
  CHECK(fused->covariance(2, 2) == Approx(0.005));
  // A state 0.5 away in x under 0.1 + 0.1 standard deviations: a squared
  // distance of 12.5, beyond the 99 % gate of three degrees of freedom (11.3).
  state.mean(0) = 0.5;
  CHECK_FALSE(FuseWithState(measured, state, kGateChiSquare3Dof99));
  state.mean(0) = 0.45;  // 10.1: within it
  CHECK(FuseWithState(measured, state, kGateChiSquare3Dof99));
  // The same distance, the heading's step taken across the wrap (0.02).
  CHECK(StepTowardState(measured.pose, state)(2) == Approx(0.02));
  CHECK(PoseInnovation(measured.pose, measured.covariance, state) == Approx(0.45 * 0.45 / 0.02 + 0.02 * 0.02 / 0.02));
  // A singular sum of covariances fuses nothing.
  measured.covariance.setZero();
  state.covariance.setZero();
  CHECK_FALSE(FuseWithState(measured, state, kGateChiSquare3Dof99));
}

TEST_CASE("motion model: a dropped frame widens the prediction exactly as two steps do", "[motion_model]") {
  MotionModelOptions options;
  options.accel_sigma = 0.4;
  options.angular_accel_sigma = 1.2;
  const Eigen::Matrix3d cov = Eigen::Vector3d(0.0025, 0.0016, 0.0009).asDiagonal();
  MotionModel a(options), b(options);
  for (MotionModel* m : {&a, &b}) {
    m->Reset(1.0, {0.5, 0.5, 0.1}, cov, 0.3, 0.5);
    m->Predict(1.1);
    m->Update({{0.53, 0.51, 0.12}, cov});
  }
  const MotionState before = a.state();
  a.Predict(1.2);
  a.Predict(1.3);
  b.Predict(1.3);  // the frame at 1.2 was dropped
  CHECK((a.state().mean - b.state().mean).cwiseAbs().maxCoeff() < 1e-15);
  CHECK((a.state().covariance - b.state().covariance).cwiseAbs().maxCoeff() < 1e-15);
  // Per axis: var' = var + 2 dt cov(p, v) + dt^2 var(v) + q dt^3 / 3.
  const double dt = 0.2;
  for (int axis = 0; axis < 3; ++axis) {
    const MotionMatrix& p = before.covariance;
    const double q = axis < 2 ? 0.16 : 1.44;
    const double expected = p(axis, axis) + 2 * dt * p(axis, axis + 3) + dt * dt * p(axis + 3, axis + 3) +
                            q * dt * dt * dt / 3;
    CHECK(b.state().covariance(axis, axis) == Approx(expected).epsilon(1e-13));
    CHECK(b.state().covariance(axis + 3, axis + 3) ==
          Approx(p(axis + 3, axis + 3) + q * dt).epsilon(1e-13));
  }
  // Twice the gap: more than twice the growth of the position variance.
  MotionModel c(options);
  c.Reset(1.0, {0.5, 0.5, 0.1}, cov, 0.3, 0.5);
  const double growth1 = c.Predict(1.1).covariance(0, 0) - cov(0, 0);
  c.Reset(1.0, {0.5, 0.5, 0.1}, cov, 0.3, 0.5);
  const double growth2 = c.Predict(1.2).covariance(0, 0) - cov(0, 0);
  CHECK(growth2 > 4 * growth1);
}

TEST_CASE("motion model: heading wraps across +-pi", "[motion_model]") {
  MotionModel model;
  const Eigen::Matrix3d cov = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  model.Reset(0.0, {0, 0, 3.0}, cov, 0.1, 1.0);
  double worst_after_cut = 0, worst_late = 0;
  for (int k = 1; k <= 40; ++k) {
    const double t = 0.1 * k;
    model.Predict(t);
    model.Update({{0, 0, WrapAngle(3.0 + 0.5 * t)}, cov});
    const double theta = model.pose().theta;
    CHECK(theta > -M_PI);
    CHECK(theta <= M_PI);
    // Measured: 2.2e-5 at the first frame across the cut, below 1e-13 from frame 16.
    const double error = std::abs(WrapAngle(theta - (3.0 + 0.5 * t)));
    if (k >= 3) worst_after_cut = std::max(worst_after_cut, error);
    if (k > 20) worst_late = std::max(worst_late, error);
  }
  CAPTURE(worst_after_cut, worst_late);
  CHECK(worst_after_cut < 3e-5);
  CHECK(worst_late < 1e-12);
  CHECK(model.PredictedHeadingRate() == Approx(0.5).epsilon(1e-12));
  // A compass heading across the cut pulls the estimate through pi, not zero.
  MotionModel compass;
  compass.Reset(0.0, {0, 0, 3.1}, cov, 0.1, 0.1);
  compass.UpdateHeading(-3.1, 0.01);
  CHECK(std::abs(compass.pose().theta) == Approx(M_PI).margin(1e-12));
  CHECK(compass.step().heading_measured);
  CHECK(compass.step().pose_measured);  // Reset counts its pose as measured
}

TEST_CASE("motion model: lost frames grow the covariance up to the caps; reinitialise", "[motion_model]") {
  MotionModelOptions options;
  options.max_position_sigma = 8.0;
  MotionModel model(options);
  const Eigen::Matrix3d cov = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  model.Reset(0.0, {1, 1, 0}, cov, 0.2, 0.2);
  model.Predict(0.1);
  model.Update({{1.02, 1.0, 0.0}, cov});
  double previous = model.pose_covariance().trace();
  for (int k = 2; k <= 10; ++k) {
    model.MarkLost(0.1 * k);
    CHECK(model.pose_covariance().trace() > previous);
    previous = model.pose_covariance().trace();
    CHECK_FALSE(model.step().pose_measured);
  }
  CHECK(model.frames_lost() == 9);
  for (int k = 11; k <= 2000; ++k) model.MarkLost(0.1 * k);
  const MotionMatrix& p = model.state().covariance;
  const double position_sigma =
      std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(p.topLeftCorner<2, 2>()).eigenvalues()(1));
  CHECK(position_sigma == Approx(8.0).epsilon(1e-12));
  CHECK(std::sqrt(p(2, 2)) <= M_PI * (1 + 1e-12));
  CHECK(std::sqrt(p(3, 3)) <= options.max_speed * (1 + 1e-12));
  CHECK(std::sqrt(p(5, 5)) <= options.max_turn_rate * (1 + 1e-12));
  CHECK(Eigen::SelfAdjointEigenSolver<MotionMatrix>(p).eigenvalues().minCoeff() > -1e-12);
  CHECK(model.frames_lost() == 1999);
  // A pose found again: the count restarts.
  model.Predict(200.1);
  model.Update({{3, 3, 1}, cov});
  CHECK(model.frames_lost() == 0);
  CHECK(model.pose().x == Approx(3).margin(1e-3));
  // Kidnapped and relocalised: new pose, velocity unknown.
  model.Reinitialize(200.2, {-2, 4, -1}, cov);
  CHECK(model.step().restart);
  CHECK(model.PredictedVelocity().norm() == 0.0);
  CHECK(model.PredictedHeadingRate() == 0.0);
  CHECK(model.state().covariance(3, 3) == options.max_speed * options.max_speed);
  CHECK(model.state().covariance(5, 5) == options.max_turn_rate * options.max_turn_rate);
  CHECK(model.pose().x == -2);
}

TEST_CASE("motion model: odometry as the control input", "[motion_model]") {
  PANO_SEEDED_RNG(5);
  std::mt19937_64 odo_rng(pano_test_seed + 1);
  const Run run = CircleRun(rng);
  // Exact increments, in the robot frame at the earlier frame.
  auto increment = [&](size_t k) {
    const MotionVector& a = run.truth[k - 1];
    const MotionVector& b = run.truth[k];
    const double c = std::cos(a(2)), s = std::sin(a(2));
    OdometryIncrement inc;
    inc.dx = c * (b(0) - a(0)) + s * (b(1) - a(1));
    inc.dy = -s * (b(0) - a(0)) + c * (b(1) - a(1));
    inc.dtheta = WrapAngle(b(2) - a(2));
    return inc;
  };
  // Exact odometry alone follows the circle and gives its velocity.
  MotionModel dead_reckoning;
  dead_reckoning.Reset(0.0, {run.truth[0](0), run.truth[0](1), run.truth[0](2)}, Eigen::Matrix3d::Zero(), 0, 0);
  for (size_t k = 1; k < run.truth.size(); ++k) dead_reckoning.PredictWithOdometry(run.times[k], increment(k));
  CHECK(PoseError(run.truth.back(), dead_reckoning.pose()).cwiseAbs().maxCoeff() < 1e-12);
  // The chord's mean velocity, a hair shorter than the tangent speed of 0.5.
  CHECK(dead_reckoning.PredictedVelocity().norm() == Approx(2 * 2.0 * std::sin(0.025 / 2) / kDt).epsilon(1e-12));
  CHECK(dead_reckoning.PredictedHeadingRate() == Approx(0.25).epsilon(1e-12));

  // Noisy odometry (1 cm, 0.3 degree a frame) with the noisy poses beats the
  // constant-velocity filter on such poses (0.047): position RMS measured
  // 0.0267-0.0353 over seeds 1-25 [0.02919].
  const Eigen::Matrix3d odo_cov = Eigen::Vector3d(1e-4, 1e-4, 0.005 * 0.005).asDiagonal();
  MotionModel model;
  model.Reset(0.0, run.measurements[0].pose, run.measurements[0].covariance, 1.0, 2.0);
  double sum = 0;
  int n = 0;
  for (size_t k = 1; k < run.truth.size(); ++k) {
    OdometryIncrement inc = increment(k);
    const Eigen::Vector3d e = Gaussian(odo_rng, odo_cov);
    inc.dx += e(0);
    inc.dy += e(1);
    inc.dtheta += e(2);
    inc.covariance = odo_cov;
    model.PredictWithOdometry(run.times[k], inc);
    model.Update(run.measurements[k]);
    if (static_cast<int>(k) >= kWarmUp) {
      sum += PoseError(run.truth[k], model.pose()).head<2>().squaredNorm();
      ++n;
    }
  }
  const double rms = std::sqrt(sum / n);
  CAPTURE(rms);
  CHECK(rms < 0.04);
  if (pano_test_seed == 5) CHECK(rms == Approx(0.02919).margin(1e-5));
}

TEST_CASE("motion model: options and bad calls", "[motion_model]") {
  const MotionModelOptions cm = MotionModelOptions::ForMapUnitsPerMetre(100);
  CHECK(cm.accel_sigma == 50);
  CHECK(cm.max_speed == 100);
  CHECK(cm.max_position_sigma == 1000);
  CHECK(cm.angular_accel_sigma == MotionModelOptions().angular_accel_sigma);
  MotionModelOptions bad;
  bad.max_position_sigma = -1;
  CHECK_THROWS_WITH(MotionModel(bad), Catch::Contains("max_position_sigma"));
  bad = MotionModelOptions();
  bad.accel_sigma = std::nan("");
  CHECK_THROWS_WITH(bad.Check(), Catch::Contains("accel_sigma"));
  CHECK_THROWS_AS(MotionModelOptions::ForMapUnitsPerMetre(0), Error);

  MotionModel model;
  CHECK_THROWS_WITH(model.Predict(1.0), Catch::Contains("before Reset"));
  CHECK_THROWS_AS(model.Update({}), Error);
  model.Reset(1.0, {}, Eigen::Matrix3d::Identity(), 0.1, 0.1);
  CHECK_THROWS_WITH(model.Predict(0.5), Catch::Contains("before the filter's time"));
  CHECK_THROWS_AS(model.Predict(std::nan("")), Error);
  CHECK_THROWS_AS(model.UpdateHeading(0.0, 0.0), Error);
  PoseMeasurement singular{{}, -Eigen::Matrix3d::Identity() * 10};
  CHECK_THROWS_WITH(model.Update(singular), Catch::Contains("not positive definite"));
  CHECK_THROWS_WITH(FixedLagSmoother({-1}), Catch::Contains("lag"));
}

// Every tenth frame and frames 200-209 give no pose; the filter drifts
// through the gap, the smoother bridges it. Position RMS filtered / smoothed
// measured 1.46-3.08 over seeds 1-25 [0.08903 / 0.03300 = 2.70].
TEST_CASE("smoother: smoothed beats filtered, lost frames marked, same output for same input", "[smoother]") {
  PANO_SEEDED_RNG(3);
  const MotionModelOptions options;
  Run run = SampledRun(rng, options);
  for (size_t k = 1; k < run.lost.size(); ++k) run.lost[k] = k % 10 == 0 || (k >= 200 && k < 210);
  const Stats st = Filter(run, options, 10);
  CAPTURE(st.filtered_rms, st.smoothed_rms, st.mean_nees, st.mean_smoothed_nees);
  REQUIRE(st.smoothed.size() == run.truth.size());
  for (size_t k = 0; k < run.lost.size(); ++k) {
    CHECK(st.smoothed[k].pose_measured == !run.lost[k]);
    CHECK(st.smoothed[k].state.time_s == run.times[k]);
  }
  CHECK(st.filtered_rms > 1.4 * st.smoothed_rms);
  CHECK(st.mean_nees > 2.4);
  CHECK(st.mean_nees < 3.6);
  if (pano_test_seed == 3) {
    CHECK(st.filtered_rms == Approx(0.08903).margin(1e-5));
    CHECK(st.smoothed_rms == Approx(0.03300).margin(1e-5));
    CHECK(st.mean_nees == Approx(3.0196).margin(1e-4));
    CHECK(st.mean_smoothed_nees == Approx(2.9117).margin(1e-4));
  }
  const Stats again = Filter(run, options, 10);
  for (size_t k = 0; k < run.lost.size(); ++k) {
    CHECK(again.smoothed[k].state.mean == st.smoothed[k].state.mean);
    CHECK(again.smoothed[k].state.covariance == st.smoothed[k].state.covariance);
  }
}

TEST_CASE("smoother: lag 0 is the filter; a restart flushes the frames before it", "[smoother]") {
  MotionModel model;
  FixedLagSmoother now({0}), late({4});
  const Eigen::Matrix3d cov = Eigen::Vector3d(1e-3, 1e-3, 1e-3).asDiagonal();
  model.Reset(0.0, {0, 0, 0}, cov, 0.5, 0.5);
  std::vector<SmoothedState> out;
  std::vector<size_t> returned;
  for (int k = 0; k < 12; ++k) {
    if (k == 7) {
      model.Reinitialize(0.7, {5, 5, 1}, cov);
    } else if (k > 0) {
      model.Predict(0.1 * k);
      model.Update({k < 7 ? Pose2{0.1 * k, 0, 0} : Pose2{5 + 0.1 * (k - 7), 5, 1}, cov});
    }
    const std::vector<SmoothedState> n = now.Push(model.step());
    REQUIRE(n.size() == 1);
    CHECK(n[0].state.mean == model.state().mean);
    CHECK(n[0].state.covariance == model.state().covariance);
    const std::vector<SmoothedState> l = late.Push(model.step());
    returned.push_back(l.size());
    out.insert(out.end(), l.begin(), l.end());
  }
  // Frames 0-2 leave at 4-6; the restart at 7 flushes 3-6; 7 leaves at 11.
  CHECK(returned == std::vector<size_t>{0, 0, 0, 0, 1, 1, 1, 4, 0, 0, 0, 1});
  CHECK(late.pending() == 4);
  const std::vector<SmoothedState> rest = late.Flush();
  out.insert(out.end(), rest.begin(), rest.end());
  REQUIRE(out.size() == 12);
  for (int k = 0; k < 12; ++k) CHECK(out[k].state.time_s == Approx(0.1 * k));
  // The restart cut the chain: the frame before it is its own filtered state.
  CHECK(out[6].state.pose().x == Approx(0.6).margin(0.05));
  CHECK(out[7].state.pose().x == Approx(5).margin(0.05));
  // Time must not go back.
  CHECK(late.Push(model.step()).empty());
  MotionStep older = model.step();
  older.restart = false;
  older.predicted.time_s = older.filtered.time_s = 0.5;
  CHECK_THROWS_WITH(late.Push(older), Catch::Contains("after one at"));
}

}  // namespace
}  // namespace pano

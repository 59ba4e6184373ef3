#include "panotrack/track/motion_model.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <string>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"

namespace pano {

Eigen::Vector3d StepTowardState(const Pose2& pose, const MotionState& state) {
  return {state.mean(0) - pose.x, state.mean(1) - pose.y, WrapAngle(state.mean(2) - pose.theta)};
}

double PoseInnovation(const Pose2& pose, const Eigen::Matrix3d& covariance, const MotionState& state) {
  const Eigen::Vector3d d = StepTowardState(pose, state);
  return d.dot((covariance + state.pose_covariance()).ldlt().solve(d));
}

std::optional<PoseMeasurement> FuseWithState(const PoseMeasurement& measured, const MotionState& state, double gate) {
  const Pose2& z = measured.pose;
  const Eigen::Vector3d toward = StepTowardState(z, state);
  const Eigen::FullPivLU<Eigen::Matrix3d> spread(measured.covariance + state.pose_covariance());
  if (!spread.isInvertible()) return std::nullopt;
  if (!(toward.dot(spread.solve(toward)) <= gate)) return std::nullopt;
  const Eigen::Matrix3d gain = measured.covariance * spread.inverse();
  const Eigen::Vector3d step = gain * toward;
  PoseMeasurement fused;
  fused.pose = Pose2{z.x + step(0), z.y + step(1), WrapAngle(z.theta + step(2))};
  const Eigen::Matrix3d covariance = measured.covariance - gain * measured.covariance;
  fused.covariance = 0.5 * (covariance + covariance.transpose());
  return fused;
}

namespace {

void CheckPositive(double v, const char* field) {
  if (!(v > 0.0) || !std::isfinite(v))
    throw Error(std::string("motion model options: ") + field + " must be a positive finite number, got " +
                std::to_string(v));
}

template <typename Derived>
bool AllFinite(const Eigen::MatrixBase<Derived>& m) {
  return m.allFinite();
}

// Scales rows and columns `a`, `a + 1` so that the 2x2 block there has no
// standard deviation above `cap`; a congruence, so the matrix stays positive
// semi-definite and keeps its correlations.
void CapBlock2(MotionMatrix* p, int a, double cap) {
  const Eigen::Matrix2d block = p->block<2, 2>(a, a);
  const double largest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(block, Eigen::EigenvaluesOnly)
                             .eigenvalues()(1);
  if (!(largest > cap * cap)) return;
  const double s = cap / std::sqrt(largest);
  p->middleRows<2>(a) *= s;
  p->middleCols<2>(a) *= s;
}

void CapBlock1(MotionMatrix* p, int a, double cap) {
  const double v = (*p)(a, a);
  if (!(v > cap * cap)) return;
  const double s = cap / std::sqrt(v);
  p->row(a) *= s;
  p->col(a) *= s;
}

MotionMatrix Symmetric(const MotionMatrix& m) { return 0.5 * (m + m.transpose()); }

}  // namespace

MotionModelOptions MotionModelOptions::Scaled(double units_per_metre) const {
  CheckPositive(units_per_metre, "units_per_metre");
  MotionModelOptions o = *this;
  o.accel_sigma *= units_per_metre;
  o.max_speed *= units_per_metre;
  o.max_position_sigma *= units_per_metre;
  return o;
}

MotionModelOptions MotionModelOptions::ForMapUnitsPerMetre(double units_per_metre) {
  return MotionModelOptions().Scaled(units_per_metre);
}

void MotionModelOptions::Check() const {
  CheckPositive(accel_sigma, "accel_sigma");
  CheckPositive(angular_accel_sigma, "angular_accel_sigma");
  CheckPositive(max_speed, "max_speed");
  CheckPositive(max_turn_rate, "max_turn_rate");
  CheckPositive(max_position_sigma, "max_position_sigma");
  CheckPositive(max_heading_sigma, "max_heading_sigma");
}

MotionVector PropagateConstantVelocity(const MotionVector& s, double dt) {
  MotionVector out = s;
  out.head<3>() += dt * s.tail<3>();
  out(2) = WrapAngle(out(2));
  return out;
}

MotionMatrix ConstantVelocityJacobian(double dt) {
  MotionMatrix f = MotionMatrix::Identity();
  f.topRightCorner<3, 3>() = dt * Eigen::Matrix3d::Identity();
  return f;
}

MotionMatrix ConstantVelocityNoise(double dt, const MotionModelOptions& o) {
  // The integral over [0, dt] of F(tau) G q G^T F(tau)^T for white
  // acceleration of spectral density q on each axis.
  MotionMatrix q = MotionMatrix::Zero();
  const double densities[3] = {o.accel_sigma * o.accel_sigma, o.accel_sigma * o.accel_sigma,
                               o.angular_accel_sigma * o.angular_accel_sigma};
  for (int axis = 0; axis < 3; ++axis) {
    const double d = densities[axis];
    q(axis, axis) = d * dt * dt * dt / 3.0;
    q(axis, axis + 3) = q(axis + 3, axis) = d * dt * dt / 2.0;
    q(axis + 3, axis + 3) = d * dt;
  }
  return q;
}

MotionVector PropagateOdometry(const MotionVector& s, double dt, const OdometryIncrement& inc) {
  const double c = std::cos(s(2)), sn = std::sin(s(2));
  const double wx = c * inc.dx - sn * inc.dy;  // the translation in the world frame
  const double wy = sn * inc.dx + c * inc.dy;
  MotionVector out = s;
  out(0) += wx;
  out(1) += wy;
  out(2) = WrapAngle(s(2) + inc.dtheta);
  if (dt > 0.0) out.tail<3>() << wx / dt, wy / dt, inc.dtheta / dt;
  return out;
}

MotionMatrix OdometryJacobian(const MotionVector& s, double dt, const OdometryIncrement& inc) {
  const double c = std::cos(s(2)), sn = std::sin(s(2));
  const double dwx = -sn * inc.dx - c * inc.dy;  // d(wx)/d(theta)
  const double dwy = c * inc.dx - sn * inc.dy;
  MotionMatrix f = MotionMatrix::Identity();
  f(0, 2) = dwx;
  f(1, 2) = dwy;
  if (dt > 0.0) {
    f.bottomRightCorner<3, 3>().setZero();  // the odometry replaces the velocity
    f(3, 2) = dwx / dt;
    f(4, 2) = dwy / dt;
  }
  return f;
}

Eigen::Matrix<double, 6, 3> OdometryInputJacobian(const MotionVector& s, double dt,
                                                  const OdometryIncrement& /*increment*/) {
  const double c = std::cos(s(2)), sn = std::sin(s(2));
  Eigen::Matrix<double, 6, 3> g = Eigen::Matrix<double, 6, 3>::Zero();
  g.block<2, 2>(0, 0) << c, -sn, sn, c;
  g(2, 2) = 1.0;
  if (dt > 0.0) {
    g.block<2, 2>(3, 0) = g.block<2, 2>(0, 0) / dt;
    g(5, 2) = 1.0 / dt;
  }
  return g;
}

MotionModel::MotionModel(const MotionModelOptions& options) : options_(options) { options_.Check(); }

void MotionModel::Reset(double t, const Pose2& pose, const Eigen::Matrix3d& pose_covariance,
                        double speed_sigma, double turn_rate_sigma) {
  if (!std::isfinite(t) || !std::isfinite(pose.x) || !std::isfinite(pose.y) ||
      !std::isfinite(pose.theta) || !AllFinite(pose_covariance))
    throw Error("motion model: Reset with a time, pose or covariance that is not finite");
  if (!(speed_sigma >= 0.0) || !(turn_rate_sigma >= 0.0) || !std::isfinite(speed_sigma) ||
      !std::isfinite(turn_rate_sigma))
    throw Error("motion model: Reset with a velocity standard deviation that is not a finite number >= 0");
  MotionState s;
  s.time_s = t;
  s.mean << pose.x, pose.y, WrapAngle(pose.theta), 0.0, 0.0, 0.0;
  s.covariance.topLeftCorner<3, 3>() = 0.5 * (pose_covariance + pose_covariance.transpose());
  s.covariance(3, 3) = s.covariance(4, 4) = speed_sigma * speed_sigma;
  s.covariance(5, 5) = turn_rate_sigma * turn_rate_sigma;
  step_ = MotionStep{};
  step_.predicted = step_.filtered = s;
  step_.restart = true;
  step_.pose_measured = true;  // the given pose is this frame's estimate
  initialized_ = true;
  frames_lost_ = 0;
}

void MotionModel::Reinitialize(double t, const Pose2& pose, const Eigen::Matrix3d& pose_covariance) {
  Reset(t, pose, pose_covariance, options_.max_speed, options_.max_turn_rate);
}

void MotionModel::CheckTime(double t, const char* what) const {
  if (!initialized_) throw Error(std::string("motion model: ") + what + " before Reset");
  if (!std::isfinite(t) || t < time())
    throw Error(std::string("motion model: ") + what + " to time " + std::to_string(t) +
                ", before the filter's time " + std::to_string(time()));
}

void MotionModel::BeginStep(double t, const MotionVector& mean, const MotionMatrix& covariance,
                            const MotionMatrix& transition) {
  MotionState s;
  s.time_s = t;
  s.mean = mean;
  s.covariance = Symmetric(covariance);
  CapCovariance(&s.covariance);
  step_ = MotionStep{};
  step_.predicted = step_.filtered = s;
  step_.transition = transition;
  step_.restart = false;
}

void MotionModel::CapCovariance(MotionMatrix* p) const {
  CapBlock2(p, 0, options_.max_position_sigma);
  CapBlock1(p, 2, options_.max_heading_sigma);
  CapBlock2(p, 3, options_.max_speed);
  CapBlock1(p, 5, options_.max_turn_rate);
}

const MotionState& MotionModel::Predict(double t) {
  CheckTime(t, "Predict");
  const double dt = t - time();
  const MotionMatrix f = ConstantVelocityJacobian(dt);
  const MotionState& prior = state();
  BeginStep(t, PropagateConstantVelocity(prior.mean, dt),
            f * prior.covariance * f.transpose() + ConstantVelocityNoise(dt, options_), f);
  return state();
}

const MotionState& MotionModel::PredictWithOdometry(double t, const OdometryIncrement& inc) {
  CheckTime(t, "PredictWithOdometry");
  if (!std::isfinite(inc.dx) || !std::isfinite(inc.dy) || !std::isfinite(inc.dtheta) ||
      !AllFinite(inc.covariance))
    throw Error("motion model: an odometry increment that is not finite");
  const double dt = t - time();
  const MotionState& prior = state();
  const MotionMatrix f = OdometryJacobian(prior.mean, dt, inc);
  const Eigen::Matrix<double, 6, 3> g = OdometryInputJacobian(prior.mean, dt, inc);
  MotionMatrix noise = g * inc.covariance * g.transpose();
  // The velocity is the increment's mean over dt; white acceleration keeps
  // the instantaneous one uncertain around it.
  noise.bottomRightCorner<3, 3>() += ConstantVelocityNoise(dt, options_).bottomRightCorner<3, 3>();
  BeginStep(t, PropagateOdometry(prior.mean, dt, inc), f * prior.covariance * f.transpose() + noise, f);
  return state();
}

const MotionState& MotionModel::MarkLost(double t) {
  Predict(t);
  ++frames_lost_;
  return state();
}

namespace {

Eigen::Vector3d PoseResidual(const PoseMeasurement& m, const MotionVector& mean) {
  return {m.pose.x - mean(0), m.pose.y - mean(1), WrapAngle(m.pose.theta - mean(2))};
}

void CheckMeasurement(const PoseMeasurement& m) {
  if (!std::isfinite(m.pose.x) || !std::isfinite(m.pose.y) || !std::isfinite(m.pose.theta) ||
      !m.covariance.allFinite())
    throw Error("motion model: a pose measurement that is not finite");
}

void CheckHeading(double theta, double sigma) {
  if (!std::isfinite(theta) || !(sigma > 0.0) || !std::isfinite(sigma))
    throw Error("motion model: a heading measurement needs a finite angle and a positive finite sigma");
}

template <int N>
double Mahalanobis2(const Eigen::Matrix<double, N, 1>& r, const Eigen::Matrix<double, N, N>& s) {
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(s);
  if (llt.info() != Eigen::Success)
    throw Error("motion model: the innovation covariance is not positive definite");
  return r.dot(llt.solve(r));
}

}  // namespace

double MotionModel::Innovation(const PoseMeasurement& m) const {
  if (!initialized_) throw Error("motion model: Innovation before Reset");
  CheckMeasurement(m);
  const Eigen::Matrix3d s = pose_covariance() + 0.5 * (m.covariance + m.covariance.transpose());
  return Mahalanobis2<3>(PoseResidual(m, state().mean), s);
}

double MotionModel::HeadingInnovation(double theta, double sigma) const {
  if (!initialized_) throw Error("motion model: HeadingInnovation before Reset");
  CheckHeading(theta, sigma);
  const double r = WrapAngle(theta - state().mean(2));
  const double s = state().covariance(2, 2) + sigma * sigma;
  return r * r / s;
}

template <int N>
void MotionModel::UpdateRows(const int (&rows)[N], const Eigen::Matrix<double, N, 1>& residual,
                             const Eigen::Matrix<double, N, N>& noise) {
  MotionState& x = step_.filtered;
  Eigen::Matrix<double, N, 6> h = Eigen::Matrix<double, N, 6>::Zero();
  for (int i = 0; i < N; ++i) h(i, rows[i]) = 1.0;
  const Eigen::Matrix<double, 6, N> ph = x.covariance * h.transpose();
  const Eigen::Matrix<double, N, N> s = h * ph + noise;
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(s);
  if (llt.info() != Eigen::Success)
    throw Error("motion model: the innovation covariance is not positive definite");
  const Eigen::Matrix<double, 6, N> k = llt.solve(ph.transpose()).transpose();
  x.mean += k * residual;
  x.mean(2) = WrapAngle(x.mean(2));
  // Joseph form: stays symmetric positive semi-definite with rounding.
  const MotionMatrix a = MotionMatrix::Identity() - k * h;
  x.covariance = Symmetric(a * x.covariance * a.transpose() + k * noise * k.transpose());
}

void MotionModel::Update(const PoseMeasurement& m) {
  if (!initialized_) throw Error("motion model: Update before Reset");
  CheckMeasurement(m);
  const int rows[3] = {0, 1, 2};
  const Eigen::Matrix3d noise = 0.5 * (m.covariance + m.covariance.transpose());
  UpdateRows<3>(rows, PoseResidual(m, state().mean), noise);
  step_.pose_measured = true;
  frames_lost_ = 0;
}

void MotionModel::UpdateHeading(double theta, double sigma) {
  if (!initialized_) throw Error("motion model: UpdateHeading before Reset");
  CheckHeading(theta, sigma);
  const int rows[1] = {2};
  Eigen::Matrix<double, 1, 1> r, noise;
  r << WrapAngle(theta - state().mean(2));
  noise << sigma * sigma;
  UpdateRows<1>(rows, r, noise);
  step_.heading_measured = true;
}

void FixedLagSmootherOptions::Check() const {
  if (lag < 0 || lag > 10000)
    throw Error("fixed-lag smoother options: lag must be between 0 and 10000 frames, got " +
                std::to_string(lag));
}

FixedLagSmoother::FixedLagSmoother(const FixedLagSmootherOptions& options) : options_(options) {
  options_.Check();
}

std::vector<SmoothedState> FixedLagSmoother::Push(const MotionStep& step) {
  if (!window_.empty() && !(step.predicted.time_s >= window_.back().filtered.time_s))
    throw Error("fixed-lag smoother: step at time " + std::to_string(step.predicted.time_s) +
                " after one at " + std::to_string(window_.back().filtered.time_s));
  std::vector<SmoothedState> out;
  if (step.restart) out = Flush();
  window_.push_back(step);
  if (window_.size() > static_cast<size_t>(options_.lag)) {
    out.push_back(SmoothWindow().front());
    window_.pop_front();
  }
  return out;
}

std::vector<SmoothedState> FixedLagSmoother::Flush() {
  std::vector<SmoothedState> out = SmoothWindow();
  window_.clear();
  return out;
}

std::vector<SmoothedState> FixedLagSmoother::SmoothWindow() const {
  const int n = static_cast<int>(window_.size());
  std::vector<SmoothedState> out(n);
  for (int k = n - 1; k >= 0; --k) {
    const MotionStep& step = window_[k];
    SmoothedState& sm = out[k];
    sm.pose_measured = step.pose_measured;
    sm.heading_measured = step.heading_measured;
    sm.state = step.filtered;
    if (k == n - 1) continue;
    // RTS: x_k|N = x_k|k + C (x_k+1|N - x_k+1|k), C = P_k|k F^T P_k+1|k^-1.
    const MotionStep& next = window_[k + 1];
    const MotionMatrix& p_pred = next.predicted.covariance;
    const MotionMatrix fp = next.transition * step.filtered.covariance;
    const MotionMatrix c = p_pred.ldlt().solve(fp).transpose();
    MotionVector diff = out[k + 1].state.mean - next.predicted.mean;
    diff(2) = WrapAngle(diff(2));
    sm.state.mean += c * diff;
    sm.state.mean(2) = WrapAngle(sm.state.mean(2));
    sm.state.covariance =
        Symmetric(step.filtered.covariance + c * (out[k + 1].state.covariance - p_pred) * c.transpose());
  }
  return out;
}

}  // namespace pano

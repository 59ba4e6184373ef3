// The robot's motion between frames: an extended Kalman filter over the state
// (x, y, theta, vx, vy, omega) in the world frame, and a fixed-lag smoother
// over its last steps.
//
// Between frames the robot moves at a constant velocity disturbed by white
// acceleration (the continuous-time model, so that one step of 2 dt is the
// same as two steps of dt: a dropped frame only widens the prediction), or by
// a wheel-odometry increment when one is available. Triangulated poses
// (pose/triangulate.h, with their covariance) and visual-compass headings are
// fused as they come; a frame without a pose only predicts, and the
// uncertainty grows up to caps so that a search window derived from it stays
// within the room.
#pragma once

#include <Eigen/Core>
#include <deque>
#include <optional>
#include <vector>

#include "panotrack/pose/odometry_increment.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

using MotionVector = Eigen::Matrix<double, 6, 1>;  // x, y, theta, vx, vy, omega
using MotionMatrix = Eigen::Matrix<double, 6, 6>;

// Squared Mahalanobis distances that a correct measurement exceeds with
// probability 1 %: chi-square quantiles for gating with Innovation().
constexpr double kGateChiSquare3Dof99 = 11.345;  // a pose (x, y, theta)
constexpr double kGateChiSquare2Dof99 = 9.210;   // a position (x, y)
constexpr double kGateChiSquare1Dof99 = 6.635;   // a heading

// Lengths are in map units. The defaults describe an indoor wheeled robot in
// a map measured in metres; ForMapUnitsPerMetre() rescales them for a map in
// other units (100 for centimetres).
struct MotionModelOptions {
  // Standard deviation of the white acceleration, per axis, in map units/s^2:
  // its spectral density is accel_sigma^2 * 1 s, so that the velocity
  // random-walks by accel_sigma * sqrt(dt / 1 s) over dt.
  double accel_sigma = 0.5;
  // The same for the heading rate, rad/s^2.
  double angular_accel_sigma = 1.5;
  // The robot's top speed (map units/s) and turn rate (rad/s): the velocity's
  // standard deviation when it is unknown (after Reinitialize) and the cap on
  // it while no pose comes.
  double max_speed = 1.0;
  double max_turn_rate = 2.0;
  // Caps on the position's (largest axis, map units) and the heading's
  // standard deviations while the robot is lost: about the room's size and
  // half a turn, beyond which the prediction says nothing anyway.
  double max_position_sigma = 10.0;
  double max_heading_sigma = M_PI;

  // These options (given in metres) with their lengths scaled for a map in
  // units of 1 / units_per_metre.
  MotionModelOptions Scaled(double units_per_metre) const;
  // The defaults, scaled so.
  static MotionModelOptions ForMapUnitsPerMetre(double units_per_metre);
  // Throws pano::Error naming the first field that is not a positive finite number.
  void Check() const;
};

// A triangulated pose and its covariance (x, y, theta).
struct PoseMeasurement {
  Pose2 pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

// The filter's estimate at one time.
struct MotionState {
  double time_s = 0.0;
  MotionVector mean = MotionVector::Zero();  // theta wrapped to (-pi, pi]
  MotionMatrix covariance = MotionMatrix::Zero();

  Pose2 pose() const { return {mean(0), mean(1), mean(2)}; }
  Eigen::Matrix3d pose_covariance() const { return covariance.topLeftCorner<3, 3>(); }
  // World-frame velocity, map units/s.
  Eigen::Vector2d velocity() const { return mean.segment<2>(3); }
  double heading_rate() const { return mean(5); }
};

// One frame of the filter, for the smoother: the prediction to this frame,
// the estimate after its measurements, and the Jacobian between the previous
// frame's estimate and this prediction.
struct MotionStep {
  MotionState predicted;
  MotionState filtered;
  MotionMatrix transition = MotionMatrix::Identity();
  bool restart = true;  // first step after Reset or Reinitialize: no link back
  bool pose_measured = false;
  bool heading_measured = false;
};

// The step from a pose to a motion state's pose, the heading difference
// wrapped to (-pi, pi].
Eigen::Vector3d StepTowardState(const Pose2& pose, const MotionState& state);

// The squared Mahalanobis distance between a pose of covariance
// `covariance` and a motion state's pose (under the sum of the two).
double PoseInnovation(const Pose2& pose, const Eigen::Matrix3d& covariance, const MotionState& state);

// A measured pose fused with a motion state's pose, each weighed by its
// covariance (the heading difference wrapped): the Kalman update of the
// pose alone. None where the two disagree: their difference's squared
// Mahalanobis distance under the sum of the covariances exceeds `gate`
// (e.g. kGateChiSquare3Dof99), or that sum is singular.
std::optional<PoseMeasurement> FuseWithState(const PoseMeasurement& measured, const MotionState& state, double gate);

// The process models and their Jacobians with respect to the state.
// Constant velocity over dt.
MotionVector PropagateConstantVelocity(const MotionVector& state, double dt);
MotionMatrix ConstantVelocityJacobian(double dt);
// The white-acceleration noise accumulated over dt.
MotionMatrix ConstantVelocityNoise(double dt, const MotionModelOptions& options);
// Odometry as the control input: the pose moves by the increment (given in the
// robot frame at the start), and the velocity becomes the increment's mean
// velocity over dt (kept as it was when dt is 0).
MotionVector PropagateOdometry(const MotionVector& state, double dt, const OdometryIncrement& increment);
MotionMatrix OdometryJacobian(const MotionVector& state, double dt, const OdometryIncrement& increment);
// Jacobian of PropagateOdometry with respect to (dx, dy, dtheta).
Eigen::Matrix<double, 6, 3> OdometryInputJacobian(const MotionVector& state, double dt,
                                                  const OdometryIncrement& increment);

// Usage per frame at time t: Predict(t) (or PredictWithOdometry), then, with
// a triangulated pose, gate it with Innovation() and Update(); without one,
// MarkLost(t) instead of Predict(t). step() is what the smoother takes.
class MotionModel {
 public:
  explicit MotionModel(const MotionModelOptions& options = {});

  // Starts at `pose` at time t with zero velocity of the given standard
  // deviations (per world axis, map units/s, and rad/s). The step starts a
  // new chain for the smoother and counts the pose as this frame's
  // measurement.
  void Reset(double t, const Pose2& pose, const Eigen::Matrix3d& pose_covariance,
             double speed_sigma, double turn_rate_sigma);
  // After a relocalisation: the pose is new, the velocity unknown (zero with
  // the options' max_speed and max_turn_rate as standard deviations).
  void Reinitialize(double t, const Pose2& pose, const Eigen::Matrix3d& pose_covariance);
  bool initialized() const { return initialized_; }

  // Advances the state to time t >= time() at constant velocity and starts a
  // new step. Throws pano::Error before Reset or when t goes back.
  const MotionState& Predict(double t);
  // Advances with wheel odometry as the control input instead.
  const MotionState& PredictWithOdometry(double t, const OdometryIncrement& increment);
  // Predict(t) for a frame that gave no pose: counts the frames lost.
  const MotionState& MarkLost(double t);

  // Squared Mahalanobis distance of a measurement from the current state
  // (heading difference wrapped), for gating before Update().
  double Innovation(const PoseMeasurement& measurement) const;
  double HeadingInnovation(double theta, double sigma) const;
  // Fuses a pose, or a heading alone (visual compass), into the state.
  void Update(const PoseMeasurement& measurement);
  void UpdateHeading(double theta, double sigma);

  const MotionState& state() const { return step_.filtered; }
  double time() const { return step_.filtered.time_s; }
  Pose2 pose() const { return state().pose(); }
  Eigen::Matrix3d pose_covariance() const { return state().pose_covariance(); }
  // The velocity and heading rate expected over the next frame, for sizing
  // motion-blur widths and search windows.
  Eigen::Vector2d PredictedVelocity() const { return state().velocity(); }
  double PredictedHeadingRate() const { return state().heading_rate(); }
  // Frames since the last pose update (MarkLost calls).
  int frames_lost() const { return frames_lost_; }
  // The current frame's step, for FixedLagSmoother::Push.
  const MotionStep& step() const { return step_; }
  const MotionModelOptions& options() const { return options_; }

 private:
  void CheckTime(double t, const char* what) const;
  void BeginStep(double t, const MotionVector& mean, const MotionMatrix& covariance,
                 const MotionMatrix& transition);
  void CapCovariance(MotionMatrix* covariance) const;
  // Generic update with a measurement of the rows `rows` of the state.
  template <int N>
  void UpdateRows(const int (&rows)[N], const Eigen::Matrix<double, N, 1>& residual,
                  const Eigen::Matrix<double, N, N>& noise);

  MotionModelOptions options_;
  bool initialized_ = false;
  int frames_lost_ = 0;
  MotionStep step_;
};

struct FixedLagSmootherOptions {
  // Frames between a frame and the newest one whose measurements smooth it:
  // each smoothed state comes out `lag` frames late.
  int lag = 10;
  void Check() const;
};

struct SmoothedState {
  MotionState state;  // the smoothed mean and covariance
  // Copied from the step: a frame with neither was smoothed from its
  // neighbours alone.
  bool pose_measured = false;
  bool heading_measured = false;
};

// Rauch-Tung-Striebel over a sliding window: the state of the frame `lag`
// steps back given every measurement up to the newest frame.
class FixedLagSmoother {
 public:
  explicit FixedLagSmoother(const FixedLagSmootherOptions& options = {});
  // Adds the filter's newest step and returns what leaves the window: the
  // frame `lag` steps back (nothing while the window fills). A restart step
  // (after Reset or Reinitialize) first flushes the frames before it, which
  // are smoothed among themselves. Throws pano::Error when time goes back.
  std::vector<SmoothedState> Push(const MotionStep& step);
  // Every frame still in the window, oldest first, smoothed; empties it.
  std::vector<SmoothedState> Flush();
  size_t pending() const { return window_.size(); }

 private:
  // Smoothed states of the whole window, oldest first.
  std::vector<SmoothedState> SmoothWindow() const;

  FixedLagSmootherOptions options_;
  std::deque<MotionStep> window_;
};

}  // namespace pano

// Internals of lib/panotrack/calibrate shared by its .cc files (not installed API).
#pragma once

#include <ceres/rotation.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/corner_weights.h"
#include "panotrack/calibrate/refit.h"
#include "panotrack/sensor/catadioptric.h"
#include "panotrack/sensor/general_model.h"
#include "panotrack/sensor/sensor.h"

namespace pano::calib_internal {

// The sensor parameter block of the fit.
enum SensorIndex {
  kFocal = 0,
  kCx,
  kCy,
  kAspect,
  kAzimuth,
  kK1,
  kK2,
  kRadius,   // curvature radius at the vertex
  kConic,    // conic constant (0 for the sphere)
  kVertex,   // vertex distance above the pinhole
  kXi,       // the unified profile's xi (0 for the mirror profiles)
  kUnified,  // 1 for the unified profile, 0 for a mirror; always held fixed
  kNumSensor
};

template <typename T>
SensorParams<T> ParamsFromBlock(const T* s) {
  SensorParams<T> p;
  p.focal_px = s[kFocal];
  p.cx = s[kCx];
  p.cy = s[kCy];
  p.aspect = s[kAspect];
  p.azimuth_offset = s[kAzimuth];
  p.k1 = s[kK1];
  p.k2 = s[kK2];
  p.curvature_radius = s[kRadius];
  p.conic_constant = s[kConic];
  p.vertex_distance = s[kVertex];
  p.xi = s[kXi];
  p.unified = ScalarValue(s[kUnified]) != 0.0;
  p.rim_radius = T(0);
  return p;
}

inline std::array<double, kNumSensor> BlockFromParams(const SensorParams<double>& p) {
  std::array<double, kNumSensor> s{};
  s[kFocal] = p.focal_px;
  s[kCx] = p.cx;
  s[kCy] = p.cy;
  s[kAspect] = p.aspect;
  s[kAzimuth] = p.azimuth_offset;
  s[kK1] = p.k1;
  s[kK2] = p.k2;
  s[kRadius] = p.curvature_radius;
  s[kConic] = p.conic_constant;
  s[kVertex] = p.vertex_distance;
  s[kXi] = p.xi;
  s[kUnified] = p.unified ? 1.0 : 0.0;
  return s;
}

// The rig-fault parameter block of the fit (general_model.h's RigFaults).
enum FaultIndex {
  kOffsetX = 0,  // mirror_offset
  kOffsetY,
  kCameraTiltX,  // camera_tilt
  kCameraTiltY,
  kP1,
  kP2,
  kK3,
  kSensorTiltX,  // sensor_tilt
  kSensorTiltY,
  kSkew,
  kNumFaults
};

template <typename T>
RigFaults<T> FaultsFromBlock(const T* f) {
  RigFaults<T> r;
  r.mirror_offset[0] = f[kOffsetX];
  r.mirror_offset[1] = f[kOffsetY];
  r.camera_tilt[0] = f[kCameraTiltX];
  r.camera_tilt[1] = f[kCameraTiltY];
  r.p1 = f[kP1];
  r.p2 = f[kP2];
  r.k3 = f[kK3];
  r.sensor_tilt[0] = f[kSensorTiltX];
  r.sensor_tilt[1] = f[kSensorTiltY];
  r.skew = f[kSkew];
  return r;
}

inline std::array<double, kNumFaults> BlockFromFaults(const RigFaults<double>& r) {
  return {r.mirror_offset[0], r.mirror_offset[1], r.camera_tilt[0], r.camera_tilt[1], r.p1, r.p2, r.k3,
          r.sensor_tilt[0], r.sensor_tilt[1], r.skew};
}

// Indices of the fault block held fixed (the faults not named free).
std::vector<int> FixedFaultIndices(bool poses_known, const CalibrateOptions& o);

// Physically meaningful parameter values (the fit rejects steps outside).
template <typename T>
bool PlausibleParams(const SensorParams<T>& p) {
  if (!(p.focal_px > T(0) && p.aspect > T(0.2) && p.aspect < T(5.0))) return false;
  if (p.unified) return p.xi >= T(0) && p.xi <= T(10);
  return p.curvature_radius > T(0) && p.vertex_distance > T(0);
}

// Faults of a plausible rig (the fit rejects steps outside: a free decentre
// may wander off where the data hardly constrain it): the mirror's offset
// within half its curvature radius, tilts within 20 degrees.
template <typename T>
bool PlausibleFaults(const GeneralSensorParams<T>& g) {
  const T& dx = g.faults.mirror_offset[0];
  const T& dy = g.faults.mirror_offset[1];
  if (!g.aligned.unified &&
      !(dx * dx + dy * dy < T(0.25) * g.aligned.curvature_radius * g.aligned.curvature_radius))
    return false;
  for (const T* a : {g.faults.camera_tilt, g.faults.sensor_tilt})
    if (!(a[0] * a[0] + a[1] * a[1] < T(0.12))) return false;
  return true;
}

// A board pose as the fit's parameter block: angle-axis, then translation.
inline std::array<double, 6> PackPose(const Eigen::Vector3d& rvec, const Eigen::Vector3d& tvec) {
  return {rvec.x(), rvec.y(), rvec.z(), tvec.x(), tvec.y(), tvec.z()};
}
inline std::array<double, 6> PackPose(const BoardView& view) { return PackPose(view.rvec, view.tvec); }
inline void UnpackPose(const std::array<double, 6>& pose, BoardView* view) {
  view->rvec = Eigen::Vector3d(pose[0], pose[1], pose[2]);
  view->tvec = Eigen::Vector3d(pose[3], pose[4], pose[5]);
}

// Target image i's board view (file, known pose) with these corners.
inline BoardView ViewOfImage(const TargetSet& targets, int i, const std::vector<Eigen::Vector2d>& corners,
                             const std::string& method) {
  const TargetImage& ti = targets.images[static_cast<size_t>(i)];
  BoardView v;
  v.image_index = i;
  v.file = ti.file;
  v.corners = corners;
  v.method = method;
  v.has_pose = ti.has_pose;
  v.rvec = Eigen::Vector3d(ti.rvec[0], ti.rvec[1], ti.rvec[2]);
  v.tvec = Eigen::Vector3d(ti.tvec[0], ti.tvec[1], ti.tvec[2]);
  return v;
}

// The images of `images` (target file indices) that none of `views` is of.
inline std::vector<int> ImagesWithout(const std::vector<int>& images, const std::vector<BoardView>& views) {
  std::vector<int> left;
  for (int i : images)
    if (std::none_of(views.begin(), views.end(), [i](const BoardView& v) { return v.image_index == i; }))
      left.push_back(i);
  return left;
}

// Rim that caps the visible mirror at normalised radius m_cap when the limb
// lies beyond it (a hyperboloid has none: its rays would run off to infinity).
inline double RimForRadius(SensorParams<double> p, double m_cap) {
  p.rim_radius = 0.0;
  const double m_limb = MaxNormalizedRadius(p);
  if (!(m_cap > 0.0) || (std::isfinite(m_limb) && m_limb <= m_cap)) return 0.0;
  if (p.unified) return m_cap;  // its rim is a normalised radius
  // Rays steeper than a hyperboloid's asymptote never meet it.
  if (p.conic_constant < -1.0) m_cap = std::min(m_cap, 0.999 * std::sqrt(-(1.0 + p.conic_constant)));
  double s, z;
  for (int i = 0; i < 100; ++i, m_cap *= 0.95)
    if (MirrorHit(p, m_cap, &s, &z)) return s;
  return 0.0;
}

// A board point (board frame) in the sensor frame: pose = angle-axis, then
// translation.
template <typename T>
void BoardPointInSensor(const T* pose, const Eigen::Vector3d& board_point, T* point_sensor) {
  const T Xb[3] = {T(board_point.x()), T(board_point.y()), T(board_point.z())};
  ceres::AngleAxisRotatePoint(pose, Xb, point_sensor);
  for (int i = 0; i < 3; ++i) point_sensor[i] += pose[3 + i];
}

// The pixel error (u, v) - observed, whitened by the corner's sqrt information.
template <typename T>
void WhitenedResidual(const Eigen::Matrix2d& sqrt_info, const T& u, const T& v, const Eigen::Vector2d& observed,
                      T* residual) {
  const T du = u - T(observed.x()), dv = v - T(observed.y());
  residual[0] = T(sqrt_info(0, 0)) * du + T(sqrt_info(0, 1)) * dv;
  residual[1] = T(sqrt_info(1, 0)) * du + T(sqrt_info(1, 1)) * dv;
}

// Reprojection residual of one board corner (pixels): sensor block, pose
// block (angle-axis, translation).
struct CornerCost {
  // cap_px: image radius (pixels) beyond which the mirror is taken to end.
  // sqrt_info: the residual is sqrt_info * (projected - observed), a square
  // root of the corner's information matrix (CornerWeights); identity: pixels.
  CornerCost(const Eigen::Vector3d& board_point, const Eigen::Vector2d& pixel, double cap_px,
             const Eigen::Matrix2d& sqrt_info = Eigen::Matrix2d::Identity())
      : X(board_point), obs(pixel), cap(cap_px), L(sqrt_info) {}
  template <typename T>
  bool operator()(const T* sensor, const T* pose, T* residual) const {
    SensorParams<T> p = ParamsFromBlock(sensor);
    if (!PlausibleParams(p)) return false;
    p.asphere_a4 = T(asphere_a4);
    p.asphere_a6 = T(asphere_a6);
    p.rim_radius = T(RimForRadius(p.template cast<double>(), cap / ScalarValue(p.focal_px)));
    T Xs[3];
    BoardPointInSensor(pose, X, Xs);
    T u, v;
    if (!project(p, Xs, &u, &v)) return false;
    WhitenedResidual(L, u, v, obs, residual);
    return true;
  }
  // The mirror's even-asphere terms held fixed (SensorParams); zero for the
  // sphere and the conic, whose projection then takes the closed form.
  CornerCost& WithAsphere(const SensorParams<double>& p) {
    asphere_a4 = p.asphere_a4;
    asphere_a6 = p.asphere_a6;
    return *this;
  }
  Eigen::Vector3d X;
  Eigen::Vector2d obs;
  double cap;
  Eigen::Matrix2d L;
  double asphere_a4 = 0.0, asphere_a6 = 0.0;
};

// CornerCost through the general model (ProjectGeneral): sensor block,
// fault block, pose block. Used whenever a fault is free or non-zero, since
// with Jets only ProjectGeneral carries derivatives in the faults.
struct GeneralCornerCost {
  GeneralCornerCost(const Eigen::Vector3d& board_point, const Eigen::Vector2d& pixel, double cap_px,
                    const Eigen::Matrix2d& sqrt_info = Eigen::Matrix2d::Identity())
      : X(board_point), obs(pixel), cap(cap_px), L(sqrt_info) {}
  template <typename T>
  bool operator()(const T* sensor, const T* faults, const T* pose, T* residual) const {
    GeneralSensorParams<T> g;
    g.aligned = ParamsFromBlock(sensor);
    if (!PlausibleParams(g.aligned)) return false;
    g.aligned.rim_radius = T(RimForRadius(g.aligned.template cast<double>(), cap / ScalarValue(g.aligned.focal_px)));
    g.faults = FaultsFromBlock(faults);
    if (!PlausibleFaults(g)) return false;
    T Xs[3];
    BoardPointInSensor(pose, X, Xs);
    T u, v;
    if (!ProjectGeneral(g, Xs, &u, &v)) return false;
    WhitenedResidual(L, u, v, obs, residual);
    return true;
  }
  Eigen::Vector3d X;
  Eigen::Vector2d obs;
  double cap;
  Eigen::Matrix2d L;
};

// The even-asphere terms of the fit (model asphere): a block of their own, so
// that sphere and conic fits keep their cost and speed.
enum AsphereIndex { kA4 = 0, kA6, kNumAsphere };

// CornerCost and GeneralCornerCost with the asphere block as free parameters:
// (sensor, asphere, pose) or (sensor, faults, asphere, pose).
struct AsphereCornerCost {
  AsphereCornerCost(const Eigen::Vector3d& board_point, const Eigen::Vector2d& pixel, double cap_px,
                    const Eigen::Matrix2d& sqrt_info = Eigen::Matrix2d::Identity())
      : X(board_point), obs(pixel), cap(cap_px), L(sqrt_info) {}
  template <typename T>
  bool operator()(const T* sensor, const T* asphere, const T* pose, T* residual) const {
    return Evaluate(sensor, static_cast<const T*>(nullptr), asphere, pose, residual, false);
  }
  template <typename T>
  bool operator()(const T* sensor, const T* faults, const T* asphere, const T* pose, T* residual) const {
    return Evaluate(sensor, faults, asphere, pose, residual, true);
  }
  template <typename T>
  bool Evaluate(const T* sensor, const T* faults, const T* asphere, const T* pose, T* residual, bool general) const {
    GeneralSensorParams<T> g;
    g.aligned = ParamsFromBlock(sensor);
    if (!PlausibleParams(g.aligned)) return false;
    g.aligned.asphere_a4 = asphere[kA4];
    g.aligned.asphere_a6 = asphere[kA6];
    g.aligned.rim_radius = T(RimForRadius(g.aligned.template cast<double>(), cap / ScalarValue(g.aligned.focal_px)));
    T Xs[3];
    BoardPointInSensor(pose, X, Xs);
    T u, v;
    if (general) {
      g.faults = FaultsFromBlock(faults);
      if (!PlausibleFaults(g)) return false;
      if (!ProjectGeneral(g, Xs, &u, &v)) return false;
    } else if (!project(g.aligned, Xs, &u, &v)) {
      return false;
    }
    WhitenedResidual(L, u, v, obs, residual);
    return true;
  }
  Eigen::Vector3d X;
  Eigen::Vector2d obs;
  double cap;
  Eigen::Matrix2d L;
};

// The image radius that caps the mirror in the fit: 1.5 x the half-diagonal.
inline double CapRadiusPx(int width, int height) { return 0.75 * std::hypot(width, height); }

// Pose of one more board through an already fitted sensor (the linear
// in-plane solve, then its height along the corners' rays). False on failure.
bool InitialPoseFromSensor(const BoardView& view, const TargetBoard& board, const Sensor& sensor,
                           std::array<double, 6>* pose);

// Leaves out the corners of a board found in an unwarped view that lie off
// both where the board's pose through `sensor` puts them and where the
// affine trend of their grid neighbours' errors (within 2 board points)
// puts them, each by more than 1 px and 5 times the board's median of that
// figure, refitting the pose until none is left; the view then carries ids.
// At the limb, where the squares shrink to 2 - 4 px, the view's detector
// can place a corner several pixels off, and where it does depends on the
// last digits of the model the view was unwarped through: one such corner
// among 500 doubles a calibration's RMS. The model's own error, smooth
// across a board (a rough first fit's at the limb, or a poor calibration's
// under evaluation), follows the trend and takes out no corner. False when
// the corners left are too few for a board.
bool DropStrayCorners(const TargetBoard& board, const Sensor& sensor, BoardView* view);

// Step 4a: the images `missing` (target file indices) searched in views
// unwarped through `sensor`, near where the fitted boards `fitted` lie
// (their median distance and height), in parallel over images. Returns the
// boards found (method "unwarped", corners refined in the raw image);
// searches that raised an error are added to *warnings (when given).
std::vector<BoardView> FindUnwarpedBoards(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                          const std::vector<int>& missing, const std::vector<BoardView>& fitted,
                                          const Sensor& sensor, int threads, std::vector<std::string>* warnings);

// Step 4a as calibrate and evaluate run it: the images det.not_found searched
// in views unwarped through `sensor` (FindUnwarpedBoards), then those still
// without a board by the exhaustive raw search when det deferred it; the
// boards found in image order.
std::vector<BoardView> FindMissingBoards(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                         const DetectionResult& det, const std::vector<BoardView>& fitted,
                                         const Sensor& sensor, int threads, std::vector<std::string>* warnings);

// Pose of one more board from the rays of its corners through `sensor`
// (rig faults and asphere terms included): the homography from the board
// plane to the rays' directions, made a rotation, then the translation with
// the rays' own origins. A start that does not depend on the image centre
// (InitialPoseFromSensor's in-plane solve is about cx, cy, where a decentred
// mirror's image is not centred). False on failure.
bool PoseFromRays(const BoardView& view, const TargetBoard& board, const Sensor& sensor,
                  std::array<double, 6>* pose);

// Indices of the sensor block held fixed for this model and these options.
std::vector<int> FixedSensorIndices(bool poses_known, const CalibrateOptions& o);

// For a hyperboloid without a limb: the rim that keeps the whole image on the
// mirror (so that Sensor::Check passes and back-projection works everywhere).
void SetRimForImage(Sensor* sensor);

}  // namespace pano::calib_internal

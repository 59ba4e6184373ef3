// Synthetic corner observations: board corners projected through the sensor
// model with Gaussian pixel noise (no rendering, so the fit is tested exactly).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <vector>

#include "panotrack/calibrate/calibrate.h"

namespace pano::test {

struct SyntheticSet {
  TargetBoard board;
  std::vector<BoardView> views;
  std::vector<std::array<double, 6>> true_poses;
};

// `n` boards around the sensor: centres at horizontal distance d_min..d_max,
// heights z_min..z_max, every azimuth, facing the mirror with random tilts.
// Only poses whose every corner is visible inside the image are kept.
template <typename Rng>
SyntheticSet MakeSyntheticSet(const Sensor& sensor, const TargetBoard& board, int n, double d_min, double d_max,
                              double z_min, double z_max, double noise_px, Rng& rng) {
  SyntheticSet set;
  set.board = board;
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::normal_distribution<double> N(0.0, 1.0);
  const std::vector<Eigen::Vector3d> pts = BoardPoints(board);
  const Eigen::Vector3d mid(0.5 * (board.cols - 1) * board.square, 0.5 * (board.rows - 1) * board.square, 0);
  const double view_z = sensor.params.vertex_distance;
  int attempts = 0;
  while (static_cast<int>(set.views.size()) < n && attempts++ < 20000) {
    const double az = 2.0 * M_PI * (set.views.size() + U(rng) * 0.8) / n;  // spread over azimuth
    const double D = d_min + (d_max - d_min) * U(rng);
    const double Z = z_min + (z_max - z_min) * U(rng);
    const Eigen::Vector3d C(D * std::cos(az), D * std::sin(az), Z);
    Eigen::Vector3d zb = (C - Eigen::Vector3d(0, 0, view_z)).normalized();
    // Random tilt up to ~35 degrees. One draw per statement: the order in
    // which a call's arguments are evaluated is unspecified (gcc and clang
    // differ), and the data must not depend on the compiler. Last component
    // first: the order the tests' figures were measured with.
    const double tilt_z = 0.35 * N(rng), tilt_y = 0.35 * N(rng), tilt_x = 0.35 * N(rng);
    const Eigen::Vector3d tilt(tilt_x, tilt_y, tilt_z);
    zb = (Eigen::AngleAxisd(tilt.norm(), tilt.normalized()) * zb).normalized();
    Eigen::Vector3d xb = Eigen::Vector3d::UnitZ().cross(zb).normalized();
    const double roll = 0.5 * N(rng);
    xb = Eigen::AngleAxisd(roll, zb) * xb;
    const Eigen::Vector3d yb = zb.cross(xb);
    Eigen::Matrix3d R;
    R.col(0) = xb;
    R.col(1) = yb;
    R.col(2) = zb;
    const Eigen::Vector3d t = C - R * mid;
    BoardView v;
    bool ok = true;
    for (const Eigen::Vector3d& p : pts) {
      Eigen::Vector2d px;
      if (!sensor.project(R * p + t, &px) || !sensor.inside_image(px, 2.0)) {
        ok = false;
        break;
      }
      const double noise_v = N(rng), noise_u = N(rng);  // one draw per statement, as above
      v.corners.push_back(px + noise_px * Eigen::Vector2d(noise_u, noise_v));
    }
    if (!ok) continue;
    std::array<double, 6> pose{};
    const Eigen::AngleAxisd aa(R);
    const Eigen::Vector3d rv = aa.angle() * aa.axis();
    pose[0] = rv.x();
    pose[1] = rv.y();
    pose[2] = rv.z();
    pose[3] = t.x();
    pose[4] = t.y();
    pose[5] = t.z();
    v.image_index = static_cast<int>(set.views.size());
    v.file = "synthetic_" + std::to_string(v.image_index);
    v.has_pose = true;
    v.rvec = Eigen::Vector3d(pose[0], pose[1], pose[2]);
    v.tvec = t;
    set.views.push_back(v);
    set.true_poses.push_back(pose);
  }
  return set;
}

inline std::vector<BoardView> WithoutPoses(std::vector<BoardView> v) {
  for (BoardView& b : v) b.has_pose = false;
  return v;
}

inline double Param(const CalibrationResult& r, const std::string& name) {
  for (const ParameterEstimate& p : r.parameters)
    if (p.name == name) return p.value;
  return NAN;
}

}  // namespace pano::test

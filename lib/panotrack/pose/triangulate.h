// Pose from landmark azimuths (paper section 2).
//
// Each tracked landmark gives its bearing in the sensor frame (image azimuth
// minus azimuth_offset). For a heading theta_c the camera lies on the line
// through the landmark along bearing + theta_c. The paper solves the position
// by least squares over those lines (Eqn 1) and the heading by Newton-Raphson
// on the sum of squared perpendicular distances (Eqn 2). We do that, then
// refine (x, y, theta) jointly by Gauss-Newton on the bearing residuals
// themselves (angles, which is what the tracker measures with even accuracy
// whatever the landmark's distance), with Huber weights and rejection of
// outlying bearings, and give the first-order covariance.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

struct BearingObservation {
  Eigen::Vector2d landmark{0, 0};  // world (x, y)
  double bearing = 0.0;            // sensor-frame azimuth, radians
  double weight = 1.0;             // relative confidence (> 0)
  int id = -1;                     // caller's landmark index
  // Observations of one group lie on one vertical line (two corners of one
  // edge): one bearing's worth of evidence between them. -1: its own.
  int group = -1;
  // Its expected error relative to a bearing of image noise alone (>= 1):
  // a landmark whose surveyed position is uncertain. Every threshold on its
  // residual (Huber, outlier, inlier) is this much wider; the caller
  // divides `weight` by its square.
  double spread = 1.0;
};

// The number of independent bearings among obs[use]: distinct groups.
int DistinctBearings(const std::vector<BearingObservation>& obs, const std::vector<int>& use);

// The bearing obs[i] belongs to: its group, or its own index where it has
// none (a group's id is its first member's index, so the two never meet).
inline int BearingGroup(const std::vector<BearingObservation>& obs, int i) {
  const int group = obs[static_cast<size_t>(i)].group;
  return group >= 0 ? group : i;
}

struct TriangulationOptions {
  int min_landmarks = 3;
  // Refine by Gauss-Newton on bearing residuals after Eqns 1-2.
  bool refine = true;
  // Huber threshold on bearing residuals (radians).
  double huber = 0.3 * M_PI / 180;
  // Bearings off by more than this (radians) after the fit are dropped and
  // the pose solved again (while at least min_landmarks remain).
  double outlier_threshold = 1.5 * M_PI / 180;
  // Expected standard deviation of a bearing (radians), for the covariance
  // when too few landmarks are left to estimate it from the residuals.
  double bearing_sigma = 0.05 * M_PI / 180;
  // Degenerate when the smallest eigenvalue of the normalised normal matrix
  // (its position rows scaled by the landmarks' typical distance: the same
  // verdict in any unit), over its largest, is below this (all bearing
  // lines nearly parallel: landmarks on one line through the camera).
  double degenerate_eigen = 1e-6;
  void Check() const;
};

struct TriangulationResult {
  bool ok = false;
  std::string failure;  // why not ok
  Pose2 pose;
  // RMS perpendicular distance of the bearing lines from the position (map
  // units): the pose CSV's residual column.
  double residual = 0.0;
  double rms_bearing = 0.0;     // RMS bearing residual of the inliers (rad)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (x, y, theta)
  // The variance of a unit-weight bearing (rad^2) the covariance was scaled
  // by: from the residuals, or options.bearing_sigma^2 with too few.
  double variance_factor = 0.0;
  std::vector<int> inliers;     // indices into the observations
  std::vector<double> bearing_residuals;  // per observation (rad)
};

// Eqn 1: least-squares position for a given heading. Returns false when the
// lines are (nearly) parallel. `sum_dist2` receives Eqn 2's value.
bool PositionFromBearings(const std::vector<BearingObservation>& obs, double heading,
                          Eigen::Vector2d* position, double* sum_dist2);

// Eqn 2 minimised over the heading by Newton-Raphson from `heading0`.
bool HeadingNewtonRaphson(const std::vector<BearingObservation>& obs, double heading0,
                          double* heading);

// The whole solve. `prior` seeds the heading (the tracker's prediction).
TriangulationResult Triangulate(const std::vector<BearingObservation>& obs, const Pose2& prior,
                                const TriangulationOptions& options = TriangulationOptions());

}  // namespace pano

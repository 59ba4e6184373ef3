// A real rig's frames as the aligned rig of the same mirror would see them.
//
// The trackers, the PH transform and the E(D,Z) table describe an aligned
// rig: mirror axis vertical and through the pinhole, a camera looking along
// it. A real rig (sensor/general_model.h: decentred mirror, tilted camera,
// lens distortion, tilted sensor) is handled by resampling each frame into
// the image of an equivalent aligned rig (the "view"), so that everything
// downstream stays exact and fast:
//   - the view's rig has the calibration's mirror and camera with every fault
//     zeroed, and stands upright with its mirror centred where the real
//     mirror's centre (a sphere's centre, a conic's centre of curvature at
//     its vertex) is: for a sphere this is the same mirror, so the real rig
//     differs from the view's only by a rotation of the pinhole about the
//     mirror's centre and the lens, which leaves each pixel's ray nearly the
//     same line;
//   - its pinhole therefore lies `pinhole_offset()` from the robot's (the
//     robot frame of general_model.h), a constant in the robot frame: poses
//     are converted between the two with ViewPose / RobotPose;
//   - each view pixel takes the real image's value where the real rig sees
//     the point its ray reaches at `exact_distance` from the axis. Points at
//     other distances land a little off (the rays are nearly, not exactly,
//     the same lines); residual_px() states how far, measured at
//     construction over 0.5x to 8x that distance.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

class AlignedView {
 public:
  // `rig`: a sensor with faults; `exact_distance`: the horizontal distance
  // (map units) at which the resampling is exact, best the typical distance
  // of the landmarks. `grid_step_px`: the exact mapping is computed every
  // that many pixels and interpolated between (the mapping is smooth).
  // The grid's rows on `num_threads` threads (0: every core); the mapping is
  // the same for every count. Throws pano::Error when the rig's parameters
  // are impossible or the distance is not positive.
  AlignedView(const Sensor& rig, double exact_distance, int grid_step_px = 2, int num_threads = 0);

  // The view's rig: `rig` with every fault zeroed.
  const Sensor& view_sensor() const { return view_; }
  // The view's pinhole in the robot frame (x, y, z).
  const Eigen::Vector3d& pinhole_offset() const { return offset_; }
  // Largest image distance (px) between where the real rig sees a point and
  // where the resampled view puts it, over sampled directions and 0.5x to 8x
  // the exact distance.
  double residual_px() const { return residual_px_; }

  // The view of a real frame (CV_8UC1 of the rig's size); pixels whose ray
  // the real rig does not see hold arbitrary values.
  void Resample(const cv::Mat& real, cv::Mat* view) const;

  // A robot pose as the pose of the view's pinhole, and back.
  Pose2 ViewPose(const Pose2& robot) const;
  Pose2 RobotPose(const Pose2& view) const;

  // Real-image pixel that view pixel (u, v) samples; false outside.
  bool RealPixel(double u, double v, double* ur, double* vr) const;

 private:
  bool ExactRealPixel(double u, double v, double* ur, double* vr) const;
  double MeasureResidual() const;
  // Image offsets between where the rig sees sample points and where the
  // exact view mapping puts them, for a view pinhole at `offset`; false
  // when no sample point is seen.
  bool RayMismatch(const Eigen::Vector3d& offset, std::vector<double>* residuals) const;
  void FitOffset();

  Sensor rig_, view_;
  Eigen::Vector3d offset_;
  double exact_distance_;
  cv::Mat map_x_, map_y_;  // CV_32FC1: the real pixel of each view pixel (-1 outside)
  cv::Mat fixed_xy_, fixed_fraction_;  // the same for cv::remap (CV_16SC2, CV_16UC1)
  double residual_px_ = 0.0;
};

// The distance the view is best made exact at for a map: the RMS distance
// of its rectangles' end points from their centroid.
double TypicalLandmarkDistance(const struct Map& map);

}  // namespace pano

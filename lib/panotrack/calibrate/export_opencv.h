// A calibration in OpenCV's terms, for users whose other tools speak them.
//
// The camera that looks at the mirror is an ordinary pinhole: its camera
// matrix and radial distortion are exactly OpenCV's (the sensor frame is its
// camera frame, z along the axis up to the mirror). The whole sensor has no
// single viewpoint, so OpenCV's omnidirectional model (Mei's unified model,
// cv::omnidir) can only approximate it: it is fitted here to the exact
// projection of points at one horizontal distance from the axis, and its
// reprojection RMS over the mirror's annulus says how good it is.
#pragma once

#include <Eigen/Core>
#include <string>

#include "panotrack/sensor/calibration.h"

namespace pano {

struct OmnidirApproximationOptions {
  // Horizontal distance from the axis of the points the fit uses (the
  // calibration's units); 0: 1000 mirror distances (the far field).
  double distance = 0.0;
  int samples_radial = 40;     // sample rings over the mirror's annulus
  int samples_azimuthal = 72;  // samples per ring
  void Check() const;
};

// Mei's model as cv::omnidir uses it: K (with its skew s), xi, D = (k1, k2, p1, p2),
// for points in the omnidir frame X_omnidir = omnidir_from_sensor * X_sensor
// (the image centre sees straight down, so that frame's z points down).
struct OmnidirApproximation {
  double fx = 0, fy = 0, cx = 0, cy = 0, xi = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0;
  double s = 0;  // K(0, 1)
  Eigen::Matrix3d omnidir_from_sensor = Eigen::Matrix3d::Identity();
  double distance = 0.0;  // the distance the fit used
  double rms_px = 0.0;    // over the samples
  double max_px = 0.0;
  int samples = 0;
};

// Projects a sensor-frame point with the approximation (false: behind its
// viewpoint).
bool ProjectOmnidir(const OmnidirApproximation& a, const Eigen::Vector3d& point_sensor, Eigen::Vector2d* pixel);

// Fits the approximation by least squares (Ceres); throws pano::Error when
// the sensor shows too little of the mirror to fit it.
OmnidirApproximation FitOmnidirApproximation(const Sensor& sensor, const OmnidirApproximationOptions& options);

// Writes an OpenCV FileStorage file (.yml, .yaml, .xml or .json by the name):
// image size, camera_matrix and distortion_coefficients of the pinhole, the
// mirror, and the omnidir approximation (omnidir_K, omnidir_xi, omnidir_D,
// omnidir_from_sensor, its distance and RMS). Atomic; throws pano::Error.
void WriteOpenCvCalibration(const std::string& path, const Calibration& calib,
                            const OmnidirApproximation& omnidir);

}  // namespace pano

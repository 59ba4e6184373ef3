// Double-precision sensor: the templated model of catadioptric.h plus the
// image size, the model's name and Eigen-typed conveniences.
#pragma once

#include <Eigen/Core>
#include <string>

#include "panotrack/core/angles.h"
#include "panotrack/sensor/catadioptric.h"
#include "panotrack/sensor/general_model.h"

namespace pano {

// kAsphere: the conic with its even-asphere terms (SensorParams::asphere_a4,
// asphere_a6), which only it may have non-zero. kUnified: Mei's unified
// central model (SensorParams::unified and xi; catadioptric.h), no mirror
// geometry.
enum class MirrorModel { kSphere, kConic, kAsphere, kUnified };
const char* MirrorModelName(MirrorModel m);

struct Sensor {
  MirrorModel model = MirrorModel::kSphere;
  int image_width = 0;
  int image_height = 0;
  SensorParams<double> params;
  // Faults of a real rig (general_model.h); all zero for an aligned one.
  // project and backproject account for them; the meridian helpers
  // (image_radius, inverse_image_radius, limb_radius, polar forms) describe
  // the aligned model only.
  RigFaults<double> faults;

  bool aligned() const { return faults.IsZero(); }
  GeneralSensorParams<double> general() const { return {params, faults}; }

  // The sphere's own parameters (README, "Files and conventions"), valid for kSphere.
  double mirror_radius() const { return params.curvature_radius; }
  double mirror_distance() const { return params.vertex_distance + params.curvature_radius; }

  // Throws pano::Error naming `what` when the parameters are impossible
  // (non-positive focal length, mirror reaching the pinhole, NaN...).
  void Check(const std::string& what) const;

  bool project(const Eigen::Vector3d& point_sensor, Eigen::Vector2d* pixel) const;
  bool backproject(const Eigen::Vector2d& pixel, Eigen::Vector3d* origin,
                   Eigen::Vector3d* direction) const;
  bool image_radius(double horizontal_distance, double height, double* radius) const;
  bool inverse_image_radius(double radius, double height, double* horizontal_distance) const;
  // Image radius (pixels) of the mirror's visible edge.
  double limb_radius() const { return LimbRadiusPx(params); }
  // Image azimuth of a sensor-frame bearing, and back.
  double image_azimuth(double bearing) const { return WrapAngle(bearing + params.azimuth_offset); }
  double bearing_of_azimuth(double azimuth) const { return WrapAngle(azimuth - params.azimuth_offset); }
  // Polar image coordinates (radius with aspect removed, azimuth) of a pixel and back.
  void to_polar(double u, double v, double* radius, double* azimuth) const;
  Eigen::Vector2d from_polar(double radius, double azimuth) const;
  bool inside_image(const Eigen::Vector2d& pixel, double margin = 0.0) const;
};

// The same rig seen in images resized by `scale` (0 < scale, as cv::resize
// does: width and height rounded, pixel centres mapped through the scale of
// each axis): focal length, principal point, aspect and image size follow;
// the mirror and the faults do not change. Throws pano::Error for a scale
// that leaves no pixel.
Sensor ScaledSensor(const Sensor& sensor, double scale);

// The sphere model from its named parameters.
Sensor MakeSphereSensor(int width, int height, double focal_px, double cx, double cy,
                        double aspect, double mirror_radius, double mirror_distance,
                        double azimuth_offset = 0.0);

}  // namespace pano

// Unwarping a catadioptric image into a cylindrical panorama or a
// perspective view (like OpenCV's omnidir::initUndistortRectifyMap with
// RECTIFY_CYLINDRICAL / RECTIFY_PERSPECTIVE), with the remap tables as the API.
//
// The sensor has no single viewpoint: the reflected rays do not meet in one
// point, so a view pixel cannot stand for a direction alone. Each view pixel
// stands for one 3-D point, and the tables hold that point's exact projection
// (Sensor::project):
//   - panorama: column = azimuth (the sensor-frame bearing, counter-clockwise
//     from sensor +x, as everywhere in the toolkit: a point at bearing a is at
//     column a * width / 360 deg), row = elevation, linear from
//     max_elevation (row 0) to min_elevation (row height - 1), of points on a
//     vertical cylinder of radius `distance` around the axis, seen from the
//     eye (0, 0, eye_height);
//   - perspective: a virtual pinhole at the eye looking along yaw (bearing)
//     and pitch (elevation), horizontal field of view fov, seeing points on
//     the plane at depth `distance` along its optical axis.
// Whatever lies on that cylinder (plane) appears exactly where the ideal view
// puts it; nearer or farther things are shifted by the mirror's parallax,
// vertically only (every view pixel keeps its azimuth: vertical edges stay
// exactly vertical in the panorama and straight in the perspective view).
// distance 0 means infinitely far: the asymptotic directions, where the eye's
// position no longer matters.
//
// The eye defaults to the point where the reflected rays of the horizon,
// extended backwards, cross the axis (for a hyperbolic single-viewpoint mirror
// that is its focus, and every view is then exact at any distance).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <limits>
#include <memory>
#include <mutex>
#include <string>

#include "panotrack/sensor/sensor.h"

namespace pano {

enum class UnwarpKind { kPanorama, kPerspective };
const char* UnwarpKindName(UnwarpKind kind);

struct UnwarpOptions {
  UnwarpKind kind = UnwarpKind::kPanorama;
  // View size in pixels; 0 picks a default: the panorama is 2 pi times the
  // mirror's outer image radius wide and as high as makes its pixels square
  // in angle; the perspective view is 640 x 480.
  int width = 0;
  int height = 0;
  // Radius of the panorama's cylinder, depth of the perspective view's plane
  // (the calibration's units); 0: infinitely far (directions).
  double distance = 0.0;
  // Height of the eye above the pinhole (sensor frame z); NaN: where the
  // horizon's reflected rays cross the axis.
  double eye_height = std::numeric_limits<double>::quiet_NaN();
  // Panorama: elevation of row 0 and of the last row (degrees, within
  // (-90, 90)); NaN: those of the reflected rays at 98 % and 40 % of the
  // mirror's outer image radius (the rim compresses without limit; the centre
  // shows the camera and the floor under it).
  double min_elevation_deg = std::numeric_limits<double>::quiet_NaN();
  double max_elevation_deg = std::numeric_limits<double>::quiet_NaN();
  // Panorama: columns increase clockwise (as seen from above), so that the
  // view reads as from inside the cylinder (not mirror-reversed); column c is
  // then at bearing -c * 360 deg / width.
  bool clockwise = false;
  // Perspective: bearing and elevation of the optical axis, horizontal field
  // of view (degrees).
  double yaw_deg = 0.0;
  double pitch_deg = 0.0;
  double fov_deg = 60.0;
  // cv::remap's interpolation (INTER_NEAREST, _LINEAR, _CUBIC, _LANCZOS4) and
  // the value of view pixels whose point the mirror does not show.
  int interpolation = cv::INTER_LINEAR;
  cv::Scalar border_value = cv::Scalar::all(0);
  int threads = 0;  // 0: OpenMP's default

  // Throws pano::Error naming the field and what was expected.
  void Check() const;
};

// The view with every default resolved against a sensor: the geometry of its
// pixels, and the remap tables.
class UnwarpView {
 public:
  UnwarpView(const Sensor& sensor, const UnwarpOptions& options);

  UnwarpKind kind() const { return options_.kind; }
  int width() const { return width_; }
  int height() const { return height_; }
  // Infinity for an infinitely far view.
  double distance() const { return distance_; }
  double eye_height() const { return eye_height_; }
  // Panorama rows (radians).
  double min_elevation() const { return min_elevation_; }
  double max_elevation() const { return max_elevation_; }
  // Perspective: focal length and principal point of the virtual pinhole (px).
  double focal_px() const { return focal_px_; }
  const UnwarpOptions& options() const { return options_; }
  const Sensor& sensor() const { return sensor_; }

  // The sensor-frame point that view pixel (col, row) stands for. For an
  // infinitely far view: a point so far along the direction (10^6 times the
  // mirror's size) that its parallax is below 10^-4 px.
  Eigen::Vector3d PointOfPixel(double col, double row) const;
  // Where the ideal view shows a sensor-frame point (exact for points on the
  // view's cylinder or plane). False when it has none: a point on the axis,
  // or behind the perspective camera. Panorama columns are in [0, width).
  bool PixelOfPoint(const Eigen::Vector3d& point_sensor, Eigen::Vector2d* pixel) const;

  // The remap tables (CV_32FC1, height x width): map_x/map_y at a view pixel
  // is the raw-image pixel of PointOfPixel, or -1000 where the mirror does not
  // show it. Parallel over rows.
  void InitMaps(cv::Mat* map_x, cv::Mat* map_y) const;
  // Remaps an image of the sensor's size (any depth and channel count that
  // cv::remap takes) with the tables, built once on first use (thread-safe;
  // copies of the view share them).
  cv::Mat Unwarp(const cv::Mat& image) const;

 private:
  void InitPanoramaMaps(cv::Mat* map_x, cv::Mat* map_y) const;
  void InitPerspectiveMaps(cv::Mat* map_x, cv::Mat* map_y) const;
  Sensor sensor_;
  UnwarpOptions options_;
  int width_ = 0, height_ = 0;
  double distance_ = 0.0;
  double far_ = 0.0;  // the stand-in for infinity
  double eye_height_ = 0.0;
  double min_elevation_ = 0.0, max_elevation_ = 0.0;
  double focal_px_ = 0.0;
  Eigen::Vector3d forward_{1, 0, 0}, right_{0, -1, 0}, down_{0, 0, -1};
  struct Tables {
    std::once_flag built;
    cv::Mat map_x, map_y;
  };
  std::shared_ptr<Tables> tables_ = std::make_shared<Tables>();
};

// Value of map_x/map_y where the mirror does not show the view pixel's point.
constexpr float kUnwarpOutside = -1000.0f;

// The remap tables of `options` against `sensor` (see UnwarpView::InitMaps).
void InitUnwarpMaps(const Sensor& sensor, const UnwarpOptions& options, cv::Mat* map_x, cv::Mat* map_y);
// `image` (the sensor's size) unwarped.
cv::Mat UnwarpImage(const cv::Mat& image, const Sensor& sensor, const UnwarpOptions& options);

// Elevation (radians) of the reflected ray of the pixels at image radius
// `radius_px` (aspect removed); false off the mirror.
bool RayElevationAtRadius(const Sensor& sensor, double radius_px, double* elevation);
// Height above the pinhole where the horizon's reflected rays, extended
// backwards, cross the axis (the middle elevation's rays where the mirror does
// not show the horizon).
double HorizonEyeHeight(const Sensor& sensor);
// Image radius of the outermost full ring the view can use: the mirror's limb
// (or rim), or the farthest image corner from the centre when that is nearer.
double OuterImageRadius(const Sensor& sensor);

}  // namespace pano

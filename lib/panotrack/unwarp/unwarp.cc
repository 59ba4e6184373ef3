#include "panotrack/unwarp/unwarp.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <vector>

#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"

namespace pano {

namespace {

constexpr double kDeg = M_PI / 180.0;
// Largest view side and size (a 2^28-pixel view needs 2 GiB of tables).
constexpr int kMaxViewSide = 65536;
constexpr long long kMaxViewPixels = 1LL << 28;
// The panorama's default rows: the reflected rays at these fractions of the
// outer image radius.
constexpr double kTopRadiusFraction = 0.98;
constexpr double kBottomRadiusFraction = 0.40;
constexpr int kDefaultPerspectiveWidth = 640;
constexpr int kDefaultPerspectiveHeight = 480;

std::string Num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

// Normalised camera-ray radius m of an image radius (px), or false.
bool NormalizedRadius(const Sensor& sensor, double radius_px, double* m) {
  return UndistortRadius(sensor.params, radius_px / sensor.params.focal_px, m) && *m >= 0.0 &&
         *m < MaxNormalizedRadius(sensor.params);
}

// Elevation of the reflected ray of normalised radius m, and where that ray,
// extended backwards, crosses the axis.
bool RayOfNormalizedRadius(const Sensor& sensor, double m, double* elevation, double* axis_height) {
  double ps, pz, ds, dz;
  if (!ReflectMeridian(sensor.params, m, &ps, &pz, &ds, &dz)) return false;
  *elevation = std::atan2(dz, ds);
  if (axis_height) *axis_height = ds > 1e-12 ? pz - ps * dz / ds : pz;
  return true;
}

// Normalised radius whose reflected ray has `elevation`, by bisection on
// [0, m_hi] (the elevation grows outwards on a convex mirror).
double NormalizedRadiusOfElevation(const Sensor& sensor, double elevation, double m_hi) {
  double lo = 0.0, hi = m_hi;
  for (int i = 0; i < 200 && hi - lo > 1e-16; ++i) {
    const double mid = 0.5 * (lo + hi);
    double e;
    if (!RayOfNormalizedRadius(sensor, mid, &e, nullptr) || e > elevation)
      hi = mid;
    else
      lo = mid;
  }
  return 0.5 * (lo + hi);
}

// The scale of the sensor (map units): the mirror's height and size.
double SensorScale(const Sensor& sensor) {
  return std::abs(sensor.params.vertex_distance) + std::abs(sensor.params.curvature_radius) + 1e-9;
}

}  // namespace

const char* UnwarpKindName(UnwarpKind kind) {
  return kind == UnwarpKind::kPanorama ? "panorama" : "perspective";
}

void UnwarpOptions::Check() const {
  auto size_ok = [](int n) { return n == 0 || (n >= 2 && n <= kMaxViewSide); };
  if (!size_ok(width)) throw Error("unwarp width: expected 2.." + std::to_string(kMaxViewSide) + " (0: default), got " + std::to_string(width));
  if (!size_ok(height)) throw Error("unwarp height: expected 2.." + std::to_string(kMaxViewSide) + " (0: default), got " + std::to_string(height));
  if (static_cast<long long>(width) * height > kMaxViewPixels)
    throw Error("unwarp size: " + std::to_string(width) + "x" + std::to_string(height) + " is over " +
                std::to_string(kMaxViewPixels) + " pixels");
  if (!std::isfinite(distance) || distance < 0.0)
    throw Error("unwarp distance: expected a finite distance >= 0 (0: infinitely far), got " + Num(distance));
  if (!std::isnan(eye_height) && !std::isfinite(eye_height))
    throw Error("unwarp eye_height: expected a finite height (NaN: automatic), got " + Num(eye_height));
  for (const auto& [name, value] : {std::pair<const char*, double>{"min_elevation_deg", min_elevation_deg},
                                    {"max_elevation_deg", max_elevation_deg}})
    if (!std::isnan(value) && !(value > -90.0 && value < 90.0))
      throw Error(std::string("unwarp ") + name + ": expected -90 < elevation < 90 degrees, got " + Num(value));
  if (!std::isnan(min_elevation_deg) && !std::isnan(max_elevation_deg) && !(min_elevation_deg < max_elevation_deg))
    throw Error("unwarp elevation: expected min_elevation_deg < max_elevation_deg, got " + Num(min_elevation_deg) +
                " and " + Num(max_elevation_deg));
  if (!std::isfinite(yaw_deg)) throw Error("unwarp yaw_deg: expected a finite angle, got " + Num(yaw_deg));
  if (!(pitch_deg >= -90.0 && pitch_deg <= 90.0))
    throw Error("unwarp pitch_deg: expected -90..90 degrees, got " + Num(pitch_deg));
  if (!(fov_deg > 0.0 && fov_deg <= 170.0))
    throw Error("unwarp fov_deg: expected 0 < fov <= 170 degrees, got " + Num(fov_deg));
  if (interpolation != cv::INTER_NEAREST && interpolation != cv::INTER_LINEAR && interpolation != cv::INTER_CUBIC &&
      interpolation != cv::INTER_LANCZOS4)
    throw Error("unwarp interpolation: expected cv::INTER_NEAREST, _LINEAR, _CUBIC or _LANCZOS4, got " +
                std::to_string(interpolation));
  if (threads < 0) throw Error("unwarp threads: expected >= 0, got " + std::to_string(threads));
}

bool RayElevationAtRadius(const Sensor& sensor, double radius_px, double* elevation) {
  double m;
  if (!(radius_px >= 0.0) || !NormalizedRadius(sensor, radius_px, &m)) return false;
  return RayOfNormalizedRadius(sensor, m, elevation, nullptr);
}

double OuterImageRadius(const Sensor& sensor) {
  double corner = 0.0;
  for (double u : {-0.5, sensor.image_width - 0.5})
    for (double v : {-0.5, sensor.image_height - 0.5}) {
      double r, a;
      sensor.to_polar(u, v, &r, &a);
      corner = std::max(corner, r);
    }
  return std::min(sensor.limb_radius(), corner);
}

double HorizonEyeHeight(const Sensor& sensor) {
  double m_hi;
  if (!NormalizedRadius(sensor, OuterImageRadius(sensor) * (1.0 - 1e-9), &m_hi))
    throw Error("unwarp: the sensor's outer image radius is not on the mirror");
  double e_lo, e_hi;
  if (!RayOfNormalizedRadius(sensor, 0.0, &e_lo, nullptr) || !RayOfNormalizedRadius(sensor, m_hi, &e_hi, nullptr))
    throw Error("unwarp: the sensor's mirror reflects no ray");
  const double target = e_lo <= 0.0 && 0.0 <= e_hi ? 0.0 : 0.5 * (e_lo + e_hi);
  double e, axis;
  if (!RayOfNormalizedRadius(sensor, NormalizedRadiusOfElevation(sensor, target, m_hi), &e, &axis))
    throw Error("unwarp: no reflected ray at the horizon");
  return axis;
}

UnwarpView::UnwarpView(const Sensor& sensor, const UnwarpOptions& options) : sensor_(sensor), options_(options) {
  options_.Check();
  sensor_.Check("unwarp sensor");
  distance_ = options_.distance > 0.0 ? options_.distance : std::numeric_limits<double>::infinity();
  far_ = 1e6 * SensorScale(sensor_);
  eye_height_ = std::isnan(options_.eye_height) ? HorizonEyeHeight(sensor_) : options_.eye_height;
  const double outer = OuterImageRadius(sensor_);
  if (options_.kind == UnwarpKind::kPanorama) {
    width_ = options_.width > 0 ? options_.width : std::max(2, static_cast<int>(std::lround(2.0 * M_PI * outer)));
    auto default_elevation = [&](double fraction) {
      double e;
      if (!RayElevationAtRadius(sensor_, fraction * outer, &e))
        throw Error("unwarp: no reflected ray at " + Num(fraction * outer) + " px from the image centre");
      return std::clamp(e, -89.0 * kDeg, 89.0 * kDeg);
    };
    max_elevation_ = std::isnan(options_.max_elevation_deg) ? default_elevation(kTopRadiusFraction)
                                                            : options_.max_elevation_deg * kDeg;
    min_elevation_ = std::isnan(options_.min_elevation_deg) ? default_elevation(kBottomRadiusFraction)
                                                            : options_.min_elevation_deg * kDeg;
    if (!(min_elevation_ < max_elevation_))
      throw Error("unwarp elevation: the range " + Num(min_elevation_ / kDeg) + ".." + Num(max_elevation_ / kDeg) +
                  " degrees is empty (one end given, the other from the mirror)");
    // Square pixels in angle.
    height_ = options_.height > 0
                  ? options_.height
                  : std::max(2, static_cast<int>(std::lround((max_elevation_ - min_elevation_) * width_ / (2 * M_PI))) + 1);
  } else {
    width_ = options_.width > 0 ? options_.width : kDefaultPerspectiveWidth;
    height_ = options_.height > 0 ? options_.height
                                  : std::max(2, static_cast<int>(std::lround(
                                                    width_ * double(kDefaultPerspectiveHeight) / kDefaultPerspectiveWidth)));
    focal_px_ = 0.5 * width_ / std::tan(0.5 * options_.fov_deg * kDeg);
    const double yaw = options_.yaw_deg * kDeg, pitch = options_.pitch_deg * kDeg;
    forward_ = Eigen::Vector3d(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch), std::sin(pitch));
    right_ = Eigen::Vector3d(std::sin(yaw), -std::cos(yaw), 0.0);  // bearing yaw - 90 deg
    down_ = forward_.cross(right_);
  }
  if (static_cast<long long>(width_) * height_ > kMaxViewPixels)
    throw Error("unwarp size: " + std::to_string(width_) + "x" + std::to_string(height_) + " is over " +
                std::to_string(kMaxViewPixels) + " pixels");
}

Eigen::Vector3d UnwarpView::PointOfPixel(double col, double row) const {
  if (options_.kind == UnwarpKind::kPanorama) {
    const double sign = options_.clockwise ? -1.0 : 1.0;
    const double bearing = sign * col * (2.0 * M_PI / width_);
    const double elevation = max_elevation_ - row * (max_elevation_ - min_elevation_) / (height_ - 1);
    const double cb = std::cos(bearing), sb = std::sin(bearing);
    if (std::isinf(distance_)) {
      const double ce = std::cos(elevation), se = std::sin(elevation);
      return {far_ * ce * cb, far_ * ce * sb, eye_height_ + far_ * se};
    }
    return {distance_ * cb, distance_ * sb, eye_height_ + distance_ * std::tan(elevation)};
  }
  const double cx = 0.5 * (width_ - 1), cy = 0.5 * (height_ - 1);
  const Eigen::Vector3d ray = focal_px_ * forward_ + (col - cx) * right_ + (row - cy) * down_;
  const Eigen::Vector3d eye(0.0, 0.0, eye_height_);
  if (std::isinf(distance_)) return eye + far_ * ray.normalized();
  return eye + (distance_ / focal_px_) * ray;  // depth `distance` along the optical axis
}

bool UnwarpView::PixelOfPoint(const Eigen::Vector3d& p, Eigen::Vector2d* pixel) const {
  if (!p.allFinite()) return false;
  const Eigen::Vector3d q = p - Eigen::Vector3d(0.0, 0.0, eye_height_);
  if (options_.kind == UnwarpKind::kPanorama) {
    const double horizontal = std::hypot(p.x(), p.y());
    if (!(horizontal > 0.0)) return false;
    double bearing = std::atan2(p.y(), p.x());
    if (options_.clockwise) bearing = -bearing;
    double col = bearing * width_ / (2.0 * M_PI);
    if (col < 0.0) col += width_;
    if (col >= width_) col -= width_;
    const double elevation = std::atan2(q.z(), horizontal);
    const double row = (max_elevation_ - elevation) * (height_ - 1) / (max_elevation_ - min_elevation_);
    *pixel = {col, row};
    return true;
  }
  const double depth = q.dot(forward_);
  if (!(depth > 0.0)) return false;
  *pixel = {0.5 * (width_ - 1) + focal_px_ * q.dot(right_) / depth,
            0.5 * (height_ - 1) + focal_px_ * q.dot(down_) / depth};
  return true;
}

void UnwarpView::InitMaps(cv::Mat* map_x, cv::Mat* map_y) const {
  if (!map_x || !map_y) throw Error("unwarp: null map");
  map_x->create(height_, width_, CV_32FC1);
  map_y->create(height_, width_, CV_32FC1);
  if (options_.kind == UnwarpKind::kPanorama)
    InitPanoramaMaps(map_x, map_y);
  else
    InitPerspectiveMaps(map_x, map_y);
}

// A panorama row is one ring of the raw image: its points share their
// horizontal distance and height, hence their image radius (one reflection
// solve per row), and differ in azimuth only.
void UnwarpView::InitPanoramaMaps(cv::Mat* map_x, cv::Mat* map_y) const {
  const SensorParams<double>& sp = sensor_.params;
  std::vector<double> cos_az(width_), sin_az(width_);
  for (int c = 0; c < width_; ++c) {
    const Eigen::Vector3d p = PointOfPixel(c, 0.0);
    const double image_azimuth = std::atan2(p.y(), p.x()) + sp.azimuth_offset;
    cos_az[c] = std::cos(image_azimuth);
    sin_az[c] = std::sin(image_azimuth);
  }
  ParallelFor(
      height_,
      [&](int r) {
        float* mx = map_x->ptr<float>(r);
        float* my = map_y->ptr<float>(r);
        const Eigen::Vector3d p = PointOfPixel(0.0, r);
        double radius;
        if (!sensor_.image_radius(std::hypot(p.x(), p.y()), p.z(), &radius)) {
          std::fill(mx, mx + width_, kUnwarpOutside);
          std::fill(my, my + width_, kUnwarpOutside);
          return;
        }
        for (int c = 0; c < width_; ++c) {
          mx[c] = static_cast<float>(sp.cx + radius * cos_az[c]);
          my[c] = static_cast<float>(sp.cy + sp.aspect * radius * sin_az[c]);
        }
      },
      true, options_.threads);
}

void UnwarpView::InitPerspectiveMaps(cv::Mat* map_x, cv::Mat* map_y) const {
  ParallelFor(
      height_,
      [&](int r) {
        float* mx = map_x->ptr<float>(r);
        float* my = map_y->ptr<float>(r);
        for (int c = 0; c < width_; ++c) {
          Eigen::Vector2d px;
          if (sensor_.project(PointOfPixel(c, r), &px)) {
            mx[c] = static_cast<float>(px.x());
            my[c] = static_cast<float>(px.y());
          } else {
            mx[c] = my[c] = kUnwarpOutside;
          }
        }
      },
      true, options_.threads);
}

cv::Mat UnwarpView::Unwarp(const cv::Mat& image) const {
  if (image.empty()) throw Error("unwarp: empty image");
  if (image.cols != sensor_.image_width || image.rows != sensor_.image_height)
    throw Error("unwarp: the image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                ", the calibration's " + std::to_string(sensor_.image_width) + "x" +
                std::to_string(sensor_.image_height));
  Tables& t = *tables_;
  std::call_once(t.built, [&] { InitMaps(&t.map_x, &t.map_y); });
  cv::Mat out;
  try {
    cv::remap(image, out, t.map_x, t.map_y, options_.interpolation, cv::BORDER_CONSTANT, options_.border_value);
  } catch (const cv::Exception& e) {
    throw Error(std::string("unwarp: cannot remap the image: ") + e.what());
  }
  return out;
}

void InitUnwarpMaps(const Sensor& sensor, const UnwarpOptions& options, cv::Mat* map_x, cv::Mat* map_y) {
  UnwarpView(sensor, options).InitMaps(map_x, map_y);
}

cv::Mat UnwarpImage(const cv::Mat& image, const Sensor& sensor, const UnwarpOptions& options) {
  return UnwarpView(sensor, options).Unwarp(image);
}

}  // namespace pano

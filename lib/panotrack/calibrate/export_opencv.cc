#include "panotrack/calibrate/export_opencv.h"

#include <ceres/ceres.h>

#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <vector>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"

namespace pano {

namespace {

// Mei's unified projection with OpenCV's distortion (cv::omnidir::projectPoints).
// params: fx, fy, cx, cy, xi, k1, k2, p1, p2, s (K's skew).
template <typename T>
bool ProjectMei(const T* params, const T* X, T* u, T* v) {
  const T norm = sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2]);
  const T denom = X[2] / norm + params[4];
  if (!(denom > T(1e-9))) return false;
  const T x = X[0] / norm / denom, y = X[1] / norm / denom;
  const T r2 = x * x + y * y, r4 = r2 * r2;
  const T radial = T(1) + params[5] * r2 + params[6] * r4;
  const T xd = x * radial + T(2) * params[7] * x * y + params[8] * (r2 + T(2) * x * x);
  const T yd = y * radial + params[7] * (r2 + T(2) * y * y) + T(2) * params[8] * x * y;
  *u = params[0] * xd + params[9] * yd + params[2];
  *v = params[1] * yd + params[3];
  return true;
}

struct MeiResidual {
  Eigen::Vector3d point;  // omnidir frame
  Eigen::Vector2d pixel;
  template <typename T>
  bool operator()(const T* params, T* residual) const {
    const T X[3] = {T(point.x()), T(point.y()), T(point.z())};
    T u, v;
    if (!ProjectMei(params, X, &u, &v)) return false;
    residual[0] = u - T(pixel.x());
    residual[1] = v - T(pixel.y());
    return true;
  }
};

// The frame whose z points down the axis (the image centre's direction),
// turned by the azimuth offset so that image azimuths match.
Eigen::Matrix3d OmnidirFromSensor(const Sensor& s) {
  const double o = s.params.azimuth_offset;
  Eigen::Matrix3d rz;
  rz << std::cos(o), -std::sin(o), 0, std::sin(o), std::cos(o), 0, 0, 0, 1;
  return Eigen::Vector3d(1, 1, -1).asDiagonal() * rz;
}

struct Sample {
  Eigen::Vector3d point_sensor;
  Eigen::Vector2d pixel;
};

// Pixels over the mirror's annulus and the points at horizontal distance D
// that they see (the reflected ray met with the cylinder of radius D).
std::vector<Sample> SampleAnnulus(const Sensor& s, double distance, const OmnidirApproximationOptions& o) {
  std::vector<Sample> out;
  const double limb = s.limb_radius();
  const double outer = std::isfinite(limb) ? limb : 0.5 * std::min(s.image_width, s.image_height);
  for (int i = 1; i <= o.samples_radial; ++i) {
    const double radius = outer * (i - 0.5) / o.samples_radial;
    for (int j = 0; j < o.samples_azimuthal; ++j) {
      const double azimuth = 2.0 * M_PI * j / o.samples_azimuthal;
      const Eigen::Vector2d pixel = s.from_polar(radius, azimuth);
      Eigen::Vector3d origin, dir;
      if (!s.backproject(pixel, &origin, &dir)) continue;
      // |origin.xy + t dir.xy| = D, the root with t > 0.
      const double a = dir.head<2>().squaredNorm(), b = 2.0 * origin.head<2>().dot(dir.head<2>()),
                   c = origin.head<2>().squaredNorm() - distance * distance;
      if (!(a > 1e-12)) continue;
      const double disc = b * b - 4 * a * c;
      if (!(disc >= 0)) continue;
      const double t = (-b + std::sqrt(disc)) / (2 * a);
      if (!(t > 0)) continue;
      Sample smp{origin + t * dir, Eigen::Vector2d()};
      if (!s.project(smp.point_sensor, &smp.pixel)) continue;  // the exact model's own pixel
      out.push_back(smp);
    }
  }
  return out;
}

}  // namespace

void OmnidirApproximationOptions::Check() const {
  if (!(distance >= 0.0) || !std::isfinite(distance))
    throw Error("OmnidirApproximationOptions.distance: expected >= 0, got " + std::to_string(distance));
  if (samples_radial < 4 || samples_azimuthal < 8)
    throw Error("OmnidirApproximationOptions.samples_radial/samples_azimuthal: at least 4 and 8");
}

bool ProjectOmnidir(const OmnidirApproximation& a, const Eigen::Vector3d& point_sensor, Eigen::Vector2d* pixel) {
  const double params[10] = {a.fx, a.fy, a.cx, a.cy, a.xi, a.k1, a.k2, a.p1, a.p2, a.s};
  const Eigen::Vector3d X = a.omnidir_from_sensor * point_sensor;
  return ProjectMei(params, X.data(), &pixel->x(), &pixel->y());
}

OmnidirApproximation FitOmnidirApproximation(const Sensor& s, const OmnidirApproximationOptions& options) {
  options.Check();
  OmnidirApproximation a;
  a.distance = options.distance > 0 ? options.distance : 1000.0 * s.mirror_distance();
  a.omnidir_from_sensor = OmnidirFromSensor(s);
  const std::vector<Sample> samples = SampleAnnulus(s, a.distance, options);
  if (samples.size() < 20)
    throw Error("the omnidir approximation: only " + std::to_string(samples.size()) +
                " pixels of the mirror see the distance " + std::to_string(a.distance));
  // Start: xi = 1 (a parabolic mirror's value), the focal length from the
  // horizon's image radius (there x = 1 / xi).
  double horizon_radius = 0.0;
  if (!s.image_radius(a.distance, 0.0, &horizon_radius) || !(horizon_radius > 0))
    horizon_radius = 0.5 * s.limb_radius();
  double params[10] = {horizon_radius, horizon_radius * s.params.aspect, s.params.cx, s.params.cy, 1.0, 0, 0, 0, 0,
                       s.faults.skew};
  ceres::Problem problem;
  for (const Sample& smp : samples)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<MeiResidual, 2, 10>(
                                 new MeiResidual{a.omnidir_from_sensor * smp.point_sensor, smp.pixel}),
                             nullptr, params);
  ceres::Solver::Options so;
  so.max_num_iterations = 200;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  a.fx = params[0], a.fy = params[1], a.cx = params[2], a.cy = params[3], a.xi = params[4];
  a.k1 = params[5], a.k2 = params[6], a.p1 = params[7], a.p2 = params[8], a.s = params[9];
  double sum2 = 0;
  for (const Sample& smp : samples) {
    Eigen::Vector2d px;
    const double e = ProjectOmnidir(a, smp.point_sensor, &px) ? (px - smp.pixel).norm() : HUGE_VAL;
    sum2 += e * e;
    a.max_px = std::max(a.max_px, e);
  }
  a.samples = static_cast<int>(samples.size());
  a.rms_px = std::sqrt(sum2 / samples.size());
  if (!std::isfinite(a.rms_px)) throw Error("the omnidir approximation did not converge: " + summary.BriefReport());
  return a;
}

void WriteOpenCvCalibration(const std::string& path, const Calibration& calib, const OmnidirApproximation& om) {
  const Sensor& s = calib.sensor;
  const SensorParams<double>& p = s.params;
  std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size() : path.find_last_of('.'));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext != ".yml" && ext != ".yaml" && ext != ".xml" && ext != ".json")
    throw Error(path + ": expected a .yml, .yaml, .xml or .json name (OpenCV FileStorage picks its format by it)");
  cv::FileStorage fs(ext, cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  fs.writeComment("panotrack calibration for OpenCV. camera_matrix and distortion_coefficients: the pinhole "
                  "that views the mirror (camera frame = sensor frame, z up the axis). omnidir_*: Mei's "
                  "unified model (cv::omnidir) fitted to the sensor at omnidir_distance; points go in as "
                  "omnidir_from_sensor * X_sensor.");
  fs << "image_width" << s.image_width << "image_height" << s.image_height;
  fs << "units" << calib.units;
  fs << "camera_matrix"
     << (cv::Mat_<double>(3, 3) << p.focal_px, s.faults.skew, p.cx, 0, p.focal_px * p.aspect, p.cy, 0, 0, 1);
  fs << "distortion_coefficients" << (cv::Mat_<double>(1, 5) << p.k1, p.k2, 0, 0, 0);
  fs << "mirror_model" << MirrorModelName(s.model);
  fs << "curvature_radius" << p.curvature_radius << "conic_constant" << p.conic_constant
     << "vertex_distance" << p.vertex_distance << "azimuth_offset" << p.azimuth_offset;
  if (s.model == MirrorModel::kAsphere) fs << "asphere_a4" << p.asphere_a4 << "asphere_a6" << p.asphere_a6;
  if (s.model == MirrorModel::kUnified) fs << "xi" << p.xi;
  fs << "omnidir_K" << (cv::Mat_<double>(3, 3) << om.fx, om.s, om.cx, 0, om.fy, om.cy, 0, 0, 1);
  fs << "omnidir_xi" << om.xi;
  fs << "omnidir_D" << (cv::Mat_<double>(1, 4) << om.k1, om.k2, om.p1, om.p2);
  cv::Mat omnidir_from_sensor;
  cv::eigen2cv(om.omnidir_from_sensor, omnidir_from_sensor);
  fs << "omnidir_from_sensor" << omnidir_from_sensor;
  fs << "omnidir_distance" << om.distance << "omnidir_rms_px" << om.rms_px << "omnidir_max_px" << om.max_px;
  if (!calib.software.empty()) fs << "software" << calib.software;
  WriteFileAtomic(path, fs.releaseAndGetString());
}

}  // namespace pano

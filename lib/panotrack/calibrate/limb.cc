// The mirror's limb as a measurement (limb.h).
#include "panotrack/calibrate/limb.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>

#include "panotrack/calibrate/internal.h"
#include "panotrack/core/grey_sample.h"
#include "panotrack/core/parallel.h"

namespace pano {

using namespace calib_internal;

namespace {

// The sphere's centre in the mirror frame M (general_model.h): on the axis,
// off the pinhole by the decentre, one radius beyond the vertex.
template <typename T>
void SphereCentre(const SensorParams<T>& p, const RigFaults<T>& f, T* c) {
  c[0] = f.mirror_offset[0];
  c[1] = f.mirror_offset[1];
  c[2] = p.vertex_distance + p.curvature_radius;
}

bool IsSphere(const Sensor& s) { return s.model == MirrorModel::kSphere && s.params.conic_constant == 0.0; }

// Pixel of a camera-frame direction m given in M (general_model.h's projection after the reflection).
bool PixelOfMirrorFrameRay(const Sensor& s, const double* m, Eigen::Vector2d* px) {
  const SensorParams<double>& p = s.params;
  const RigFaults<double>& f = s.faults;
  double Rc[9], c[3];
  detail::TiltRotation(f.camera_tilt, Rc);
  detail::RotateTransposed(Rc, m, c);
  if (!(c[2] > 0.0)) return false;
  const double xn = c[0] / c[2], yn = c[1] / c[2];
  const double co = std::cos(p.azimuth_offset), so = std::sin(p.azimuth_offset);
  const double xi = xn * co - yn * so, yi = xn * so + yn * co;
  double xd, yd;
  detail::BrownDistort(p, f, xi, yi, &xd, &yd);
  double u, v;
  detail::PixelOfDistorted(p, f, xd, yd, &u, &v);
  *px = {u, v};
  return std::isfinite(px->x()) && std::isfinite(px->y());
}

// The ray at cone angle psi whose angle from the sphere's centre direction is
// `angle`, in M.
bool ConeRay(const Sensor& s, double psi, double angle, Eigen::Vector3d* m) {
  double c[3];
  SphereCentre(s.params, s.faults, c);
  const Eigen::Vector3d u = Eigen::Vector3d(c[0], c[1], c[2]).normalized();
  const Eigen::Vector3d e1 = (Eigen::Vector3d::UnitX() - u.x() * u).normalized();
  const Eigen::Vector3d e2 = u.cross(e1);
  *m = std::cos(angle) * u + std::sin(angle) * (std::cos(psi) * e1 + std::sin(psi) * e2);
  return true;
}

double LimbHalfAngle(const Sensor& s) {
  double c[3];
  SphereCentre(s.params, s.faults, c);
  const double d = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  return d > s.params.curvature_radius ? std::asin(s.params.curvature_radius / d) : NAN;
}

// Residual of one limb point: the angle of its camera ray from the sphere's
// centre direction minus the limb's half angle, scaled to pixels.
struct LimbCost {
  LimbCost(const Eigen::Vector2d& px, double scale) : px_(px), scale_(scale) {}
  template <typename T>
  bool operator()(const T* s, const T* fb, T* r) const {
    using std::atan2;
    using std::asin;
    using std::cos;
    using std::sin;
    using std::sqrt;
    const SensorParams<T> p = ParamsFromBlock(s);
    const RigFaults<T> f = FaultsFromBlock(fb);
    T xd, yd, xi, yi;
    detail::DistortedOfPixel(p, f, T(px_.x()), T(px_.y()), &xd, &yd);
    if (!detail::BrownUndistort(p, f, xd, yd, &xi, &yi)) return false;
    const T co = cos(p.azimuth_offset), so = sin(p.azimuth_offset);
    const T c[3] = {xi * co + yi * so, -xi * so + yi * co, T(1)};
    T Rc[9], m[3], C[3];
    detail::TiltRotation(f.camera_tilt, Rc);
    detail::rotate(Rc, c, m);
    SphereCentre(p, f, C);
    const T cr[3] = {m[1] * C[2] - m[2] * C[1], m[2] * C[0] - m[0] * C[2], m[0] * C[1] - m[1] * C[0]};
    const T angle = atan2(sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]), m[0] * C[0] + m[1] * C[1] + m[2] * C[2]);
    const T dist = sqrt(C[0] * C[0] + C[1] * C[1] + C[2] * C[2]);
    if (!(dist > p.curvature_radius)) return false;
    r[0] = T(scale_) * (angle - asin(p.curvature_radius / dist));
    return true;
  }
  Eigen::Vector2d px_;
  double scale_;
};

// Pixels per radian of cone angle at the limb (for the residual's scale):
// from two predicted points.
double PixelsPerRadian(const Sensor& s) {
  const double a = LimbHalfAngle(s), eps = 1e-4;
  Eigen::Vector3d m0, m1;
  Eigen::Vector2d p0, p1;
  ConeRay(s, 0.0, a, &m0);
  ConeRay(s, 0.0, a - eps, &m1);
  if (!PixelOfMirrorFrameRay(s, m0.data(), &p0) || !PixelOfMirrorFrameRay(s, m1.data(), &p1)) return s.params.focal_px;
  return (p0 - p1).norm() / eps;
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  const size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + h, v.end());
  return v[h];
}

// Where the profile crosses its mid grey nearest the centre sample (offset
// in samples from the centre); false without a clean step.
bool EdgeCrossing(const std::vector<float>& prof, int plateau, double min_contrast, double* offset) {
  const int n = static_cast<int>(prof.size()), mid = n / 2;
  double in = 0, out = 0, in2 = 0, out2 = 0;
  for (int k = 0; k < plateau; ++k) {
    in += prof[k];
    in2 += prof[k] * prof[k];
    out += prof[n - 1 - k];
    out2 += prof[n - 1 - k] * prof[n - 1 - k];
  }
  in /= plateau;
  out /= plateau;
  const double contrast = std::abs(in - out);
  if (!(contrast >= min_contrast)) return false;
  // Plateaus flat against the step: no board or other edge next to the limb.
  const double sd_in = std::sqrt(std::max(0.0, in2 / plateau - in * in));
  const double sd_out = std::sqrt(std::max(0.0, out2 / plateau - out * out));
  if (sd_in > 0.15 * contrast || sd_out > 0.15 * contrast) return false;
  const double level = 0.5 * (in + out);
  const double sign = in > out ? 1.0 : -1.0;
  // Exactly one crossing between the plateaus.
  int crossings = 0, at = -1;
  for (int k = plateau - 1; k < n - plateau; ++k)
    if ((prof[k] - level) * sign > 0 && (prof[k + 1] - level) * sign <= 0) {
      ++crossings;
      at = k;
    }
  if (crossings != 1) return false;
  const double a = prof[at] - level, b = prof[at + 1] - level;
  *offset = at + a / (a - b) - mid;
  return true;
}

}  // namespace

bool LimbPixel(const Sensor& sensor, double psi, Eigen::Vector2d* pixel) {
  if (!IsSphere(sensor)) return false;
  const double a = LimbHalfAngle(sensor);
  Eigen::Vector3d m;
  return std::isfinite(a) && ConeRay(sensor, psi, a, &m) && PixelOfMirrorFrameRay(sensor, m.data(), pixel);
}

LimbObservation MeasureLimb(const std::vector<cv::Mat>& images, const Sensor& sensor, const LimbOptions& o,
                            int num_threads) {
  LimbObservation obs;
  if (!IsSphere(sensor) || images.empty() || !std::isfinite(LimbHalfAngle(sensor))) return obs;
  const int n_az = o.azimuths;
  constexpr double kStep = 0.25;  // profile samples per pixel: 4
  const int half = static_cast<int>(std::ceil(o.search_px / kStep)), n_prof = 2 * half + 1;
  const int plateau = static_cast<int>(std::lround(3.0 / kStep));
  // The predicted limb and its outward normal, per azimuth.
  std::vector<Eigen::Vector2d> at(n_az), normal(n_az);
  std::vector<char> usable(n_az, 0);
  const double a = LimbHalfAngle(sensor);
  for (int k = 0; k < n_az; ++k) {
    const double psi = 2.0 * M_PI * k / n_az;
    Eigen::Vector3d m0, m1;
    Eigen::Vector2d p1;
    ConeRay(sensor, psi, a, &m0);
    ConeRay(sensor, psi, a - 1e-3, &m1);
    if (!PixelOfMirrorFrameRay(sensor, m0.data(), &at[k]) || !PixelOfMirrorFrameRay(sensor, m1.data(), &p1))
      continue;
    normal[k] = (at[k] - p1).normalized();
    const Eigen::Vector2d lo = at[k] - (o.search_px + 1) * normal[k], hi = at[k] + (o.search_px + 1) * normal[k];
    const double w = images.front().cols, h = images.front().rows;
    usable[k] = lo.x() >= 1 && lo.y() >= 1 && hi.x() >= 1 && hi.y() >= 1 && lo.x() < w - 2 && hi.x() < w - 2 &&
                lo.y() < h - 2 && hi.y() < h - 2;
  }
  const int n_im = static_cast<int>(images.size());
  std::vector<std::vector<float>> offsets(n_im, std::vector<float>(n_az, NAN));
  ParallelFor(
      n_im,
      [&](int i) {
        const cv::Mat& im = images[i];
        if (im.type() != CV_8UC1) return;
        std::vector<float> prof(n_prof);
        for (int k = 0; k < n_az; ++k) {
          if (!usable[k]) continue;
          bool ok = true;
          for (int j = 0; j < n_prof && ok; ++j) {
            const Eigen::Vector2d q = at[k] + (j - half) * kStep * normal[k];
            ok = SampleGrey(im, q.x(), q.y(), &prof[j]);
          }
          double off;
          if (ok && EdgeCrossing(prof, plateau, o.min_contrast, &off)) offsets[i][k] = static_cast<float>(off * kStep);
        }
      },
      true, num_threads);
  // Per azimuth: the median over the images; the spread about it gives one
  // image's sigma (median absolute deviation).
  std::vector<double> dev;
  std::vector<char> image_used(n_im, 0);
  std::vector<std::pair<int, double>> medians;
  const int need = std::max(3, static_cast<int>(std::ceil(o.min_image_fraction * n_im)));
  double n_sum = 0;
  for (int k = 0; k < n_az; ++k) {
    std::vector<double> v;
    for (int i = 0; i < n_im; ++i)
      if (std::isfinite(offsets[i][k])) v.push_back(offsets[i][k]);
    if (static_cast<int>(v.size()) < need) continue;
    const double med = Median(v);
    for (double x : v) dev.push_back(std::abs(x - med));
    for (int i = 0; i < n_im; ++i)
      if (std::isfinite(offsets[i][k])) image_used[i] = 1;
    medians.push_back({k, med});
    n_sum += v.size();
  }
  if (static_cast<int>(medians.size()) < o.min_point_fraction * n_az) return obs;
  // A point's sigma: mostly a pattern fixed in the image (the pixel grid
  // against the curve), the same in every image, so the images' spread
  // misses it; the step between neighbouring points shows it (the predicted
  // limb is smooth), each step holding two points' errors.
  std::vector<double> steps;
  for (size_t j = 1; j < medians.size(); ++j)
    if (medians[j].first == medians[j - 1].first + 1) steps.push_back(std::abs(medians[j].second - medians[j - 1].second));
  const double sigma_pattern = steps.empty() ? 0.0 : 1.4826 * Median(steps) / std::sqrt(2.0);
  const double sigma_one = 1.4826 * Median(dev);
  const double n_mean = n_sum / medians.size();
  // The median of n has about 1.25 times the mean's sigma.
  obs.point_sigma_px = std::max({o.min_sigma_px, sigma_pattern, 1.25 * sigma_one / std::sqrt(n_mean)});
  for (const auto& [k, med] : medians) obs.points.push_back(at[k] + med * normal[k]);
  obs.images_used = static_cast<int>(std::count(image_used.begin(), image_used.end(), 1));
  return obs;
}

void AddLimbResiduals(ceres::Problem* problem, const LimbObservation& obs, double* sensor_block,
                      double* fault_block) {
  if (obs.Empty()) return;
  if (!problem->HasParameterBlock(fault_block)) {
    problem->AddParameterBlock(fault_block, kNumFaults);
    problem->SetParameterBlockConstant(fault_block);
  }
  Sensor s;
  s.model = MirrorModel::kSphere;
  s.params = ParamsFromBlock(sensor_block);
  s.faults = FaultsFromBlock(fault_block);
  const double scale = obs.weight * PixelsPerRadian(s);
  for (const Eigen::Vector2d& q : obs.points)
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<LimbCost, 1, kNumSensor, kNumFaults>(new LimbCost(q, scale)), nullptr,
        sensor_block, fault_block);
}

std::vector<double> LimbResidualsPx(const LimbObservation& obs, const Sensor& sensor) {
  std::vector<double> out;
  if (obs.Empty() || !IsSphere(sensor)) return out;
  const std::array<double, kNumSensor> s = BlockFromParams(sensor.params);
  const std::array<double, kNumFaults> f = BlockFromFaults(sensor.faults);
  const double scale = PixelsPerRadian(sensor);
  for (const Eigen::Vector2d& q : obs.points) {
    double r;
    out.push_back(LimbCost(q, scale)(s.data(), f.data(), &r) ? r : NAN);
  }
  return out;
}

double LimbRmsPx(const LimbObservation& obs, const Sensor& sensor) {
  double sum = 0;
  int n = 0;
  for (double r : LimbResidualsPx(obs, sensor))
    if (std::isfinite(r)) {
      sum += r * r;
      ++n;
    }
  return n ? std::sqrt(sum / n) : NAN;
}

}  // namespace pano

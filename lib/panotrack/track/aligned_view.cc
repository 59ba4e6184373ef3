#include "panotrack/track/aligned_view.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>
#include <Eigen/Dense>

#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/scene/map.h"

namespace pano {

namespace {

// The point of ray (origin, direction) at horizontal distance d from the
// axis; false when the ray never gets there going forward.
bool PointAtDistance(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double d, Eigen::Vector3d* x) {
  const double a = dir.x() * dir.x() + dir.y() * dir.y();
  const double b = 2 * (origin.x() * dir.x() + origin.y() * dir.y());
  const double c = origin.x() * origin.x() + origin.y() * origin.y() - d * d;
  const double disc = b * b - 4 * a * c;
  if (!(a > 0) || disc < 0) return false;
  const double t = (-b + std::sqrt(disc)) / (2 * a);
  if (!(t > 0)) return false;
  *x = origin + t * dir;
  return true;
}

}  // namespace

AlignedView::AlignedView(const Sensor& rig, double exact_distance, int grid_step_px, int num_threads)
    : rig_(rig), view_(rig), exact_distance_(exact_distance) {
  rig_.Check("aligned view: rig");
  if (!(exact_distance > 0)) throw Error("aligned view: exact_distance: expected > 0");
  if (grid_step_px < 1) throw Error("aligned view: grid_step_px: expected >= 1");
  CheckThreadCount(num_threads, "aligned view: num_threads");
  [[maybe_unused]] const int threads = ThreadCount(num_threads);
  view_.faults = RigFaults<double>();
  // The mirror's centre (a sphere's centre; a conic's centre of curvature at
  // its vertex) in the robot frame; the view's upright rig has its own there.
  const RigFaults<double>& f = rig.faults;
  const double centre_height = rig.params.vertex_distance + rig.params.curvature_radius;
  double tilt[9];
  detail::TiltRotation(f.sensor_tilt, tilt);
  const double centre_mirror[3] = {f.mirror_offset[0], f.mirror_offset[1], centre_height};
  double centre_robot[3];
  detail::rotate(tilt, centre_mirror, centre_robot);
  // Its height differs from the robot pinhole's by (1 - cos tilt) times the
  // mirror distance, a few thousandths of a per cent of it: taken as 0, so
  // that the map's heights hold for the view as they are.
  offset_ = Eigen::Vector3d(centre_robot[0], centre_robot[1], 0.0);
  FitOffset();

  const int w = rig.image_width, h = rig.image_height;
  map_x_.create(h, w, CV_32FC1);
  map_y_.create(h, w, CV_32FC1);
  map_x_.setTo(-1.0f);
  map_y_.setTo(-1.0f);
  // The exact mapping on a grid, then each cell interpolated where its four
  // nodes are inside, else computed pixel by pixel.
  const int gw = (w - 1 + grid_step_px - 1) / grid_step_px + 1, gh = (h - 1 + grid_step_px - 1) / grid_step_px + 1;
  cv::Mat gx(gh, gw, CV_64FC1, cv::Scalar(-1)), gy(gh, gw, CV_64FC1, cv::Scalar(-1));
  cv::Mat ok(gh, gw, CV_8UC1, cv::Scalar(0));
  auto node_u = [&](int j) { return std::min(j * grid_step_px, w - 1); };
  auto node_v = [&](int i) { return std::min(i * grid_step_px, h - 1); };
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads)
  for (int i = 0; i < gh; ++i)
    for (int j = 0; j < gw; ++j) {
      double ur, vr;
      if (ExactRealPixel(node_u(j), node_v(i), &ur, &vr)) {
        gx.at<double>(i, j) = ur;
        gy.at<double>(i, j) = vr;
        ok.at<uchar>(i, j) = 1;
      }
    }
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads)
  for (int i = 0; i < gh - 1; ++i)
    for (int j = 0; j + 1 < gw; ++j) {
      const int u0 = node_u(j), u1 = node_u(j + 1), v0 = node_v(i), v1 = node_v(i + 1);
      const bool all = ok.at<uchar>(i, j) && ok.at<uchar>(i, j + 1) && ok.at<uchar>(i + 1, j) &&
                       ok.at<uchar>(i + 1, j + 1);
      for (int v = v0; v <= v1; ++v)
        for (int u = u0; u <= u1; ++u) {
          double ur, vr;
          if (all) {
            const double s = u1 > u0 ? double(u - u0) / (u1 - u0) : 0.0;
            const double t = v1 > v0 ? double(v - v0) / (v1 - v0) : 0.0;
            auto lerp = [&](const cv::Mat& g) {
              return (1 - t) * ((1 - s) * g.at<double>(i, j) + s * g.at<double>(i, j + 1)) +
                     t * ((1 - s) * g.at<double>(i + 1, j) + s * g.at<double>(i + 1, j + 1));
            };
            ur = lerp(gx);
            vr = lerp(gy);
          } else if (!ExactRealPixel(u, v, &ur, &vr)) {
            continue;
          }
          map_x_.at<float>(v, u) = static_cast<float>(ur);
          map_y_.at<float>(v, u) = static_cast<float>(vr);
        }
    }
  residual_px_ = MeasureResidual();
  // The resampling tables: fixed point (OpenCV's bilinear remap works so in
  // any case, to 1/32 px); a view pixel the rig does not see samples the
  // real image's corner instead of the border, which keeps cv::remap on its
  // fast path (nothing reads those pixels).
  cv::Mat x = map_x_.clone(), y = map_y_.clone();
  x.setTo(0.0f, map_x_ < 0);
  y.setTo(0.0f, map_x_ < 0);
  cv::convertMaps(x, y, fixed_xy_, fixed_fraction_, CV_16SC2);
}

bool AlignedView::ExactRealPixel(double u, double v, double* ur, double* vr) const {
  Eigen::Vector3d origin, dir, x;
  if (!view_.backproject(Eigen::Vector2d(u, v), &origin, &dir)) return false;
  if (!PointAtDistance(origin, dir, exact_distance_, &x)) return false;
  Eigen::Vector2d pixel;
  if (!rig_.project(x + offset_, &pixel)) return false;
  if (!rig_.inside_image(pixel)) return false;
  *ur = pixel.x();
  *vr = pixel.y();
  return true;
}

bool AlignedView::RayMismatch(const Eigen::Vector3d& offset, std::vector<double>* residuals) const {
  // Sample points over 0.5x to 8x the exact distance, in every direction
  // the rig sees: where the rig sees each, less where the exact view
  // mapping puts it (x and y, px); 0 for points either side does not see,
  // so that the vector keeps its layout.
  residuals->clear();
  bool any = false;
  for (double scale : {0.5, 1.0, 2.0, 4.0, 8.0})
    for (int iz = -3; iz <= 3; ++iz)
      for (int k = 0; k < 16; ++k) {
        const double d = scale * exact_distance_, a = (k + 0.5) * 2 * M_PI / 16;
        const Eigen::Vector3d x(d * std::cos(a), d * std::sin(a), iz * exact_distance_ / 6);
        Eigen::Vector2d real, view, back;
        Eigen::Vector3d origin, dir, at;
        const bool seen = rig_.project(x, &real) && rig_.inside_image(real, 2.0) && view_.project(x - offset, &view) &&
                          view_.backproject(view, &origin, &dir) &&
                          PointAtDistance(origin, dir, exact_distance_, &at) && rig_.project(at + offset, &back);
        residuals->push_back(seen ? back.x() - real.x() : 0.0);
        residuals->push_back(seen ? back.y() - real.y() : 0.0);
        any = any || seen;
      }
  return any;
}

void AlignedView::FitOffset() {
  // The view is upright and the rig's mirror is not, so no offset makes
  // every ray the same line: from the mirror centres' coincidence, the
  // offset that makes them nearest (Gauss-Newton, numeric derivatives).
  std::vector<double> r0, r1;
  if (!RayMismatch(offset_, &r0)) return;
  const double h = 1e-4 * std::max(1.0, std::abs(rig_.params.curvature_radius));
  for (int iteration = 0; iteration < 8; ++iteration) {
    Eigen::MatrixXd J(r0.size(), 2);
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector3d trial = offset_;
      trial[k] += h;
      RayMismatch(trial, &r1);
      for (size_t i = 0; i < r0.size(); ++i) J(static_cast<Eigen::Index>(i), k) = (r1[i] - r0[i]) / h;
    }
    const Eigen::Map<const Eigen::VectorXd> r(r0.data(), static_cast<Eigen::Index>(r0.size()));
    const Eigen::Vector2d step2 = -(J.transpose() * J).ldlt().solve(J.transpose() * r);
    const Eigen::Vector3d step(step2.x(), step2.y(), 0.0);
    if (!step.allFinite()) return;
    RayMismatch(offset_ + step, &r1);
    const Eigen::Map<const Eigen::VectorXd> rn(r1.data(), static_cast<Eigen::Index>(r1.size()));
    if (!(rn.squaredNorm() < r.squaredNorm())) return;
    offset_ += step;
    r0.swap(r1);
    if (step.norm() < 1e-7 * h / 1e-4) return;
  }
}

bool AlignedView::RealPixel(double u, double v, double* ur, double* vr) const {
  if (!(u >= 0 && v >= 0 && u <= map_x_.cols - 1 && v <= map_x_.rows - 1)) return false;
  const int j = std::min(static_cast<int>(u), map_x_.cols - 2), i = std::min(static_cast<int>(v), map_x_.rows - 2);
  const double s = u - j, t = v - i;
  double out[2];
  const cv::Mat* maps[2] = {&map_x_, &map_y_};
  for (int k = 0; k < 2; ++k) {
    const cv::Mat& m = *maps[k];
    const float a = m.at<float>(i, j), b = m.at<float>(i, j + 1), c = m.at<float>(i + 1, j),
                d = m.at<float>(i + 1, j + 1);
    if (a < 0 || b < 0 || c < 0 || d < 0) return false;
    out[k] = (1 - t) * ((1 - s) * a + s * b) + t * ((1 - s) * c + s * d);
  }
  *ur = out[0];
  *vr = out[1];
  return true;
}

double AlignedView::MeasureResidual() const {
  // Points in every direction the view sees, at several distances: where
  // the real rig sees each against where the resampled view puts it.
  double worst = 0.0;
  const double z_span = 0.5 * exact_distance_;
  for (double scale : {0.5, 1.0, 2.0, 4.0, 8.0})
    for (int iz = -4; iz <= 4; ++iz)
      for (int k = 0; k < 64; ++k) {
        const double d = scale * exact_distance_, a = k * 2 * M_PI / 64;
        const Eigen::Vector3d x(d * std::cos(a), d * std::sin(a), iz * z_span / 4);
        Eigen::Vector2d real, view;
        if (!rig_.project(x, &real) || !view_.project(x - offset_, &view)) continue;
        if (!rig_.inside_image(real, 2.0) || !view_.inside_image(view, 2.0)) continue;
        double ur, vr;
        if (!RealPixel(view.x(), view.y(), &ur, &vr)) continue;
        worst = std::max(worst, std::hypot(ur - real.x(), vr - real.y()));
      }
  return worst;
}

void AlignedView::Resample(const cv::Mat& real, cv::Mat* view) const {
  if (real.type() != CV_8UC1 || real.cols != rig_.image_width || real.rows != rig_.image_height)
    throw Error("aligned view: expected a " + std::to_string(rig_.image_width) + "x" +
                std::to_string(rig_.image_height) + " grey frame");
  cv::remap(real, *view, fixed_xy_, fixed_fraction_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
}

Pose2 AlignedView::ViewPose(const Pose2& robot) const {
  const double c = std::cos(robot.theta), s = std::sin(robot.theta);
  return {robot.x + c * offset_.x() - s * offset_.y(), robot.y + s * offset_.x() + c * offset_.y(), robot.theta};
}

Pose2 AlignedView::RobotPose(const Pose2& view) const {
  const double c = std::cos(view.theta), s = std::sin(view.theta);
  return {view.x - (c * offset_.x() - s * offset_.y()), view.y - (s * offset_.x() + c * offset_.y()), view.theta};
}

double TypicalLandmarkDistance(const Map& map) {
  Eigen::Vector2d sum(0, 0);
  int n = 0;
  for (const MapRectangle& r : map.rectangles) {
    sum += r.from + r.to;
    n += 2;
  }
  if (n == 0) return 0.0;
  const Eigen::Vector2d centre = sum / n;
  double ss = 0.0;
  for (const MapRectangle& r : map.rectangles) ss += (r.from - centre).squaredNorm() + (r.to - centre).squaredNorm();
  return std::sqrt(ss / n);
}

}  // namespace pano

#include "view_measure.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace pano::test {

namespace {

double Bilinear(const cv::Mat& img, const Eigen::Vector2d& p) {
  const int u0 = static_cast<int>(std::floor(p.x())), v0 = static_cast<int>(std::floor(p.y()));
  const double fu = p.x() - u0, fv = p.y() - v0;
  auto at = [&](int u, int v) {
    u = std::clamp(u, 0, img.cols - 1);
    v = std::clamp(v, 0, img.rows - 1);
    return static_cast<double>(img.at<uint8_t>(v, u));
  };
  return (1 - fv) * ((1 - fu) * at(u0, v0) + fu * at(u0 + 1, v0)) +
         fv * ((1 - fu) * at(u0, v0 + 1) + fu * at(u0 + 1, v0 + 1));
}

int IdAt(const cv::Mat& ids, const Eigen::Vector2d& p) {
  const int u = static_cast<int>(std::lround(p.x())), v = static_cast<int>(std::lround(p.y()));
  if (u < 0 || v < 0 || u >= ids.cols || v >= ids.rows) return -3;
  return static_cast<int>(std::lround(ids.at<float>(v, u)));
}

}  // namespace

double StepOffset(const cv::Mat& view, const cv::Mat& ids, int surface, const Eigen::Vector2d& p,
                  const Eigen::Vector2d& dir, double reach) {
  const double nan = std::nan("");
  int side_id[2];
  for (int side = 0; side < 2; ++side) {
    const double sg = side == 0 ? -1.0 : 1.0;
    side_id[side] = IdAt(ids, p + sg * reach * dir);
    for (double d = reach - 1.0; d <= reach + 1.0 + 1e-9; d += 0.5)
      if (IdAt(ids, p + sg * d * dir) != side_id[side]) return nan;
  }
  if (side_id[0] == side_id[1] || side_id[0] < 0 || side_id[1] < 0) return nan;
  if (side_id[0] != surface && side_id[1] != surface) return nan;
  int changes = 0;
  for (double d = -reach - 1.0 + 0.25; d <= reach + 1.0 + 1e-9; d += 0.25)
    if (IdAt(ids, p + d * dir) != IdAt(ids, p + (d - 0.25) * dir)) ++changes;
  if (changes != 1) return nan;
  const double lo = Bilinear(view, p - reach * dir), hi = Bilinear(view, p + reach * dir);
  if (std::abs(hi - lo) < 30.0) return nan;
  const double mid = 0.5 * (lo + hi), step = 0.02;
  double best = nan;
  double prev = Bilinear(view, p - reach * dir) - mid;
  for (double t = -reach + step; t <= reach + 1e-9; t += step) {
    const double cur = Bilinear(view, p + t * dir) - mid;
    if ((prev <= 0 && cur > 0) || (prev >= 0 && cur < 0)) {
      const double x = t - step + step * prev / (prev - cur);
      if (std::isnan(best) || std::abs(x) < std::abs(best)) best = x;
    }
    prev = cur;
  }
  return best;
}

LineFit FitLine(const std::vector<Eigen::Vector2d>& points) {
  LineFit f;
  f.n = static_cast<int>(points.size());
  if (f.n < 2) return f;
  Eigen::Vector2d c(0, 0);
  for (const auto& p : points) c += p;
  c /= f.n;
  Eigen::Matrix2d s = Eigen::Matrix2d::Zero();
  for (const auto& p : points) s += (p - c) * (p - c).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(s);
  f.centre = c;
  f.direction = eig.eigenvectors().col(1);
  const Eigen::Vector2d normal(-f.direction.y(), f.direction.x());
  double sum = 0.0;
  for (const auto& p : points) {
    const double r = normal.dot(p - c);
    sum += r * r;
    f.max_abs = std::max(f.max_abs, std::abs(r));
  }
  f.rms = std::sqrt(sum / f.n);
  return f;
}

Eigen::Vector2d Intersect(const LineFit& a, const LineFit& b) {
  // a.centre + s a.dir = b.centre + t b.dir
  Eigen::Matrix2d m;
  m << a.direction, -b.direction;
  const Eigen::Vector2d st = m.colPivHouseholderQr().solve(b.centre - a.centre);
  return a.centre + st[0] * a.direction;
}

cv::Mat UnwarpIds(const cv::Mat& ids, const Sensor& sensor, UnwarpOptions options) {
  cv::Mat f;
  ids.convertTo(f, CV_32F);
  options.interpolation = cv::INTER_NEAREST;
  options.border_value = cv::Scalar::all(-1);
  return UnwarpImage(f, sensor, options);
}

}  // namespace pano::test

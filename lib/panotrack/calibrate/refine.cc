// Model-based corner refinement (step 5 of calibrate.h).
#include <ceres/rotation.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/core/grey_sample.h"
#include "panotrack/core/parallel.h"
#include "panotrack/sensor/catadioptric.h"

namespace pano {

namespace {

// Pixel of the board point (x, y, 0) for a view's pose.
bool ProjectBoardPoint(const Sensor& s, const BoardView& v, double x, double y, Eigen::Vector2d* px) {
  const double pb[3] = {x, y, 0.0};
  double ps[3];
  ceres::AngleAxisRotatePoint(v.rvec.data(), pb, ps);
  for (int k = 0; k < 3; ++k) ps[k] += v.tvec[k];
  // Through the faults too (Sensor::project).
  return s.project(Eigen::Vector3d(ps[0], ps[1], ps[2]), px);
}

}  // namespace

int RefineCornersThroughModel(const std::vector<cv::Mat>& images, const TargetBoard& board,
                              const Sensor& sensor, std::vector<BoardView>* views, int num_threads) {
  // A patch of +-0.4 squares around each corner, 33 x 33 samples.
  constexpr int kN = 33, kHalf = kN / 2;
  const double step = 0.8 * board.square / (kN - 1);
  // One task per corner (in parallel), each writing only its own corner.
  std::vector<cv::Mat> greys(views->size());
  std::vector<std::pair<int, int>> tasks;  // (view, corner)
  const std::vector<Eigen::Vector3d> points = BoardPoints(board);
  for (size_t i = 0; i < views->size(); ++i) {
    const BoardView& v = (*views)[i];
    if (v.image_index < 0 || v.image_index >= static_cast<int>(images.size())) continue;
    cv::Mat grey = images[v.image_index];
    if (grey.channels() != 1) cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
    if (grey.depth() != CV_8U) continue;
    greys[i] = grey;
    for (size_t k = 0; k < v.corners.size(); ++k)
      if (v.PointId(k) >= 0 && v.PointId(k) < static_cast<int>(points.size()))
        tasks.push_back({static_cast<int>(i), static_cast<int>(k)});
  }
  std::vector<char> moved(tasks.size(), 0);
  ParallelFor(static_cast<int>(tasks.size()), [&](int t) {
    BoardView& v = (*views)[tasks[t].first];
    const cv::Mat& grey = greys[tasks[t].first];
    const size_t k = static_cast<size_t>(tasks[t].second);
    const Eigen::Vector3d& point = points[static_cast<size_t>(v.PointId(k))];
    const double x0 = point.x(), y0 = point.y();
    cv::Mat patch(kN, kN, CV_32FC1);
    bool ok = true;
    for (int i = 0; i < kN && ok; ++i)
      for (int j = 0; j < kN && ok; ++j) {
        Eigen::Vector2d px;
        ok = ProjectBoardPoint(sensor, v, x0 + (j - kHalf) * step, y0 + (i - kHalf) * step, &px) &&
             SampleGrey(grey, px.x(), px.y(), &patch.at<float>(i, j));
      }
    if (!ok) return;
    // The X-junction of the straightened squares: the saddle point of the
    // patch smoothed by a Gaussian, from a quadratic surface fitted by least
    // squares around it (Lucchese and Mitra), iterated as the centre moves.
    cv::GaussianBlur(patch, patch, cv::Size(0, 0), 3.0);
    double cx = kHalf, cy = kHalf;
    bool fitted = false;
    for (int it = 0; it < 3; ++it) {
      const int ix = static_cast<int>(std::lround(cx)), iy = static_cast<int>(std::lround(cy));
      constexpr int kW = 5;
      if (ix - kW < 0 || iy - kW < 0 || ix + kW >= kN || iy + kW >= kN) break;
      Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
      for (int i = -kW; i <= kW; ++i)
        for (int j = -kW; j <= kW; ++j) {
          Eigen::Matrix<double, 6, 1> row;
          row << j * j, j * i, i * i, j, i, 1.0;
          A += row * row.transpose();
          b += row * patch.at<float>(iy + i, ix + j);
        }
      const Eigen::Matrix<double, 6, 1> q = A.ldlt().solve(b);
      Eigen::Matrix2d H;
      H << 2 * q[0], q[1], q[1], 2 * q[2];
      if (!(H.determinant() < 0)) break;  // not a saddle
      const Eigen::Vector2d off = -H.inverse() * Eigen::Vector2d(q[3], q[4]);
      if (!off.allFinite() || off.norm() > kW) break;
      cx = ix + off.x();
      cy = iy + off.y();
      fitted = true;
      if (off.norm() < 0.5) break;
    }
    if (!fitted) return;
    const double dx = (cx - kHalf) * step, dy = (cy - kHalf) * step;
    // A move of more than a fifth of a square is no refinement: keep the corner.
    if (!std::isfinite(dx) || !std::isfinite(dy) || std::hypot(dx, dy) > 0.2 * board.square) return;
    Eigen::Vector2d px;
    if (!ProjectBoardPoint(sensor, v, x0 + dx, y0 + dy, &px)) return;
    v.corners[k] = px;
    moved[t] = 1;
  }, true, num_threads);
  return static_cast<int>(std::count(moved.begin(), moved.end(), 1));
}

}  // namespace pano

// The peer users would pick instead of panocalib: OpenCV's
// cv::omnidir::calibrate (Mei's unified model: xi, fx, fy, skew, cx, cy,
// k1, k2, p1, p2), fitted by least squares to the same corners, and its
// Euclidean RMS reprojection error computed as panocalib computes its own.
// Also the pose of a board held out of omnidir's fit, through its fixed
// intrinsics (OmnidirHeldOut), as `panocalib evaluate` fits panotrack's.
// Header-only; whoever includes it links opencv_ccalib (Debian's OpenCV
// contrib). Used by bench/calibrate_compare.cc, bench/omnidir_cv.cc and
// tests/calibrate.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Dense>
#include <opencv2/ccalib/omnidir.hpp>

#include <chrono>
#include <cmath>
#include <vector>

#include "panotrack/calibrate/calibrate.h"

namespace pano {

struct OmnidirFit {
  double rms_px = NAN;  // over the images omnidir kept
  int images_used = 0;  // omnidir drops images whose initialisation fails
  std::vector<int> kept;  // the views it kept (indices into the views given)
  double seconds = 0.0;
  cv::Mat K, D, xi;  // camera matrix (with skew), k1 k2 p1 p2, xi
};

// flags: cv::omnidir::CALIB_FIX_* to hold some of omnidir's terms.
inline OmnidirFit FitOmnidir(const std::vector<BoardView>& views, const TargetBoard& board, cv::Size size,
                             int flags = 0) {
  std::vector<cv::Mat> obj, img;
  const std::vector<Eigen::Vector3d> pts = BoardPoints(board);
  for (const BoardView& v : views) {
    // A partial view (ChArUco) names the board point of each corner.
    const int n = static_cast<int>(v.corners.size());
    cv::Mat o(n, 1, CV_64FC3), p(n, 1, CV_64FC2);
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3d& q = pts[v.PointId(j)];
      o.at<cv::Vec3d>(j) = cv::Vec3d(q.x(), q.y(), 0.0);
      p.at<cv::Vec2d>(j) = cv::Vec2d(v.corners[j].x(), v.corners[j].y());
    }
    obj.push_back(o);
    img.push_back(p);
  }
  OmnidirFit fit;
  cv::Mat idx;
  std::vector<cv::Mat> rvecs, tvecs;
  const auto t0 = std::chrono::steady_clock::now();
  cv::omnidir::calibrate(obj, img, size, fit.K, fit.xi, fit.D, rvecs, tvecs, flags,
                         cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 300, 1e-8), idx);
  fit.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  double s2 = 0;
  size_t n = 0;
  fit.images_used = static_cast<int>(idx.total());
  for (int k = 0; k < fit.images_used; ++k) {
    const int i = idx.at<int>(k);
    fit.kept.push_back(i);
    cv::Mat proj;
    cv::omnidir::projectPoints(obj[i], proj, rvecs[k], tvecs[k], fit.K, fit.xi.at<double>(0), fit.D);
    for (int j = 0; j < proj.rows; ++j) {
      const cv::Vec2d d = proj.at<cv::Vec2d>(j) - img[i].at<cv::Vec2d>(j);
      s2 += d.dot(d);
      ++n;
    }
  }
  if (n > 0) fit.rms_px = std::sqrt(s2 / n);
  return fit;
}

// Mei's unified projection as cv::omnidir::projectPoints computes it: the
// point on the unit sphere, shifted by xi, k1 k2 p1 p2 distortion, the camera
// matrix with skew.
struct OmnidirIntrinsics {
  double fx, fy, s, cx, cy, xi, k1, k2, p1, p2;
  explicit OmnidirIntrinsics(const OmnidirFit& f)
      : fx(f.K.at<double>(0, 0)), fy(f.K.at<double>(1, 1)), s(f.K.at<double>(0, 1)), cx(f.K.at<double>(0, 2)),
        cy(f.K.at<double>(1, 2)), xi(f.xi.at<double>(0)), k1(f.D.at<double>(0)), k2(f.D.at<double>(1)),
        p1(f.D.at<double>(2)), p2(f.D.at<double>(3)) {}
};

struct OmnidirCornerCost {
  OmnidirCornerCost(const OmnidirIntrinsics& k, const Eigen::Vector3d& X, const Eigen::Vector2d& obs)
      : k(k), X(X), obs(obs) {}
  template <typename T>
  bool operator()(const T* pose, T* r) const {
    const T Xb[3] = {T(X.x()), T(X.y()), T(X.z())};
    T Xc[3];
    ceres::AngleAxisRotatePoint(pose, Xb, Xc);
    for (int i = 0; i < 3; ++i) Xc[i] += pose[3 + i];
    const T n = ceres::sqrt(Xc[0] * Xc[0] + Xc[1] * Xc[1] + Xc[2] * Xc[2]);
    const T zs = Xc[2] / n + T(k.xi);
    const T x = Xc[0] / n / zs, y = Xc[1] / n / zs;
    const T r2 = x * x + y * y, r4 = r2 * r2;
    const T radial = T(1) + T(k.k1) * r2 + T(k.k2) * r4;
    const T xd = x * radial + T(2 * k.p1) * x * y + T(k.p2) * (r2 + T(2) * x * x);
    const T yd = y * radial + T(k.p1) * (r2 + T(2) * y * y) + T(2 * k.p2) * x * y;
    r[0] = T(k.fx) * xd + T(k.s) * yd + T(k.cx) - T(obs.x());
    r[1] = T(k.fy) * yd + T(k.cy) - T(obs.y());
    return true;
  }
  OmnidirIntrinsics k;
  Eigen::Vector3d X;
  Eigen::Vector2d obs;
};

// The unit ray of a pixel through Mei's model (distortion undone by
// fixed-point iteration, then lifted onto the sphere).
inline Eigen::Vector3d OmnidirRay(const OmnidirIntrinsics& k, const Eigen::Vector2d& px) {
  const double yd = (px.y() - k.cy) / k.fy, xd = (px.x() - k.cx - k.s * yd) / k.fx;
  double x = xd, y = yd;
  for (int i = 0; i < 50; ++i) {
    const double r2 = x * x + y * y, radial = 1 + k.k1 * r2 + k.k2 * r2 * r2;
    const double dx = 2 * k.p1 * x * y + k.p2 * (r2 + 2 * x * x), dy = k.p1 * (r2 + 2 * y * y) + 2 * k.p2 * x * y;
    x = (xd - dx) / radial;
    y = (yd - dy) / radial;
  }
  const double r2 = x * x + y * y;
  const double lambda = (k.xi + std::sqrt(1 + (1 - k.xi * k.xi) * r2)) / (1 + r2);
  return Eigen::Vector3d(lambda * x, lambda * y, lambda - k.xi).normalized();
}

// A held-out board's pose through fixed omnidir intrinsics: a homography from
// the corners' rays (DLT: ray x H [X Y 1] = 0), then Ceres on the pixel
// error (least squares, omnidir's own objective). Adds the squared errors
// of its corners (cv::omnidir::projectPoints) to *s2 and their count to *n.
inline bool OmnidirHeldOut(const OmnidirFit& f, const BoardView& v, const std::vector<Eigen::Vector3d>& pts,
                    double* s2, size_t* n) {
  const OmnidirIntrinsics k(f);
  const int m = static_cast<int>(v.corners.size());
  Eigen::MatrixXd A(2 * m, 9);
  for (int j = 0; j < m; ++j) {
    const Eigen::Vector3d b = OmnidirRay(k, v.corners[j]);
    const Eigen::Vector3d p(pts[v.PointId(j)].x(), pts[v.PointId(j)].y(), 1.0);
    // Rows of [b]_x (I kron p^T): b x (H p) = 0, two independent rows.
    A.row(2 * j) << 0, 0, 0, -b.z() * p.transpose(), b.y() * p.transpose();
    A.row(2 * j + 1) << b.z() * p.transpose(), 0, 0, 0, -b.x() * p.transpose();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d H;
  H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  double scale = 2.0 / (H.col(0).norm() + H.col(1).norm());
  // In front of the camera along the rays.
  const Eigen::Vector3d p0(pts[v.PointId(0)].x(), pts[v.PointId(0)].y(), 1.0);
  if (OmnidirRay(k, v.corners[0]).dot(H * p0) < 0) scale = -scale;
  Eigen::Matrix3d M;
  M.col(0) = scale * H.col(0);
  M.col(1) = scale * H.col(1);
  M.col(2) = M.col(0).cross(M.col(1));
  Eigen::JacobiSVD<Eigen::Matrix3d> rs(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = rs.matrixU() * rs.matrixV().transpose();
  if (R.determinant() < 0) R = -R;
  const Eigen::AngleAxisd aa(R);
  double pose[6];
  for (int i = 0; i < 3; ++i) pose[i] = aa.angle() * aa.axis()(i);
  for (int i = 0; i < 3; ++i) pose[3 + i] = scale * H(i, 2);
  ceres::Problem problem;
  for (int j = 0; j < m; ++j)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<OmnidirCornerCost, 2, 6>(
                                 new OmnidirCornerCost(k, pts[v.PointId(j)], v.corners[j])),
                             nullptr, pose);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 200;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &problem, &sum);
  if (sum.termination_type == ceres::FAILURE) return false;
  cv::Mat obj(m, 1, CV_64FC3), proj;
  for (int j = 0; j < m; ++j) obj.at<cv::Vec3d>(j) = cv::Vec3d(pts[v.PointId(j)].x(), pts[v.PointId(j)].y(), 0.0);
  cv::omnidir::projectPoints(obj, proj, cv::Vec3d(pose[0], pose[1], pose[2]), cv::Vec3d(pose[3], pose[4], pose[5]),
                             f.K, f.xi.at<double>(0), f.D);
  for (int j = 0; j < m; ++j) {
    const cv::Vec2d d = proj.at<cv::Vec2d>(j) - cv::Vec2d(v.corners[j].x(), v.corners[j].y());
    *s2 += d.dot(d);
    ++*n;
  }
  return true;
}

}  // namespace pano

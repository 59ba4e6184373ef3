// The peer users would pick instead of panocalib: OpenCV's
// cv::omnidir::calibrate (Mei's unified model: xi, fx, fy, skew, cx, cy,
// k1, k2, p1, p2), fitted by least squares to the same corners, and its
// Euclidean RMS reprojection error computed as panocalib computes its own.
// Header-only; whoever includes it links opencv_ccalib (Debian's OpenCV
// contrib). Used by bench/calibrate_compare.cc and tests/calibrate.
#pragma once

#include <opencv2/ccalib/omnidir.hpp>

#include <chrono>
#include <cmath>
#include <vector>

#include "panotrack/calibrate/calibrate.h"

namespace pano {

struct OmnidirFit {
  double rms_px = NAN;  // over the images omnidir kept
  int images_used = 0;  // omnidir drops images whose initialisation fails
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

}  // namespace pano

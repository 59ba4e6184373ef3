// Report image: residual vectors over one image, and per-image RMS bars.
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "panotrack/calibrate/calibrate.h"

namespace pano {

cv::Mat DrawReport(const CalibrationResult& r, const cv::Mat& image, int view_index) {
  const Sensor& s = r.calib.sensor;
  const int W = s.image_width, H = std::max(s.image_height, 360);
  const int panel = 420;
  cv::Mat canvas(H + 40, W + panel, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat left = canvas(cv::Rect(0, 40, W, s.image_height));
  if (!image.empty() && image.cols == W && image.rows == s.image_height) {
    cv::Mat grey = image;
    if (grey.channels() == 3) cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
    cv::Mat faded;
    grey.convertTo(faded, CV_8U, 0.6, 60);
    cv::cvtColor(faded, left, cv::COLOR_GRAY2BGR);
  } else {
    left.setTo(cv::Scalar(200, 200, 200));
  }
  // Mirror's visible disc and centre.
  const double limb = s.limb_radius();
  if (std::isfinite(limb) && limb < 4.0 * std::max(W, s.image_height))
    cv::ellipse(left, cv::Point2d(s.params.cx, s.params.cy), cv::Size2d(limb, limb * s.params.aspect), 0, 0, 360,
                cv::Scalar(255, 160, 0), 1, cv::LINE_AA);
  cv::drawMarker(left, cv::Point2d(s.params.cx, s.params.cy), cv::Scalar(255, 160, 0), cv::MARKER_CROSS, 12);
  const int vi = (view_index >= 0 && view_index < static_cast<int>(r.views.size())) ? view_index : 0;
  double max_res = 0.0;
  if (!r.views.empty())
    for (const Eigen::Vector2d& e : r.residuals[vi])
      if (std::isfinite(e.x())) max_res = std::max(max_res, e.norm());
  const double gain = max_res > 0 ? std::min(200.0, 25.0 / max_res) : 1.0;
  if (!r.views.empty()) {
    const BoardView& v = r.views[vi];
    for (size_t j = 0; j < v.corners.size(); ++j) {
      const cv::Point2d p(v.corners[j].x(), v.corners[j].y());
      cv::circle(left, p, 2, cv::Scalar(0, 160, 0), -1, cv::LINE_AA);
      const Eigen::Vector2d& e = r.residuals[vi][j];
      if (!std::isfinite(e.x())) continue;
      cv::line(left, p, p + cv::Point2d(gain * e.x(), gain * e.y()), cv::Scalar(0, 0, 230), 1, cv::LINE_AA);
    }
  }
  char text[256];
  std::snprintf(text, sizeof text, "%s: residuals x%.0f (red), corners (green)",
                r.views.empty() ? "-" : r.views[vi].file.c_str(), gain);
  cv::putText(canvas, text, cv::Point(8, 26), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);

  // Bars.
  cv::Mat right = canvas(cv::Rect(W, 0, panel, H + 40));
  std::snprintf(text, sizeof text, "per-image RMS (px), all %.3f", r.rms_px);
  cv::putText(right, text, cv::Point(10, 26), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  const int n = static_cast<int>(r.views.size());
  if (n > 0) {
    double vmax = r.rms_px;
    for (double v : r.image_rms) vmax = std::max(vmax, v);
    vmax *= 1.15;
    const int top = 50, bottom = H + 20, x0 = 150, x1 = panel - 20;
    const double bh = static_cast<double>(bottom - top) / n;
    for (int i = 0; i < n; ++i) {
      const int y = static_cast<int>(top + i * bh);
      const int len = static_cast<int>((x1 - x0) * r.image_rms[i] / vmax);
      const cv::Scalar col = i == vi ? cv::Scalar(0, 0, 200) : cv::Scalar(180, 120, 40);
      cv::rectangle(right, cv::Rect(x0, y + 2, std::max(1, len), std::max(2, static_cast<int>(bh) - 4)), col, -1);
      std::snprintf(text, sizeof text, "%.16s", r.views[i].file.c_str());
      const double fs = std::min(0.45, bh / 30.0);
      cv::putText(right, text, cv::Point(8, static_cast<int>(y + bh * 0.7)), cv::FONT_HERSHEY_SIMPLEX, fs,
                  cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
      std::snprintf(text, sizeof text, "%.3f", r.image_rms[i]);
      cv::putText(right, text, cv::Point(x0 + len + 3, static_cast<int>(y + bh * 0.7)), cv::FONT_HERSHEY_SIMPLEX,
                  fs, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    }
    const int xr = x0 + static_cast<int>((x1 - x0) * r.rms_px / vmax);
    cv::line(right, cv::Point(xr, top - 4), cv::Point(xr, bottom), cv::Scalar(0, 140, 0), 1);
  }
  return canvas;
}

}  // namespace pano

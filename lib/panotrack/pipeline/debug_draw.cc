#include "panotrack/pipeline/debug_draw.h"

#include <cmath>
#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <map>
#include <opencv2/imgproc.hpp>

#include "panotrack/core/error.h"
#include "panotrack/plot/figure.h"

namespace pano {

namespace {

std::string Printf(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string Printf(const char* fmt, ...) {
  char buf[256];
  va_list ap;
  va_start(ap, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  return buf;
}

// "found 3 of 9; most missed: <why>".
std::string FoundSummary(const FrameResult& fr) {
  int found = 0;
  std::map<std::string, int> why;
  for (const LandmarkMeasurement& m : fr.measurements) {
    found += m.found;
    if (!m.found && m.why && *m.why) ++why[m.why];
  }
  std::string s = Printf("found %d of %d", found, static_cast<int>(fr.measurements.size()));
  const auto most =
      std::max_element(why.begin(), why.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  if (most != why.end()) s += "; missed: " + most->first + Printf(" (%d)", most->second);
  return s;
}

}  // namespace

std::string LostReason(const FrameResult& fr, const LocalizerOptions& opt) {
  if (fr.row.status != PoseStatus::kLost) return "";
  const TriangulationResult& tri = fr.triangulation;
  if (fr.unconfirmed)
    return Printf("relocalised pose held for the next frame to confirm (%d inliers)",
                  static_cast<int>(tri.inliers.size()));
  if (fr.withheld)
    return Printf("no velocity to check it, and one bearing left out could move it beyond the alert limit "
                  "(%d inliers; tracked on from it)",
                  static_cast<int>(tri.inliers.size()));
  if (fr.predicted.empty()) return "no landmark predicted (no pose to track from, or none in view)";
  if (!tri.ok) return (tri.failure.empty() ? std::string("no pose") : tri.failure) + "; " + FoundSummary(fr);
  const double deg = 180 / M_PI;
  if (tri.rms_bearing > opt.max_rms_bearing)
    return Printf("bearing RMS %.2f > %.2f deg", tri.rms_bearing * deg, opt.max_rms_bearing * deg);
  const double n_pred = static_cast<double>(fr.predicted.size());
  if (n_pred >= 8 && tri.inliers.size() < opt.min_inlier_fraction * n_pred)
    return Printf("%d inliers of %d predicted (< %.0f %%)", static_cast<int>(tri.inliers.size()),
                  static_cast<int>(n_pred), 100 * opt.min_inlier_fraction);
  const IntegrityReport& in = fr.integrity;
  if (!in.testable) return Printf("integrity: no spare bearing to check (%d inliers)", in.inliers);
  if (!in.consistent) return Printf("integrity: residuals inconsistent (chi2 %.1f > %.1f)", in.chi2, in.chi2_threshold);
  if (in.quality < opt.min_quality) return Printf("integrity: quality %.2f < %.2f", in.quality, opt.min_quality);
  if (!in.within_alert_limit)
    return Printf("integrity: protection level %.3g > alert limit %.3g", in.protection_level, in.alert_limit);
  if (fr.innovation > opt.gate_chi2)
    return Printf("motion gate: innovation %.1f > %.1f, too few inliers to override", fr.innovation, opt.gate_chi2);
  return "relocalised pose not confirmed by this frame";
}

void DrawDebug(const cv::Mat& grey, const Sensor& s, const FrameResult& fr, cv::Mat* out) {
  const int header = kDebugHeaderHeight;
  out->create(grey.rows + header, grey.cols, CV_8UC3);
  out->setTo(cv::Scalar(32, 32, 32));
  cv::Mat image = (*out)(cv::Rect(0, header, grey.cols, grey.rows));
  cv::cvtColor(grey, image, cv::COLOR_GRAY2BGR);
  auto pt = [](const Eigen::Vector2d& p) { return cv::Point2d(p.x(), p.y()); };
  LabelPlacer placer(cv::Rect(0, 0, image.cols, image.rows));
  for (size_t i = 0; i < fr.predicted.size() && i < fr.measurements.size(); ++i) {
    const PredictedLandmark& p = fr.predicted[i];
    const LandmarkMeasurement& m = fr.measurements[i];
    DrawLine(&image, pt(s.from_polar(p.corner_radius, p.azimuth)), pt(s.from_polar(p.v_radius, p.azimuth)),
             cv::Scalar(0, 200, 255));
    for (const Eigen::Vector2d& q : m.edge_points) cv::circle(image, pt(q), 1, cv::Scalar(0, 220, 0), cv::FILLED);
  }
  // Markers first (reserved), then the labels around them.
  std::vector<std::pair<cv::Point2d, const PredictedLandmark*>> found;
  for (size_t i = 0; i < fr.predicted.size() && i < fr.measurements.size(); ++i) {
    const PredictedLandmark& p = fr.predicted[i];
    const LandmarkMeasurement& m = fr.measurements[i];
    if (m.found) {
      const cv::Point2d j = pt(s.from_polar(m.radius, m.azimuth));
      cv::drawMarker(image, j, cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 9, 1);
      placer.ReservePoint(j, 5);
      found.emplace_back(j, &p);
    } else {
      cv::drawMarker(image, pt(p.corner_px), cv::Scalar(0, 128, 255), cv::MARKER_TILTED_CROSS, 7, 1);
      placer.ReservePoint(pt(p.corner_px), 4);
    }
  }
  const TextStyle label{cv::FONT_HERSHEY_SIMPLEX, 0.33, 1, cv::Scalar(255, 255, 0), 1, cv::Scalar(0, 0, 0)};
  for (const auto& [j, p] : found)
    if (p->landmark) placer.Place(&image, p->landmark->id, j, label, 5);

  // Header: frame, time and status; the pose (or why lost); the legend.
  const PoseRow& r = fr.row;
  const TextStyle text{cv::FONT_HERSHEY_SIMPLEX, 0.42, 1, cv::Scalar(235, 235, 235)};
  const cv::Scalar status_colour = r.status == PoseStatus::kOk     ? cv::Scalar(90, 210, 90)
                                   : r.status == PoseStatus::kLost ? cv::Scalar(80, 80, 255)
                                                                   : cv::Scalar(60, 200, 230);
  std::string status = r.status == PoseStatus::kOk ? "OK" : r.status == PoseStatus::kLost ? "LOST" : "INIT";
  if (fr.relocalized) status += fr.unconfirmed ? " (relocalised, unconfirmed)" : " (relocalised)";
  const cv::Rect f = DrawText(out, Printf("frame %d   t %.2f s", r.frame, r.time_s), {8, 5}, Anchor::kTopLeft, text);
  TextStyle status_style = text;
  status_style.colour = status_colour;
  const cv::Rect st = DrawText(out, status, {f.x + f.width + 14.0, 5}, Anchor::kTopLeft, status_style);
  const std::string counts = r.status == PoseStatus::kLost
                                 ? Printf("%d landmarks found", r.n_landmarks)
                                 : Printf("%d landmarks   residual %.3g", r.n_landmarks, r.residual);
  DrawText(out, counts, {st.x + st.width + 14.0, 5}, Anchor::kTopLeft, text);
  std::string second;
  TextStyle second_style = text;
  if (r.status == PoseStatus::kLost) {
    second = "why: " + LostReason(fr);
    second_style.colour = cv::Scalar(120, 170, 255);
  } else {
    second = Printf("x %.3f  y %.3f  heading %.2f deg", r.pose.x, r.pose.y, r.pose.theta * 180 / M_PI);
    if (r.extra.size() >= 3 && std::isfinite(r.extra[0]))
      second += Printf("   std %.3g, %.3g, %.3g deg", r.extra[0], r.extra[1], r.extra[2] * 180 / M_PI);
  }
  // Shrink a long line rather than cut it.
  while (second_style.scale > 0.3 && TextBox(second, {0, 0}, Anchor::kTopLeft, second_style).width > out->cols - 16)
    second_style.scale -= 0.02;
  DrawText(out, second, {8, 22}, Anchor::kTopLeft, second_style);
  // Legend of the marks.
  const TextStyle legend{cv::FONT_HERSHEY_SIMPLEX, 0.33, 1, cv::Scalar(190, 190, 190)};
  double x = 8;
  const double y = header - 10;
  auto key = [&](const cv::Scalar& c, int kind, const std::string& what) {
    if (kind == 0) DrawLine(out, {x, y}, {x + 12, y}, c);
    if (kind == 1) cv::circle(*out, cv::Point(int(x) + 6, int(y)), 1, c, cv::FILLED);
    if (kind == 2) cv::drawMarker(*out, cv::Point(int(x) + 6, int(y)), c, cv::MARKER_CROSS, 7, 1);
    if (kind == 3) cv::drawMarker(*out, cv::Point(int(x) + 6, int(y)), c, cv::MARKER_TILTED_CROSS, 7, 1);
    const cv::Rect b = DrawText(out, what, {x + 16, y}, Anchor::kLeft, legend);
    x = b.x + b.width + 12;
  };
  key(cv::Scalar(0, 200, 255), 0, "predicted edge");
  key(cv::Scalar(0, 220, 0), 1, "edge points");
  key(cv::Scalar(0, 0, 255), 2, "junction");
  key(cv::Scalar(0, 128, 255), 3, "not found");
}

DebugVideo::DebugVideo(const std::string& path, cv::Size size, double fps) : file_(path) {
  const cv::Size annotated(size.width, size.height + kDebugHeaderHeight);
  if (!writer_.open(file_.temp_path(), opencv_io::fourcc('a', 'v', 'c', '1'), fps, annotated, true) &&
      !writer_.open(file_.temp_path(), opencv_io::fourcc('m', 'p', '4', 'v'), fps, annotated, true))
    throw Error(path + ": cannot open a video writer");
}

void DebugVideo::Write(const cv::Mat& grey, const Sensor& sensor, const FrameResult& fr) {
  DrawDebug(grey, sensor, fr, &annotated_);
  writer_.write(annotated_);
}

void DebugVideo::Commit() {
  writer_.release();
  file_.Commit();
}

}  // namespace pano

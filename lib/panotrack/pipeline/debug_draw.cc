#include "panotrack/pipeline/debug_draw.h"

#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "panotrack/core/error.h"

namespace pano {

void DrawDebug(const cv::Mat& grey, const Sensor& s, const FrameResult& fr, cv::Mat* out) {
  cv::cvtColor(grey, *out, cv::COLOR_GRAY2BGR);
  auto pt = [](const Eigen::Vector2d& p) { return cv::Point2d(p.x(), p.y()); };
  for (size_t i = 0; i < fr.predicted.size(); ++i) {
    const PredictedLandmark& p = fr.predicted[i];
    const LandmarkMeasurement& m = fr.measurements[i];
    cv::line(*out, pt(s.from_polar(p.corner_radius, p.azimuth)), pt(s.from_polar(p.v_radius, p.azimuth)),
             cv::Scalar(0, 200, 255), 1, cv::LINE_AA);
    for (const Eigen::Vector2d& q : m.edge_points)
      cv::circle(*out, pt(q), 1, cv::Scalar(0, 220, 0), cv::FILLED);
    if (m.found) {
      const Eigen::Vector2d j = s.from_polar(m.radius, m.azimuth);
      cv::drawMarker(*out, pt(j), cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 9, 1);
      cv::putText(*out, p.landmark->id, pt(j) + cv::Point2d(4, -4), cv::FONT_HERSHEY_PLAIN, 0.7,
                  cv::Scalar(255, 255, 0), 1, cv::LINE_AA);
    } else {
      cv::drawMarker(*out, pt(p.corner_px), cv::Scalar(0, 128, 255), cv::MARKER_TILTED_CROSS, 5, 1);
    }
  }
  char buf[128];
  std::snprintf(buf, sizeof buf, "frame %d  %s  %d landmarks", fr.row.frame,
                pose_status_name(fr.row.status), fr.row.n_landmarks);
  cv::putText(*out, buf, cv::Point(6, 16), cv::FONT_HERSHEY_PLAIN, 1.0, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
}

DebugVideo::DebugVideo(const std::string& path, cv::Size size, double fps) : file_(path) {
  if (!writer_.open(file_.temp_path(), cv::VideoWriter::fourcc('a', 'v', 'c', '1'), fps, size, true) &&
      !writer_.open(file_.temp_path(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size, true))
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

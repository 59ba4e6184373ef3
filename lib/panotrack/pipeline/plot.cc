#include "panotrack/pipeline/plot.h"

#include <Eigen/Core>

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"

namespace pano {

void WritePlot(const std::string& path, const Map& map, const std::vector<PoseRow>& est,
               const std::vector<PoseRow>& gt) {
  Eigen::Vector2d lo, hi;
  double top;
  map.Extent(&lo, &hi, &top);
  for (const auto& r : est)
    if (r.status != PoseStatus::kLost) {
      lo = lo.cwiseMin(Eigen::Vector2d(r.pose.x, r.pose.y));
      hi = hi.cwiseMax(Eigen::Vector2d(r.pose.x, r.pose.y));
    }
  const int size = 800, margin = 40;
  const double scale = (size - 2 * margin) / std::max(hi.x() - lo.x(), hi.y() - lo.y());
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(255, 255, 255));
  auto P = [&](double x, double y) {
    return cv::Point2d(margin + (x - lo.x()) * scale, size - margin - (y - lo.y()) * scale);
  };
  if (map.room.present)
    cv::rectangle(img, P(map.room.min.x(), map.room.min.y()), P(map.room.max.x(), map.room.max.y()),
                  cv::Scalar(120, 120, 120), 2);
  for (const auto& r : map.rectangles)
    cv::line(img, P(r.from.x(), r.from.y()), P(r.to.x(), r.to.y()), cv::Scalar(40, 40, 40), 3);
  for (const auto& b : map.boxes)
    cv::rectangle(img, P(b.min.x(), b.min.y()), P(b.max.x(), b.max.y()), cv::Scalar(60, 60, 160), 2);
  auto draw = [&](const std::vector<PoseRow>& rows, const cv::Scalar& colour, int radius) {
    cv::Point2d last(-1, -1);
    for (const auto& r : rows) {
      if (r.status == PoseStatus::kLost) {
        last = cv::Point2d(-1, -1);
        continue;
      }
      const cv::Point2d p = P(r.pose.x, r.pose.y);
      if (last.x >= 0) cv::line(img, last, p, colour, 1, cv::LINE_AA);
      cv::circle(img, p, radius, colour, cv::FILLED, cv::LINE_AA);
      last = p;
    }
  };
  draw(gt, cv::Scalar(0, 160, 0), 3);
  draw(est, cv::Scalar(200, 60, 0), 2);
  cv::putText(img, "estimate (blue), ground truth (green), units: " + map.units, cv::Point(margin, 24),
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  AtomicFile f(path);
  if (!cv::imwrite(f.temp_path(), img)) throw Error(path + ": cannot write the plot");
  f.Commit();
}

}  // namespace pano

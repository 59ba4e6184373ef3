// panoloc's debug video: each frame annotated like the paper's Fig. 7, under
// a header band with the pose, its residual and, on a lost frame, why.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include "panotrack/video/opencv_io.h"
#include <string>

#include "panotrack/core/atomic_file.h"
#include "panotrack/track/localizer.h"

namespace pano {

// Why the localiser did not report a pose for this frame, in words (e.g.
// "too few landmarks (3 < 4)", "motion gate: innovation 35.2 > 21.1",
// "integrity: protection level 2.1 > alert limit 0.9"), derived from the
// result's fields in the order the localiser tests them; `options` gives the
// thresholds it ran with. Empty when the frame has a pose.
std::string LostReason(const FrameResult& fr, const LocalizerOptions& options = LocalizerOptions());

// Height (px) of the header band DrawDebug puts above the frame.
constexpr int kDebugHeaderHeight = 56;

// The frame (grey) below a header band (frame, time, status, pose, residual,
// or the reason a frame was lost), with the predicted edges (yellow), found
// edge points (green), junctions (red crosses) with their landmark ids placed
// so that they do not overlap, and landmarks not found (orange).
// `out` is BGR, grey.cols x (grey.rows + kDebugHeaderHeight).
void DrawDebug(const cv::Mat& grey, const Sensor& sensor, const FrameResult& fr, cv::Mat* out);

// An annotated video (frames of DrawDebug) written to a temporary file beside
// `path` and moved into place by Commit(); destroyed without Commit(), it
// removes the temporary. `size` is the input frames' size.
class DebugVideo {
 public:
  DebugVideo(const std::string& path, cv::Size size, double fps);
  void Write(const cv::Mat& grey, const Sensor& sensor, const FrameResult& fr);
  void Commit();

 private:
  AtomicFile file_;
  opencv_io::VideoWriter writer_;  // declared after file_: released before the temporary is removed
  cv::Mat annotated_;
};

}  // namespace pano

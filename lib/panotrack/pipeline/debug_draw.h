// panoloc's debug video: each frame annotated like the paper's Fig. 7.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <string>

#include "panotrack/core/atomic_file.h"
#include "panotrack/track/localizer.h"

namespace pano {

// Predicted edges (yellow), found edge points (green), junctions (red
// crosses) with their landmark ids, and the frame's status.
void DrawDebug(const cv::Mat& grey, const Sensor& sensor, const FrameResult& fr, cv::Mat* out);

// An annotated video written to a temporary file beside `path` and moved
// into place by Commit(); destroyed without Commit(), it removes the
// temporary.
class DebugVideo {
 public:
  DebugVideo(const std::string& path, cv::Size size, double fps);
  void Write(const cv::Mat& grey, const Sensor& sensor, const FrameResult& fr);
  void Commit();

 private:
  AtomicFile file_;
  cv::VideoWriter writer_;  // declared after file_: released before the temporary is removed
  cv::Mat annotated_;
};

}  // namespace pano

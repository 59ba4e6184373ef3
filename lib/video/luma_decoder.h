// Decodes a video's luma plane straight from FFmpeg's decoder. panoloc works
// on grey frames: taking Y skips the YUV -> BGR conversion that OpenCV's
// VideoCapture does for every frame and the BGR -> grey conversion after it,
// which together cost about as much as decoding a small H.264 frame. Videos
// whose pixel format has no luma plane are left to cv::VideoCapture.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>

namespace pano {

class LumaDecoder {
 public:
  LumaDecoder();
  ~LumaDecoder();
  LumaDecoder(const LumaDecoder&) = delete;
  LumaDecoder& operator=(const LumaDecoder&) = delete;

  // False (with the reason) when the file cannot be opened this way; the
  // caller then falls back to cv::VideoCapture.
  bool Open(const std::string& path, std::string* reason);
  // Next frame's luma as CV_8UC1 (reusing *grey's buffer); false at the end.
  bool Read(cv::Mat* grey);
  double fps() const { return fps_; }
  long frame_count() const { return frame_count_; }  // -1 when unknown

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double fps_ = 0.0;
  long frame_count_ = -1;
};

// True when this build can decode luma planes directly (FFmpeg found).
bool LumaDecoderAvailable();

}  // namespace pano

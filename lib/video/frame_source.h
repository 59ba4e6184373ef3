// Frames from a video file, a folder of images (sorted by name) or a printf
// pattern ("frames/frame_%04d.png"), converted to 8-bit grey, decoded ahead
// on a thread of their own so that decoding overlaps tracking. Video files
// are decoded to their luma plane directly where FFmpeg allows
// (LumaDecoder), else through cv::VideoCapture.
#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <thread>
#include <vector>

#include "video/luma_decoder.h"

namespace pano {

class FrameSource {
 public:
  // Opens the input and reads its first frame; throws pano::Error naming the
  // path when it cannot be opened or holds no frame. Decoding runs ahead by
  // up to `prefetch_bytes` of frames (at least 8), so that it goes on while
  // the tracker starts up.
  explicit FrameSource(const std::string& path, size_t prefetch_bytes = size_t(64) << 20);
  ~FrameSource();
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  // True for inputs that are read as they arrive and have no known length:
  // "-" (standard input), camera devices (/dev/video0), stream URLs
  // (rtsp://, udp://...).
  static bool IsLive(const std::string& path);

  // Number of frames of an input without decoding it; -1 when unknown or
  // unreadable (for a progress display).
  static int FrameCount(const std::string& path);

  // Next frame; false at the end. Throws pano::Error for a frame that cannot
  // be decoded in a folder of images.
  bool Read(cv::Mat* grey);
  // The same, with the frame's presentation time in seconds from the
  // video's timestamps (NaN when the input has none, e.g. image folders).
  bool Read(cv::Mat* grey, double* time_s);
  int width() const { return width_; }
  int height() const { return height_; }
  double fps() const { return fps_; }    // 0 when unknown (image folders)
  int frame_count() const { return count_; }  // -1 when unknown

 private:
  bool ReadDirect(cv::Mat* frame);  // the next frame as decoded
  void Decode();
  std::string path_;
  std::unique_ptr<LumaDecoder> luma_;  // video files with a luma plane
  cv::VideoCapture capture_;           // other videos and printf patterns
  std::vector<std::string> files_;  // folder input
  size_t next_file_ = 0;
  long frames_read_ = 0;  // frames handed out by Read()
  int width_ = 0, height_ = 0, count_ = -1;
  double fps_ = 0.0;
  cv::Mat first_;
  // Prefetch queue.
  int capacity_;
  std::thread worker_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<cv::Mat> queue_;  // decoded frames, converted to grey by Read()
  // Buffers handed back by Read() for the decoder to fill again: a fresh
  // frame-sized allocation per frame costs page faults on every frame.
  std::vector<cv::Mat> free_;
  bool done_ = false, stop_ = false;
  std::string error_;
};

}  // namespace pano

// Frames from a video file, a folder of images (sorted by name), a printf
// pattern ("frames/frame_%04d.png"), standard input ("-"), a camera
// (/dev/video0) or a stream URL (rtsp://, udp://, http://...), converted to
// 8-bit grey, decoded ahead on a thread of their own (or, for a file decoded
// two groups of pictures at a time, on the decoders' threads) so that
// decoding overlaps tracking. Videos and streams are decoded to their luma plane
// directly where FFmpeg allows (LumaDecoder), else through cv::VideoCapture;
// cameras through cv::VideoCapture's V4L2 backend.
//
// An input that ends early or holds damaged data is an error, not a short
// success: Read() hands out every frame decoded before the problem, then
// throws pano::Error "<input>: decode error at frame N: <why>" (N counts from
// 0: the frames before it were handed out; the reasons are listed in
// luma_decoder.h, plus "truncated or damaged file (container lists 62
// frames)" on the cv::VideoCapture path and "camera stopped delivering
// frames" for cameras).
#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>  // its property and API constants
#include <string>
#include <thread>
#include <vector>

#include "panotrack/core/output_check.h"
#include "panotrack/video/luma_decoder.h"
#include "panotrack/video/opencv_io.h"

namespace pano {

struct FrameSourceOptions {
  // Decoding runs ahead by up to this many bytes of frames (at least 8
  // frames), so that it goes on while the tracker starts up or works
  // through a costly frame. Also the bound on the memory that frames
  // waiting take, which a long run reaches sooner or later: 16 MiB (64
  // frames of 500 x 500) runs as fast as 64 MiB did, and keeps memory flat.
  size_t prefetch_bytes = size_t(16) << 20;
  // A stream (IsLive) that delivers no data for this long fails with "no
  // data for ... s", at opening or later.
  double live_timeout_s = 10.0;
  // FFmpeg's decoding threads for videos and streams; 0: FFmpeg's choice
  // (a thread per core, and one more).
  int decoder_threads = 0;
  // Files whose groups of pictures fit in this many bytes of luma planes
  // are decoded two groups at a time (LumaDecoder::Open), which spares the
  // frame threads' per-frame hand-over: a sixth less decoding CPU on a
  // cheap stream. A group's frames wait in memory; 0: never.
  size_t gop_parallel_bytes = size_t(128) << 20;
  // Videos and streams decoded on the CPU, or on an NVIDIA GPU's NVDEC
  // (LumaDecoderOptions::hardware). With kCuda, an input NVDEC cannot
  // decode is an error; other inputs (image folders, cameras) ignore it.
  HardwareDecoding hardware = HardwareDecoding::kNone;
};

class FrameSource {
 public:
  // Opens the input and reads its first frame; throws pano::Error naming the
  // input when it cannot be opened or holds no frame.
  explicit FrameSource(const std::string& path, const FrameSourceOptions& options = {});
  ~FrameSource();
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  // True for inputs that are read as they arrive and have no known length:
  // "-" (standard input), camera devices (/dev/video0), stream URLs
  // (rtsp://, udp://...).
  static bool IsLive(const std::string& path);

  // The files the input reads, for the output guard (CheckOutputsDistinct):
  // the input itself under `option`, and for a folder or pattern input each
  // of its images, as "a frame of <input>". Live inputs are not opened.
  static NamedPaths InputReads(const std::string& path, const std::string& option = "");

  // Number of frames of an input as its container lists it, without
  // decoding; -1 when unknown or unreadable (for a progress display). Live
  // inputs are not opened: -1.
  static int FrameCount(const std::string& path);

  // Throws pano::Error naming `path` when it is a PNG file cut short (a copy
  // or a download that stopped): its last chunk, IEND, is not in its last
  // 64 KiB. libpng would otherwise print its own "libpng error: Read Error"
  // on stderr from inside the decoder. Other files pass unread but for 8
  // bytes.
  static void CheckImageComplete(const std::string& path);

  // Next frame; false at the clean end. Throws pano::Error for a frame that
  // cannot be decoded or an input that ends before its container says.
  // Frames are not copied out: *grey may share the decoder's buffer (rows
  // `step` bytes apart, not necessarily continuous). Read it, never write it
  // (clone() for a frame to draw on).
  bool Read(cv::Mat* grey);
  // The same, with the frame's presentation time in seconds from the first
  // frame's, from the video's timestamps (variable frame rates included);
  // NaN for image folders and patterns.
  bool Read(cv::Mat* grey, double* time_s);
  int width() const { return width_; }
  int height() const { return height_; }
  double fps() const { return fps_; }         // 0 when unknown (image folders)
  int frame_count() const { return count_; }  // -1 when unknown (and for live inputs)
  // Frames decoded and waiting for Read(): how far the consumer lags.
  int frames_waiting();
  int prefetch_frames() const { return capacity_; }  // the most that wait
  // Decoding two groups of pictures at a time (gop_parallel_bytes).
  bool gop_parallel() const { return luma_ && luma_->gop_parallel(); }
  // Decoding on NVDEC (FrameSourceOptions::hardware).
  bool hardware_decoding() const { return luma_ && luma_->hardware(); }

 private:
  struct Frame {
    cv::Mat image;  // as decoded
    double time_s;
  };
  void OpenVideo(const FrameSourceOptions& options);
  void OpenCamera();
  bool ReadDirect(Frame* frame);  // the next frame as decoded
  bool ReadCapture(Frame* frame);
  void Decode();
  std::string path_, name_;            // name_: how errors name the input
  std::unique_ptr<LumaDecoder> luma_;  // videos and streams with a luma plane
  opencv_io::VideoCapture capture_;    // other videos, and cameras
  bool camera_ = false;
  long captured_ = 0;           // frames read through capture_
  long capture_expected_ = -1;  // frames capture_ must deliver; -1 unknown
  double first_capture_ms_ = 0.0;
  std::vector<std::string> files_;  // folder or pattern input
  size_t next_file_ = 0;
  int width_ = 0, height_ = 0, count_ = -1;
  double fps_ = 0.0;
  Frame first_;  // read by the constructor, already grey
  bool have_first_ = false;
  // Prefetch queue.
  int capacity_;
  std::thread worker_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Frame> queue_;  // decoded frames; Read() converts those not grey yet
  // Buffers handed back by Read() for the decoder to fill again: a fresh
  // frame-sized allocation per frame costs page faults on every frame.
  std::vector<cv::Mat> free_;
  bool done_ = false, stop_ = false;
  std::string error_;
};

}  // namespace pano

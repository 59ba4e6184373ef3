// Decodes a video's luma plane straight from FFmpeg's decoder. panoloc works
// on grey frames: taking Y skips the YUV -> BGR conversion that OpenCV's
// VideoCapture does for every frame and the BGR -> grey conversion after it,
// which together cost about as much as decoding a small H.264 frame. Videos
// whose pixel format has no luma plane are left to cv::VideoCapture.
//
// A frame that cannot be decoded is an error, not the end: Read() throws
// pano::Error "<input>: decode error at frame N: <why>" once the frames
// decoded before it are out, where <why> is one of
//   truncated file (container lists 62 frames)
//   truncated file (its last packet is cut short)
//   truncated or damaged file (container lists 2.48 s, data ends at 1.00 s)
//   damaged packet in the container
//   damaged frame (the decoder concealed errors in it)
//   corrupt data (<FFmpeg's error text>)
//   read failed (<FFmpeg's error text>)
//   no data for 10 s
//   pixel format <name> has no 8-bit luma plane
//   NVDEC cannot decode this stream (<codec>, <width> x <height>)
//   NVDEC: CUDA copy failed (error <code>)
// and Open() gives "NVDEC: <why>" when NVDEC, demanded, cannot be set up
// (no device or driver: FFmpeg's words; "built without CUDA").
//
// A damaged file gives the same frames and the same error every time,
// whatever the threads: those of one decoding thread, or in GOP mode (see
// LumaDecoderOptions::gop_parallel_bytes) of one decoding thread per group
// of pictures (where the damage is in the IDR picture that starts a group,
// every frame of the group before it comes out, of which one decoder alone
// may keep the last back). FFmpeg's frame threads decode the same pixels,
// but flag a damaged frame only now and then; so once a decoder reports
// damage (logging.h: CountDecoderDamage), a file decoded on frame threads
// is decoded again without them from its start, and goes on from the frames
// handed out. Streams and standard input, which cannot be read twice, keep
// their threads.
#pragma once

#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace pano {

// Where videos are decoded.
enum class HardwareDecoding {
  kNone,  // on the CPU (FFmpeg's software decoders)
  kCuda,  // on an NVIDIA GPU's video engine (NVDEC, through FFmpeg's CUDA hwaccel); an error where it cannot
  kAuto,  // NVDEC where a device is present and FFmpeg has a hwaccel for the codec, else the CPU
};
// From its name: "none", "cuda" or "auto"; throws pano::Error for others.
HardwareDecoding ParseHardwareDecoding(const std::string& name);

struct LumaDecoderOptions {
  // With io_timeout_s > 0 (streams), opening and every wait for data give
  // up after that long instead of blocking for ever.
  double io_timeout_s = 0.0;
  // FFmpeg's decoding threads; 0: FFmpeg's choice (a thread per core, and
  // one more). NVDEC decodes with one.
  int num_threads = 0;
  // With gop_parallel_bytes > 0 and at least two threads, a file whose
  // index shows groups of pictures whose luma planes fit in that many bytes
  // (H.264 or HEVC as MP4 or MOV hold them) is decoded on the CPU two groups
  // at a time, each by its own decoder with half the threads
  // (gop_parallel(); the last groups, where two decoders would share them
  // unevenly, by one with all the threads: gop_tail()); the frames come out
  // the same, in order, as packed copies of their luma planes that wait for
  // Read().
  size_t gop_parallel_bytes = 0;
  // NVDEC decodes into the GPU's memory; the luma plane alone comes to the
  // host, into page-locked buffers: the same bytes as the CPU's decoder
  // gives (H.264 and HEVC decoding is exact). Needs a build with CUDA.
  // Streams NVDEC refuses (4:4:4 H.264, 10-bit) fail with kCuda, and with
  // kAuto are decoded on one CPU thread. NVDEC conceals no errors, so a
  // damaged frame is not told apart as the CPU's decoder tells it.
  HardwareDecoding hardware = HardwareDecoding::kNone;
  // With gop_parallel() and two or three threads (one for each of the two
  // decoders): the last groups of pictures may go to a decoder with all the
  // threads (gop_tail()); false: the two decoders take them all.
  bool gop_tail = true;
};

class LumaDecoder {
 public:
  LumaDecoder();
  ~LumaDecoder();
  LumaDecoder(const LumaDecoder&) = delete;
  LumaDecoder& operator=(const LumaDecoder&) = delete;

  // False (with the reason) when the input cannot be decoded this way; when
  // container_opened() the caller can fall back to cv::VideoCapture (not
  // with HardwareDecoding::kCuda, which cv::VideoCapture cannot give). "-"
  // is standard input.
  bool Open(const std::string& path, std::string* reason, const LumaDecoderOptions& options = {});
  // Next frame's luma as CV_8UC1 and, when time_s is given, its presentation
  // time in seconds from the first frame's; false at the clean end (or after
  // Abort()). Throws pano::Error as above. Not a copy: *grey shares the
  // decoder's buffer (rows `step` bytes apart, usually not continuous), which
  // returns to the decoder when the last cv::Mat sharing it is released. The
  // decoder may still predict later frames from it (or, with GOP-parallel
  // decoding, fill it again once released): read it, never write it.
  bool Read(cv::Mat* grey, double* time_s = nullptr);
  // From another thread: makes a Read() blocked on input return false.
  void Abort();
  double fps() const { return fps_; }
  // Frames the container lists; -1 when unknown. Set as soon as the
  // container is open, also when Open() then declines the pixel format.
  long frame_count() const { return frame_count_; }
  bool container_opened() const { return container_opened_; }
  // Decoding two groups of pictures at a time (see Open); Read() then
  // takes frames that wait decoded, without blocking while any do.
  bool gop_parallel() const;
  // With gop_parallel(): the frames decoded, in order, waiting for Read().
  int frames_waiting();
  // With gop_parallel(): the last groups of pictures go to a third decoder
  // with all the threads, one after another, where the two would share
  // them unevenly (detail::FirstTailSegment, from the container's index).
  bool gop_tail() const;
  // Decoding on NVDEC (HardwareDecoding::kCuda, or kAuto where it could).
  bool hardware() const;

 private:
  struct Impl;
  bool ReadDecoded(cv::Mat* grey, double* time_s);
  void RedecodeWithoutFrameThreads();

  // Replaced by RedecodeWithoutFrameThreads() on the reading thread while Abort()
  // or frames_waiting() may come from another: impl_mu_ guards the swap.
  std::unique_ptr<Impl> impl_;
  mutable std::mutex impl_mu_;
  bool aborted_ = false;
  std::string path_;
  LumaDecoderOptions options_;
  bool gop_ = false;  // as opened: Read() is called on the consumer's thread
  double fps_ = 0.0;
  long frame_count_ = -1;
  bool container_opened_ = false;
};

// True when this build can decode luma planes directly (FFmpeg found).
bool LumaDecoderAvailable();

// How errors name an input: "standard input" for "-", else the path itself.
std::string InputName(const std::string& path);

namespace detail {

// GOP mode's decoders, each on a segment of its own.
constexpr int kGopDecoderCount = 2;
// Where the segments of a stream (their decoding costs, in order) split
// unevenly between GOP mode's decoders (an odd count, a short last one),
// the last of them are better decoded one after another by a decoder with
// all the threads: the first such segment, or -1 where none is.
long FirstTailSegment(const std::vector<double>& segment_costs);

}  // namespace detail

}  // namespace pano

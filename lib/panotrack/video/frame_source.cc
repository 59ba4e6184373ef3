#include "panotrack/video/frame_source.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>

#include "panotrack/core/error.h"
#include "panotrack/video/logging.h"

namespace pano {

namespace fs = std::filesystem;

namespace {
bool IsImageFile(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".bmp" ||
         ext == ".tif" || ext == ".tiff" || ext == ".ppm";
}

bool IsCamera(const std::string& path) { return path.rfind("/dev/video", 0) == 0; }

// A file whose name holds a '%' is a file.
bool IsPattern(const std::string& path) {
  std::error_code ec;
  return !FrameSource::IsLive(path) && path.find('%') != std::string::npos && !fs::exists(path, ec);
}

// The files of a printf pattern with one integer conversion
// ("frames/f_%04d.png"): consecutive numbers from 0 or 1 (as OpenCV's image
// sequences) while the files exist.
std::vector<std::string> ExpandPattern(const std::string& pattern) {
  static const std::regex one_conversion("[^%]*%0?[0-9]*d[^%]*");
  if (!std::regex_match(pattern, one_conversion))
    throw Error(pattern + ": unsupported pattern (one %d conversion expected, e.g. frame_%04d.png)");
  std::vector<std::string> files;
  std::vector<char> name(pattern.size() + 32);
  std::error_code ec;
  for (int i = 0;; ++i) {
    std::snprintf(name.data(), name.size(), pattern.c_str(), i);
    if (!fs::exists(name.data(), ec)) {
      if (i == 0) continue;  // numbering may start at 1
      break;
    }
    files.emplace_back(name.data());
  }
  return files;
}

// The image files of a folder, sorted by name; throws std::filesystem's
// error for a folder or an entry that cannot be examined.
std::vector<std::string> FolderImages(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && IsImageFile(e.path())) files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

// Frames that are 8-bit grey already are handed out as they are, sharing
// their buffer (the decoder's own for LumaDecoder's frames): no copy.
bool IsGrey(const cv::Mat& image) { return image.type() == CV_8UC1; }

void ToGrey(const cv::Mat& in, cv::Mat* out) {
  if (in.channels() == 3) cv::cvtColor(in, *out, cv::COLOR_BGR2GRAY);
  else if (in.channels() == 4) cv::cvtColor(in, *out, cv::COLOR_BGRA2GRAY);
  else in.copyTo(*out);  // into *out's buffer when it has the size already
  // A camera's full range to 8 bits: 16-bit values by their high byte (as
  // cv_bridge does), floating point ones as 0 - 1.
  const int depth = out->depth();
  if (depth == CV_16U || depth == CV_16S) out->convertTo(*out, CV_8U, 1.0 / 256);
  else if (depth == CV_32F || depth == CV_64F) out->convertTo(*out, CV_8U, 255.0);
  else if (depth != CV_8U) out->convertTo(*out, CV_8U);
}

// A frame handed out as decoded has waited in the prefetch queue and left
// the CPU caches: one sequential read of each cache line brings it back at
// memory bandwidth, where the tracker's scattered reads would each wait for
// memory.
void BringIntoCache(const cv::Mat& image) {
  constexpr int kCacheLine = 64;
  unsigned sum = 0;
  for (int y = 0; y < image.rows; ++y) {
    const uchar* row = image.ptr<uchar>(y);
    for (int x = 0; x < image.cols; x += kCacheLine) sum += row[x];
  }
  asm volatile("" : : "r"(sum));  // the reads are the point: keep them
}

std::string DecodeError(const std::string& name, long frame, const std::string& why) {
  return name + ": decode error at frame " + std::to_string(frame) + ": " + why;
}
}  // namespace

void FrameSource::CheckImageComplete(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char signature[8];
  if (!in.read(signature, 8) || std::memcmp(signature, "\x89PNG\r\n\x1a\n", 8) != 0) return;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  // Data after IEND is allowed, but a PNG ends with it in practice.
  const std::streamoff tail = std::min<std::streamoff>(size - 8, 65536);
  std::string bytes(static_cast<size_t>(tail), '\0');
  in.seekg(size - tail);
  if (!in.read(&bytes[0], tail)) return;  // the decoder says what is wrong
  if (bytes.find("IEND") == std::string::npos)
    throw Error(path + ": a PNG cut short (its last chunk, IEND, is missing; " + std::to_string(size) + " bytes)");
}

FrameSource::FrameSource(const std::string& path, const FrameSourceOptions& options)
    : path_(path), name_(InputName(path)), capacity_(8) {
  UseDefaultDecoderLogging();
  std::error_code ec;
  if (!IsLive(path) && fs::is_directory(path, ec)) {
    files_ = FolderImages(path);
    if (files_.empty()) throw Error(path + ": no image files in this folder");
    count_ = static_cast<int>(files_.size());
  } else if (IsCamera(path)) {
    OpenCamera();
  } else if (IsPattern(path)) {
    files_ = ExpandPattern(path);
    if (files_.empty()) throw Error(path + ": no images match this pattern");
    count_ = static_cast<int>(files_.size());
  } else {
    OpenVideo(options);
  }
  if (!ReadDirect(&first_) || first_.image.empty())
    throw Error(name_ + ": no frames (empty or corrupt input)");
  const size_t frame_bytes = first_.image.total() * first_.image.elemSize();
  if (!IsGrey(first_.image)) {
    cv::Mat grey;
    ToGrey(first_.image, &grey);
    first_.image = grey;
  }
  const cv::Mat& grey = first_.image;
  have_first_ = true;
  width_ = grey.cols;
  height_ = grey.rows;
  capacity_ =
      static_cast<int>(std::clamp<size_t>(options.prefetch_bytes / std::max<size_t>(frame_bytes, 1), 8, 4096));
  if (!(fps_ > 0.0 && fps_ < 1e4)) fps_ = 0.0;
  // A decoder of groups of pictures decodes ahead on threads of its own.
  if (!gop_parallel()) worker_ = std::thread([this] { Decode(); });
}

void FrameSource::OpenVideo(const FrameSourceOptions& options) {
  const double live_timeout_s = options.live_timeout_s;
  const bool live = IsLive(path_);
  std::error_code ec;
  if (!live && !fs::exists(path_, ec)) throw Error(path_ + ": no such file");
  luma_ = std::make_unique<LumaDecoder>();
  std::string why;
  LumaDecoderOptions decoder_options;
  decoder_options.io_timeout_s = live ? live_timeout_s : 0.0;
  decoder_options.num_threads = options.decoder_threads;
  decoder_options.gop_parallel_bytes = options.gop_parallel_bytes;
  decoder_options.hardware = options.hardware;
  if (luma_->Open(path_, &why, decoder_options)) {
    fps_ = luma_->fps();
    if (!live) count_ = static_cast<int>(luma_->frame_count());
    return;
  }
  const bool container_opened = luma_->container_opened();
  const long listed = luma_->frame_count();
  if (options.hardware == HardwareDecoding::kCuda) throw Error(name_ + ": cannot decode (" + why + ")");
  luma_.reset();
  // cv::VideoCapture decodes through the same FFmpeg: worth trying only for
  // pixel formats without a luma plane, or in a build without FFmpeg.
  // Standard input cannot be read a second time.
  if ((LumaDecoderAvailable() && !container_opened) || path_ == "-")
    throw Error(name_ + ": cannot open as a video (" + why + ")");
  std::vector<int> params;
  if (live) {
    const int ms = static_cast<int>(live_timeout_s * 1000.0);
    params = {cv::CAP_PROP_OPEN_TIMEOUT_MSEC, ms, cv::CAP_PROP_READ_TIMEOUT_MSEC, ms};
  }
  capture_.open(path_, cv::CAP_FFMPEG, params);
  if (!capture_.isOpened()) throw Error(name_ + ": cannot open as a video (" + why + ")");
  fps_ = capture_.get(cv::CAP_PROP_FPS);
  const double n = capture_.get(cv::CAP_PROP_FRAME_COUNT);
  if (!live && n > 0) count_ = static_cast<int>(n);
  // OpenCV estimates a count from the duration when the container lists
  // none: only a listed count can tell a short read.
  capture_expected_ = LumaDecoderAvailable() ? listed : count_;
}

void FrameSource::OpenCamera() {
  camera_ = true;
  std::error_code ec;
  if (!fs::exists(path_, ec)) throw Error(path_ + ": no such camera device");
  capture_.open(path_, cv::CAP_V4L2);
  if (!capture_.isOpened())
    throw Error(path_ + ": cannot open as a camera (no V4L2 capture device, or busy)");
  fps_ = capture_.get(cv::CAP_PROP_FPS);
}

bool FrameSource::IsLive(const std::string& path) {
  return path == "-" || path.rfind("/dev/", 0) == 0 || path.find("://") != std::string::npos;
}

NamedPaths FrameSource::InputReads(const std::string& path, const std::string& option) {
  std::vector<std::string> files;
  std::error_code ec;
  try {
    if (!IsLive(path) && fs::is_directory(path, ec)) files = FolderImages(path);
    else if (IsPattern(path)) files = ExpandPattern(path);
  } catch (const std::exception&) {
    // A folder that cannot be listed, a bad pattern: opening the input fails
    // and names it, without stopping a run's other inputs.
  }
  NamedPaths reads = {{option, path}};
  for (const std::string& f : files) reads.push_back({"a frame of " + path, f});
  return reads;
}

int FrameSource::FrameCount(const std::string& path) {
  if (IsLive(path)) return -1;
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    int n = 0;
    for (const auto& e : fs::directory_iterator(path, ec))
      if (e.is_regular_file() && IsImageFile(e.path())) ++n;
    return n;
  }
  if (IsPattern(path)) {
    try {
      return static_cast<int>(ExpandPattern(path).size());
    } catch (const Error&) {
      return -1;
    }
  }
  if (!fs::exists(path, ec)) return -1;
  UseDefaultDecoderLogging();
  LumaDecoder luma;
  std::string why;
  if (luma.Open(path, &why)) return static_cast<int>(luma.frame_count());
  if (LumaDecoderAvailable() && !luma.container_opened()) return -1;
  opencv_io::VideoCapture cap;
  cap.open(path, cv::CAP_FFMPEG);
  const double n = cap.isOpened() ? cap.get(cv::CAP_PROP_FRAME_COUNT) : -1;
  return n > 0 ? static_cast<int>(n) : -1;
}

FrameSource::~FrameSource() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (luma_) luma_->Abort();  // a stream may hold the decoding thread in a read
  if (worker_.joinable()) worker_.join();
}

bool FrameSource::ReadDirect(Frame* frame) {
  frame->time_s = std::nan("");
  if (!files_.empty()) {
    if (next_file_ >= files_.size()) return false;
    const std::string& f = files_[next_file_++];
    CheckImageComplete(f);
    frame->image = opencv_io::imread(f, cv::IMREAD_UNCHANGED);
    if (frame->image.empty()) throw Error(f + ": cannot decode the image");
    return true;
  }
  // Decodes into the frame's buffer when it has the right size already.
  if (luma_) return luma_->Read(&frame->image, &frame->time_s);
  return ReadCapture(frame);
}

bool FrameSource::ReadCapture(Frame* frame) {
  if (!capture_.read(frame->image) || frame->image.empty()) {
    if (camera_) throw Error(DecodeError(name_, captured_, "camera stopped delivering frames"));
    if (capture_expected_ > 0 && captured_ < capture_expected_)
      throw Error(DecodeError(
          name_, captured_,
          "truncated or damaged file (container lists " + std::to_string(capture_expected_) + " frames)"));
    return false;
  }
  const double ms = capture_.get(cv::CAP_PROP_POS_MSEC);
  if (captured_ == 0) first_capture_ms_ = ms;
  frame->time_s = (ms - first_capture_ms_) / 1000.0;
  ++captured_;
  return true;
}

void FrameSource::Decode() {
  for (;;) {
    Frame frame;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!free_.empty()) {
        frame.image = std::move(free_.back());
        free_.pop_back();
      }
    }
    bool ok = false;
    std::string err;
    try {
      ok = ReadDirect(&frame);
    } catch (const std::exception& e) {
      err = e.what();
    }
    std::unique_lock<std::mutex> lock(mu_);
    if (!ok) {
      done_ = true;
      error_ = err;
      cv_.notify_all();
      return;
    }
    cv_.wait(lock, [this] { return stop_ || static_cast<int>(queue_.size()) < capacity_; });
    if (stop_) return;
    queue_.push_back(std::move(frame));
    cv_.notify_all();
  }
}

int FrameSource::frames_waiting() {
  if (gop_parallel()) return luma_->frames_waiting();
  std::lock_guard<std::mutex> lock(mu_);
  return static_cast<int>(queue_.size());
}

bool FrameSource::Read(cv::Mat* grey) {
  double time_s;
  return Read(grey, &time_s);
}

bool FrameSource::Read(cv::Mat* grey, double* time_s) {
  if (have_first_) {
    *grey = first_.image;
    first_.image.release();
    *time_s = first_.time_s;
    have_first_ = false;
    return true;
  }
  if (gop_parallel()) {
    if (!luma_->Read(grey, time_s)) return false;
    BringIntoCache(*grey);
    return true;
  }
  std::unique_lock<std::mutex> lock(mu_);
  cv_.wait(lock, [this] { return !queue_.empty() || done_; });
  if (!queue_.empty()) {
    Frame frame = std::move(queue_.front());
    queue_.pop_front();
    cv_.notify_all();
    lock.unlock();
    *time_s = frame.time_s;
    if (IsGrey(frame.image)) {
      BringIntoCache(frame.image);
      *grey = std::move(frame.image);
      return true;
    }
    // Converted here, on the consumer's thread: the decoding thread is the
    // pipeline's bottleneck. Never into a buffer that another cv::Mat shares
    // (a frame the consumer still holds) or a decoder's (own allocator).
    if (grey->u && (grey->u->refcount > 1 || grey->u->currAllocator != cv::Mat::getDefaultAllocator()))
      grey->release();
    ToGrey(frame.image, grey);  // a copy: the buffer can be decoded into again
    std::lock_guard<std::mutex> relock(mu_);
    free_.push_back(std::move(frame.image));
    return true;
  }
  if (!error_.empty()) throw Error(error_);
  return false;
}

}  // namespace pano

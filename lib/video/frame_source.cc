#include "video/frame_source.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace pano {

namespace fs = std::filesystem;

namespace {
bool IsImageFile(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".bmp" ||
         ext == ".tif" || ext == ".tiff" || ext == ".ppm";
}

void ToGrey(const cv::Mat& in, cv::Mat* out) {
  if (in.channels() == 3) cv::cvtColor(in, *out, cv::COLOR_BGR2GRAY);
  else if (in.channels() == 4) cv::cvtColor(in, *out, cv::COLOR_BGRA2GRAY);
  else in.copyTo(*out);  // into *out's buffer when it has the size already
  if (out->depth() != CV_8U) out->convertTo(*out, CV_8U);
}
}  // namespace

FrameSource::FrameSource(const std::string& path, size_t prefetch_bytes) : path_(path), capacity_(8) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    for (const auto& e : fs::directory_iterator(path))
      if (e.is_regular_file() && IsImageFile(e.path())) files_.push_back(e.path().string());
    std::sort(files_.begin(), files_.end());
    if (files_.empty()) throw Error(path + ": no image files in this folder");
  } else if (path.find('%') != std::string::npos) {
    capture_.open(path, cv::CAP_IMAGES);
    if (!capture_.isOpened()) throw Error(path + ": no images match this pattern");
  } else {
    if (!fs::exists(path, ec)) throw Error(path + ": no such file");
    luma_ = std::make_unique<LumaDecoder>();
    std::string why;
    if (luma_->Open(path, &why)) {
      fps_ = luma_->fps();
      count_ = static_cast<int>(luma_->frame_count());
    } else {
      luma_.reset();
      capture_.open(path, cv::CAP_FFMPEG);
      if (!capture_.isOpened()) throw Error(path + ": cannot open as a video (unreadable or not a video)");
      fps_ = capture_.get(cv::CAP_PROP_FPS);
      const double n = capture_.get(cv::CAP_PROP_FRAME_COUNT);
      if (n > 0) count_ = static_cast<int>(n);
    }
  }
  if (!files_.empty()) count_ = static_cast<int>(files_.size());
  cv::Mat raw;
  if (!ReadDirect(&raw) || raw.empty()) throw Error(path + ": no frames (empty or corrupt input)");
  ToGrey(raw, &first_);
  width_ = first_.cols;
  height_ = first_.rows;
  const size_t frame_bytes = raw.total() * raw.elemSize();
  capacity_ = static_cast<int>(std::clamp<size_t>(prefetch_bytes / std::max<size_t>(frame_bytes, 1), 8, 4096));
  if (!(fps_ > 0.0 && fps_ < 1e4)) fps_ = 0.0;
  worker_ = std::thread([this] { Decode(); });
}

bool FrameSource::IsLive(const std::string& path) {
  return path == "-" || path.rfind("/dev/", 0) == 0 || path.find("://") != std::string::npos;
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
  if (path.find('%') != std::string::npos || !fs::exists(path, ec)) return -1;
  LumaDecoder luma;
  std::string why;
  if (luma.Open(path, &why)) return static_cast<int>(luma.frame_count());
  cv::VideoCapture cap(path, cv::CAP_FFMPEG);
  const double n = cap.isOpened() ? cap.get(cv::CAP_PROP_FRAME_COUNT) : -1;
  return n > 0 ? static_cast<int>(n) : -1;
}

FrameSource::~FrameSource() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

bool FrameSource::ReadDirect(cv::Mat* frame) {
  if (!files_.empty()) {
    if (next_file_ >= files_.size()) return false;
    const std::string& f = files_[next_file_++];
    *frame = cv::imread(f, cv::IMREAD_UNCHANGED);
    if (frame->empty()) throw Error(f + ": cannot decode the image");
    return true;
  }
  // Decodes into *frame's buffer when it has the right size already.
  if (luma_) return luma_->Read(frame);
  return capture_.read(*frame) && !frame->empty();
}

void FrameSource::Decode() {
  for (;;) {
    cv::Mat frame;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!free_.empty()) {
        frame = std::move(free_.back());
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

bool FrameSource::Read(cv::Mat* grey, double* time_s) {
  const long index = frames_read_;
  if (!Read(grey)) return false;
  *time_s = fps_ > 0.0 ? index / fps_ : std::nan("");
  return true;
}

bool FrameSource::Read(cv::Mat* grey) {
  if (!first_.empty()) {
    *grey = first_;
    first_.release();
    ++frames_read_;
    return true;
  }
  std::unique_lock<std::mutex> lock(mu_);
  cv_.wait(lock, [this] { return !queue_.empty() || done_; });
  if (!queue_.empty()) {
    cv::Mat frame = std::move(queue_.front());
    queue_.pop_front();
    cv_.notify_all();
    lock.unlock();
    // Converted here, on the consumer's thread: the decoding thread is the
    // pipeline's bottleneck.
    ToGrey(frame, grey);  // a copy: the buffer can be decoded into again
    std::lock_guard<std::mutex> relock(mu_);
    free_.push_back(std::move(frame));
    ++frames_read_;
    return true;
  }
  if (!error_.empty()) throw Error(error_);
  return false;
}

}  // namespace pano

// OpenCV's image and video I/O (opencv_imgcodecs, opencv_videoio), loaded
// from a small module the first time something needs it.
//
// Linked directly, those two OpenCV modules pull about a hundred more shared
// libraries (GDAL, GDCM, GStreamer...) into every process, and resolving
// their symbols costs about 0.2 s of CPU at every start, more than decoding
// a short clip. Most runs decode videos with FFmpeg directly (LumaDecoder)
// and never touch them: only image folders, cameras, pixel formats without
// a luma plane, debug videos and plots do. The module
// (libpanotrack_opencv_io.so) is searched for in order:
//   1. $PANOTRACK_OPENCV_IO, when set (then only there);
//   2. beside the program or library holding this code, and in
//      ../lib/panotrack and ../<libdir>/panotrack from its folder;
//   3. where this build put it, then where it installs it.
// The classes mirror OpenCV's names and arguments; they throw pano::Error
// when the module cannot be loaded ("<file>: OpenCV's image and video I/O
// (libpanotrack_opencv_io.so) could not be loaded: <why>; ...", naming the
// file that needed it where there is one).
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace pano::opencv_io {

// The module's side (opencv_io_module.cc implements it).
class CaptureBackend {
 public:
  virtual ~CaptureBackend() = default;
  virtual bool open(const std::string& path, int api, const std::vector<int>& params) = 0;
  virtual bool isOpened() const = 0;
  virtual bool read(cv::Mat& image) = 0;
  virtual double get(int property) const = 0;
  virtual void release() = 0;
};

class WriterBackend {
 public:
  virtual ~WriterBackend() = default;
  virtual bool open(const std::string& path, int fourcc, double fps, cv::Size size, bool color) = 0;
  virtual void write(const cv::Mat& image) = 0;
  virtual void release() = 0;
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::unique_ptr<CaptureBackend> NewCapture() const = 0;
  virtual std::unique_ptr<WriterBackend> NewWriter() const = 0;
  virtual cv::Mat imread(const std::string& path, int flags) const = 0;
  virtual bool imencode(const std::string& ext, const cv::Mat& image, std::vector<uchar>& buffer,
                        const std::vector<int>& params) const = 0;
};

// The loaded module; throws pano::Error when it cannot be loaded.
const Backend& LoadBackend();
// Where the module was loaded from ("" before it is).
std::string BackendPath();

// cv::imread, cv::imencode.
cv::Mat imread(const std::string& path, int flags);
bool imencode(const std::string& ext, const cv::Mat& image, std::vector<uchar>& buffer,
              const std::vector<int>& params = {});

// cv::VideoWriter::fourcc.
constexpr int fourcc(char c1, char c2, char c3, char c4) {
  return (c1 & 255) | ((c2 & 255) << 8) | ((c3 & 255) << 16) | ((c4 & 255) << 24);
}

// cv::VideoCapture; the module is loaded by open().
class VideoCapture {
 public:
  bool open(const std::string& path, int api, const std::vector<int>& params = {});
  bool isOpened() const { return backend_ && backend_->isOpened(); }
  bool read(cv::Mat& image) { return backend_ && backend_->read(image); }
  double get(int property) const { return backend_ ? backend_->get(property) : 0.0; }
  void release() {
    if (backend_) backend_->release();
  }

 private:
  std::unique_ptr<CaptureBackend> backend_;
};

// cv::VideoWriter; the module is loaded by open().
class VideoWriter {
 public:
  bool open(const std::string& path, int fourcc, double fps, cv::Size size, bool color);
  void write(const cv::Mat& image) {
    if (backend_) backend_->write(image);
  }
  void release() {
    if (backend_) backend_->release();
  }

 private:
  std::unique_ptr<WriterBackend> backend_;
};

}  // namespace pano::opencv_io

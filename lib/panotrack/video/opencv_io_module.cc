// The module behind opencv_io.h: OpenCV's imgcodecs and videoio, loaded
// only by the processes that need them.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "panotrack/video/opencv_io.h"

namespace pano::opencv_io {
namespace {

class Capture final : public CaptureBackend {
 public:
  bool open(const std::string& path, int api, const std::vector<int>& params) override {
    return capture_.open(path, api, params);
  }
  bool isOpened() const override { return capture_.isOpened(); }
  bool read(cv::Mat& image) override { return capture_.read(image); }
  double get(int property) const override { return capture_.get(property); }
  void release() override { capture_.release(); }

 private:
  cv::VideoCapture capture_;
};

class Writer final : public WriterBackend {
 public:
  bool open(const std::string& path, int fourcc, double fps, cv::Size size, bool color) override {
    return writer_.open(path, fourcc, fps, size, color);
  }
  void write(const cv::Mat& image) override { writer_.write(image); }
  void release() override { writer_.release(); }

 private:
  cv::VideoWriter writer_;
};

class OpenCvBackend final : public Backend {
 public:
  std::unique_ptr<CaptureBackend> NewCapture() const override { return std::make_unique<Capture>(); }
  std::unique_ptr<WriterBackend> NewWriter() const override { return std::make_unique<Writer>(); }
  cv::Mat imread(const std::string& path, int flags) const override { return cv::imread(path, flags); }
  bool imencode(const std::string& ext, const cv::Mat& image, std::vector<uchar>& buffer,
                const std::vector<int>& params) const override {
    return cv::imencode(ext, image, buffer, params);
  }
};

}  // namespace
}  // namespace pano::opencv_io

extern "C" __attribute__((visibility("default"))) const pano::opencv_io::Backend* pano_opencv_io_backend() {
  static const pano::opencv_io::OpenCvBackend backend;
  return &backend;
}

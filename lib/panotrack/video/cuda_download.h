// Internal: NVDEC's luma planes copied straight into page-locked host memory
// through the CUDA driver, which is loaded at run time as FFmpeg loads it (no
// link-time dependency: the programs start on machines without a driver).
// The GPU writes page-locked memory directly; pageable memory goes through
// the driver's staging buffers, and FFmpeg's own download also brings the
// chroma planes. Built with PANO_WITH_CUDA and FFmpeg only.
#pragma once

#include <opencv2/core.hpp>
#include <string>

struct AVBufferRef;
struct AVFrame;

namespace pano::detail {

// Allocates cv::Mat buffers in page-locked memory of one FFmpeg CUDA device
// and copies luma planes of that device's frames into them. Every buffer
// keeps the device (its CUDA context) alive until it is released, so the
// frames handed out may outlive the decoder.
class CudaLumaDownload {
 public:
  CudaLumaDownload() = default;
  ~CudaLumaDownload();
  CudaLumaDownload(const CudaLumaDownload&) = delete;
  CudaLumaDownload& operator=(const CudaLumaDownload&) = delete;

  // `device`: FFmpeg's CUDA device (AVHWDeviceContext). False with the
  // reason when the driver's functions cannot be loaded.
  bool Init(AVBufferRef* device, std::string* why);
  // Buffers of cv::Mat::create() in page-locked memory (ordinary memory
  // where that cannot be had); valid while this object lives, and after it
  // for the buffers already made.
  cv::MatAllocator* allocator() const;
  // Copies the luma plane of `frame` (AV_PIX_FMT_CUDA on this device) into
  // *luma, which has the frame's size. False with the reason on a CUDA error.
  bool Copy(const AVFrame& frame, cv::Mat* luma, std::string* why) const;

 private:
  struct Allocator;
  Allocator* allocator_ = nullptr;  // deletes itself once released by all
};

}  // namespace pano::detail

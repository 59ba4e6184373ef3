#include "panotrack/video/cuda_download.h"

#include <cuda.h>
#include <dlfcn.h>

extern "C" {
#include <libavutil/buffer.h>
#include <libavutil/frame.h>
#include <libavutil/hwcontext.h>
#include <libavutil/hwcontext_cuda.h>
}

#include <atomic>
#include <new>

namespace pano::detail {
namespace {

// The driver functions used here, from libcuda.so.1 (loaded once, never
// unloaded: FFmpeg holds it too while a device exists).
struct Driver {
  decltype(&cuMemHostAlloc) mem_host_alloc = nullptr;
  decltype(&cuMemFreeHost) mem_free_host = nullptr;
  decltype(&cuMemcpy2D) memcpy_2d = nullptr;
  decltype(&cuCtxPushCurrent) ctx_push = nullptr;
  decltype(&cuCtxPopCurrent) ctx_pop = nullptr;
  std::string error;  // why it could not be loaded; "" when it was
};

template <typename F>
bool Load(void* lib, const char* name, F* f) {
  *f = reinterpret_cast<F>(dlsym(lib, name));
  return *f != nullptr;
}

const Driver& CudaDriver() {
  static const Driver driver = [] {
    Driver d;
    void* lib = dlopen("libcuda.so.1", RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
      d.error = "cannot load libcuda.so.1";
      return d;
    }
    // The names behind cuda.h's macros (the _v2 entry points).
    if (!Load(lib, "cuMemHostAlloc", &d.mem_host_alloc) || !Load(lib, "cuMemFreeHost", &d.mem_free_host) ||
        !Load(lib, "cuMemcpy2D_v2", &d.memcpy_2d) || !Load(lib, "cuCtxPushCurrent_v2", &d.ctx_push) ||
        !Load(lib, "cuCtxPopCurrent_v2", &d.ctx_pop))
      d.error = "libcuda.so.1 lacks the functions needed";
    return d;
  }();
  return driver;
}

// Makes `context` current on the calling thread for its lifetime.
class ScopedContext {
 public:
  ScopedContext(const Driver& driver, CUcontext context)
      : driver_(driver), pushed_(driver.ctx_push(context) == CUDA_SUCCESS) {}
  ~ScopedContext() {
    CUcontext popped;
    if (pushed_) driver_.ctx_pop(&popped);
  }
  bool ok() const { return pushed_; }

 private:
  const Driver& driver_;
  bool pushed_;
};

}  // namespace

// Page-locked cv::Mat buffers of one device's context. Holds a reference to
// the device while the decoder or any buffer it made is alive: the context,
// and so the memory, lasts as long.
struct CudaLumaDownload::Allocator : cv::MatAllocator {
  Allocator(AVBufferRef* device_ref, CUcontext ctx) : device(device_ref), context(ctx) {}
  ~Allocator() override { av_buffer_unref(&device); }

  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data0, size_t* step, cv::AccessFlag flags,
                         cv::UMatUsageFlags usage) const override {
    size_t total = CV_ELEM_SIZE(type);
    for (int i = dims - 1; i >= 0; --i) {
      if (step) step[i] = total;
      total *= static_cast<size_t>(sizes[i]);
    }
    void* data = nullptr;
    if (!data0) {
      const Driver& driver = CudaDriver();
      ScopedContext current(driver, context);
      if (!current.ok() || driver.mem_host_alloc(&data, total, CU_MEMHOSTALLOC_PORTABLE) != CUDA_SUCCESS)
        return cv::Mat::getDefaultAllocator()->allocate(dims, sizes, type, data0, step, flags, usage);
    }
    auto* u = new (std::nothrow) cv::UMatData(this);
    if (!u) {
      if (data) {
        const Driver& driver = CudaDriver();
        ScopedContext current(driver, context);
        driver.mem_free_host(data);
      }
      throw std::bad_alloc();
    }
    u->data = u->origdata = static_cast<uchar*>(data0 ? data0 : data);
    u->size = total;
    if (data0) u->flags |= cv::UMatData::USER_ALLOCATED;
    holds.fetch_add(1, std::memory_order_relaxed);
    return u;
  }
  bool allocate(cv::UMatData*, cv::AccessFlag, cv::UMatUsageFlags) const override { return false; }
  void deallocate(cv::UMatData* u) const override {
    if (!u) return;
    if (!(u->flags & cv::UMatData::USER_ALLOCATED)) {
      const Driver& driver = CudaDriver();
      ScopedContext current(driver, context);
      driver.mem_free_host(u->origdata);
    }
    delete u;
    Release();
  }
  // The decoder's hold and each buffer's: the last one deletes the allocator.
  void Release() const {
    if (holds.fetch_sub(1, std::memory_order_acq_rel) == 1) delete this;
  }

  AVBufferRef* device;
  CUcontext context;
  mutable std::atomic<long> holds{1};
};

CudaLumaDownload::~CudaLumaDownload() {
  if (allocator_) allocator_->Release();
}

bool CudaLumaDownload::Init(AVBufferRef* device, std::string* why) {
  const Driver& driver = CudaDriver();
  if (!driver.error.empty()) {
    *why = driver.error;
    return false;
  }
  auto* hw = reinterpret_cast<AVHWDeviceContext*>(device->data);
  const CUcontext context = static_cast<AVCUDADeviceContext*>(hw->hwctx)->cuda_ctx;
  AVBufferRef* ref = av_buffer_ref(device);
  allocator_ = ref ? new (std::nothrow) Allocator(ref, context) : nullptr;
  if (!allocator_) {
    av_buffer_unref(&ref);
    *why = "out of memory";
    return false;
  }
  return true;
}

cv::MatAllocator* CudaLumaDownload::allocator() const { return allocator_; }

bool CudaLumaDownload::Copy(const AVFrame& frame, cv::Mat* luma, std::string* why) const {
  const Driver& driver = CudaDriver();
  ScopedContext current(driver, allocator_->context);
  CUDA_MEMCPY2D copy = {};
  copy.srcXInBytes = frame.crop_left;  // luma: a byte per pixel
  copy.srcY = frame.crop_top;
  copy.srcMemoryType = CU_MEMORYTYPE_DEVICE;
  copy.srcDevice = reinterpret_cast<CUdeviceptr>(frame.data[0]);
  copy.srcPitch = static_cast<size_t>(frame.linesize[0]);
  copy.dstMemoryType = CU_MEMORYTYPE_HOST;
  copy.dstHost = luma->data;
  copy.dstPitch = luma->step[0];
  copy.WidthInBytes = static_cast<size_t>(luma->cols);
  copy.Height = static_cast<size_t>(luma->rows);
  // Synchronous, and after FFmpeg's copy of the decoded surface into the
  // frame: that is on the device's stream, which is the context's default
  // stream as the decoder creates the device with none of its own.
  const CUresult r = current.ok() ? driver.memcpy_2d(&copy) : CUDA_ERROR_INVALID_CONTEXT;
  if (r != CUDA_SUCCESS) {
    *why = "CUDA copy failed (error " + std::to_string(static_cast<int>(r)) + ")";
    return false;
  }
  return true;
}

}  // namespace pano::detail

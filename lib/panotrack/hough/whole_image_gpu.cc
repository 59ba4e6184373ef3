#include "panotrack/hough/whole_image_gpu.h"

#include <chrono>

#include "panotrack/core/error.h"
#include "panotrack/config.h"

namespace pano {

#if !PANO_WITH_CUDA
namespace detail {
bool CudaDevicePresent(std::string* reason) {
  if (reason) *reason = "panotrack was built without CUDA (PANO_WITH_CUDA 0)";
  return false;
}
bool GpuVote(GpuVoteJob*, std::string* reason) { return CudaDevicePresent(reason); }
}  // namespace detail
#endif

bool CudaAvailable(std::string* reason) { return detail::CudaDevicePresent(reason); }

bool HoughWholeImageGpu(const PhWholeImage& ph, const std::vector<EdgeMap>& frames,
                        std::vector<WholeImageResult>* results, std::string* reason,
                        GpuTiming* timing) {
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  if (ph.empty()) throw Error("HoughWholeImageGpu: transform not built");
  if (frames.empty()) throw Error("HoughWholeImageGpu: no frames");
  if (!results) throw Error("HoughWholeImageGpu: null results");
  if (!detail::CudaDevicePresent(reason)) return false;
  const auto t0 = Clock::now();
  std::vector<WholeImageResult> res(frames.size());
  std::vector<PhVoteRecord> all, one;
  std::vector<int32_t> frame_of;
  for (size_t f = 0; f < frames.size(); ++f) {
    ph.Prepare(frames[f], &one, &res[f]);
    all.insert(all.end(), one.begin(), one.end());
    frame_of.insert(frame_of.end(), one.size(), static_cast<int32_t>(f));
  }
  const auto t1 = Clock::now();
  std::vector<int32_t> padded(ph.PaddedSize() * frames.size());
  detail::GpuVoteJob job;
  job.table = ph.int_table().data();
  job.table_ints = ph.int_table().size();
  job.plane_size = ph.int_plane_size();
  job.row_stride = ph.row_stride();
  job.n_r = ph.n_r();
  job.n_theta = ph.n_theta();
  job.records = all.data();
  job.record_frame = frame_of.data();
  job.n_records = all.size();
  job.n_frames = static_cast<int>(frames.size());
  job.padded_plane = ph.PaddedPlaneSize();
  job.padded_frame = ph.PaddedSize();
  job.out = padded.data();
  if (!detail::GpuVote(&job, reason)) return false;
  const auto t2 = Clock::now();
  for (size_t f = 0; f < frames.size(); ++f) ph.Finish(&padded[f * ph.PaddedSize()], &res[f]);
  const auto t3 = Clock::now();
  if (timing) {
    timing->prepare_ms = ms(t0, t1);
    timing->upload_ms = job.upload_ms;
    timing->kernel_ms = job.kernel_ms;
    timing->download_ms = job.download_ms;
    timing->finish_ms = ms(t2, t3);
  }
  *results = std::move(res);
  return true;
}

}  // namespace pano

// CUDA voting of the whole-image Panoramic Hough Transform (Eqns 7-8): one
// warp per vote record (edge pixel x plane), its lanes over the record's
// theta_main bins (dtheta values); integer atomicAdd into fixed-point-exact
// integer accumulators, so the result equals the CPU's bit for bit. Frames of
// a batch are voted in one launch, each into its own accumulator.
#include <cuda_runtime.h>

#include <string>

#include "panotrack/hough/gpu_vote.h"

namespace pano {
namespace detail {

namespace {

__global__ void VoteKernel(const int32_t* __restrict__ table, size_t plane_size, int stride, int n_r,
                           int n_theta,
                           const PhVoteRecord* __restrict__ recs, const int32_t* __restrict__ frame_of,
                           size_t n_records, int32_t* __restrict__ acc, size_t padded_plane,
                           size_t padded_frame) {
  const size_t warp = (static_cast<size_t>(blockIdx.x) * blockDim.x + threadIdx.x) / 32;
  const int lane = threadIdx.x & 31;
  if (warp >= n_records) return;
  const PhVoteRecord r = recs[warp];
  const int32_t* a = table + r.plane * plane_size + r.offset;
  const int32_t* b = a + stride;
  const int w1 = r.t, w0 = 256 - w1;
  const int cols = n_r + 1;
  int32_t* base = acc + static_cast<size_t>(frame_of[warp]) * padded_frame + r.plane * padded_plane;
  for (int j = lane; j < r.count; j += 32) {
    int v = (a[j] * w0 + b[j] * w1) >> 16;  // same integer arithmetic as the CPU
    v = v < n_r ? v : n_r;
    int row = r.k_start + j;
    if (row >= n_theta) row -= n_theta;  // theta_main wraps at 2 pi
    atomicAdd(base + static_cast<size_t>(row) * cols + v, 1);
  }
}

bool Check(cudaError_t e, const char* what, std::string* reason) {
  if (e == cudaSuccess) return true;
  if (reason) *reason = std::string("CUDA ") + what + ": " + cudaGetErrorString(e);
  return false;
}

}  // namespace

bool CudaDevicePresent(std::string* reason) {
  int n = 0;
  const cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    if (reason) *reason = std::string("no CUDA device: ") + cudaGetErrorString(e);
    cudaGetLastError();  // clear the sticky error
    return false;
  }
  if (n <= 0) {
    if (reason) *reason = "no CUDA device: cudaGetDeviceCount returned 0";
    return false;
  }
  return true;
}

bool GpuVote(GpuVoteJob* job, std::string* reason) {
  if (!CudaDevicePresent(reason)) return false;
  int32_t* d_table = nullptr;
  PhVoteRecord* d_recs = nullptr;
  int32_t* d_frame = nullptr;
  int32_t* d_acc = nullptr;
  cudaEvent_t ev[4] = {nullptr, nullptr, nullptr, nullptr};
  const size_t acc_ints = static_cast<size_t>(job->n_frames) * job->padded_frame;
  bool ok = true;
  auto step = [&](cudaError_t e, const char* what) {
    if (ok) ok = Check(e, what, reason);
    return ok;
  };
  for (auto& e : ev) step(cudaEventCreate(&e), "event");
  step(cudaMalloc(&d_table, job->table_ints * sizeof(int32_t)), "malloc table");
  step(cudaMalloc(&d_recs, (job->n_records + 1) * sizeof(PhVoteRecord)), "malloc records");
  step(cudaMalloc(&d_frame, (job->n_records + 1) * sizeof(int32_t)), "malloc frames");
  step(cudaMalloc(&d_acc, acc_ints * sizeof(int32_t)), "malloc accumulator");
  if (ok) {
    step(cudaEventRecord(ev[0]), "event");
    step(cudaMemcpy(d_table, job->table, job->table_ints * sizeof(int32_t), cudaMemcpyHostToDevice),
         "upload table");
    if (job->n_records > 0) {
      step(cudaMemcpy(d_recs, job->records, job->n_records * sizeof(PhVoteRecord), cudaMemcpyHostToDevice),
           "upload records");
      step(cudaMemcpy(d_frame, job->record_frame, job->n_records * sizeof(int32_t), cudaMemcpyHostToDevice),
           "upload frames");
    }
    step(cudaMemset(d_acc, 0, acc_ints * sizeof(int32_t)), "clear accumulator");
    step(cudaEventRecord(ev[1]), "event");
    if (ok && job->n_records > 0) {
      const int threads = 256;
      const size_t warps_per_block = threads / 32;
      const size_t blocks = (job->n_records + warps_per_block - 1) / warps_per_block;
      VoteKernel<<<static_cast<unsigned>(blocks), threads>>>(d_table, job->plane_size, job->row_stride,
                                                            job->n_r, job->n_theta, d_recs, d_frame, job->n_records,
                                                            d_acc, job->padded_plane, job->padded_frame);
      step(cudaGetLastError(), "kernel launch");
    }
    step(cudaEventRecord(ev[2]), "event");
    step(cudaMemcpy(job->out, d_acc, acc_ints * sizeof(int32_t), cudaMemcpyDeviceToHost), "download");
    step(cudaEventRecord(ev[3]), "event");
    step(cudaEventSynchronize(ev[3]), "synchronize");
    if (ok) {
      float ms = 0;
      cudaEventElapsedTime(&ms, ev[0], ev[1]);
      job->upload_ms = ms;
      cudaEventElapsedTime(&ms, ev[1], ev[2]);
      job->kernel_ms = ms;
      cudaEventElapsedTime(&ms, ev[2], ev[3]);
      job->download_ms = ms;
    }
  }
  cudaFree(d_table);
  cudaFree(d_recs);
  cudaFree(d_frame);
  cudaFree(d_acc);
  for (auto& e : ev)
    if (e) cudaEventDestroy(e);
  return ok;
}

}  // namespace detail
}  // namespace pano

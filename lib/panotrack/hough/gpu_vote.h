// Internal: the plain-data interface between the C++ whole-image code and the
// CUDA voting kernel (gpu_vote.cu), so that the .cu file needs neither OpenCV
// nor Eigen. Without PANO_WITH_CUDA, whole_image_gpu.cc supplies stubs that
// report "built without CUDA".
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace pano {

// One vote record per (edge pixel, plane): a contiguous run of theta_main bins
// and the integer-table row it reads. Shared by the CPU and GPU voters.
struct PhVoteRecord {
  int32_t offset;   // into the plane's table: [R row][sub step][m + M]
  int16_t k_start;  // first theta_main bin (0..n_theta-1)
  int16_t count;    // number of bins
  uint16_t t;       // weight of the next R row, 0..256
  uint16_t plane;
};

namespace detail {

struct GpuVoteJob {
  const int32_t* table = nullptr;  // host: all planes' integer tables
  size_t table_ints = 0;
  size_t plane_size = 0;           // ints per plane table
  int row_stride = 0;              // ints between R rows
  int n_r = 0;                     // R bins (column n_r collects out-of-range votes)
  int n_theta = 0;                 // theta_main bins (rows; runs wrap at 2 pi)
  const PhVoteRecord* records = nullptr;  // host, all frames
  const int32_t* record_frame = nullptr;  // host, frame of each record
  size_t n_records = 0;
  int n_frames = 0;
  size_t padded_plane = 0;         // ints of one plane's padded accumulator
  size_t padded_frame = 0;         // ints of one frame's padded accumulators
  int32_t* out = nullptr;          // host, n_frames * padded_frame ints (overwritten)
  // Filled in: milliseconds for the upload, the kernel and the download.
  double upload_ms = 0, kernel_ms = 0, download_ms = 0;
};

// False (with the reason) when no CUDA device can be used.
bool CudaDevicePresent(std::string* reason);
// Runs the voting kernel; false with the reason on any CUDA failure.
bool GpuVote(GpuVoteJob* job, std::string* reason);

}  // namespace detail
}  // namespace pano

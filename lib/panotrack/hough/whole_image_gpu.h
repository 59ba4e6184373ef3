// The whole-image Panoramic Hough Transform on a CUDA GPU, one frame or a
// batch. Edge records are prepared on the CPU exactly as for PhWholeImage::Run
// (Sobel/Canny and the per-pixel R_i, theta_i, dtheta ranges: cheap), the
// voting (the costly part: one vote per edge pixel x dtheta) runs as a kernel
// with integer atomicAdd, and the peaks are found on the CPU from the
// downloaded accumulators. The accumulators, and so the peaks, are identical
// to the CPU path's (integer arithmetic throughout: tolerance zero).
#pragma once

#include <string>
#include <vector>

#include "panotrack/hough/whole_image.h"

namespace pano {

struct GpuTiming {
  double prepare_ms = 0;   // CPU: edge records of all frames
  double upload_ms = 0;    // tables + records to the device
  double kernel_ms = 0;    // voting
  double download_ms = 0;  // accumulators back
  double finish_ms = 0;    // CPU: folding and peaks
};

// True when the library was built with CUDA and a device is present;
// otherwise false and *reason says why.
bool CudaAvailable(std::string* reason);

// Runs the transform of every frame on the GPU. Returns false (with the
// reason, results untouched) when CUDA is not built or no device is present,
// or a CUDA call fails; throws pano::Error for bad input as Run does.
bool HoughWholeImageGpu(const PhWholeImage& ph, const std::vector<EdgeMap>& frames,
                        std::vector<WholeImageResult>* results, std::string* reason,
                        GpuTiming* timing = nullptr);

}  // namespace pano

// bench_decode: the decode-only floor of a panoloc run. Decodes the inputs
// as panoloc does (FrameSource, the same split of threads between inputs,
// the same hardware decoding), --jobs at a time, hands every frame over and
// drops it, and prints the frames, the wall time and the frame rate. A
// panoloc run's frames/s over this one's is its throughput ratio.
//
//   bench_decode [--jobs N] [--threads T] [--hwaccel none|cuda|auto]
//                [--decoder-threads D] inputs...
#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "panotrack/video/frame_source.h"
#include "panotrack/video/logging.h"

int main(int argc, char** argv) {
  CLI::App app{"bench_decode: decode the inputs as panoloc does and print frames/s (the decode-only floor)"};
  std::vector<std::string> inputs;
  int jobs = 0, threads = 0, decoder_threads = 0;
  std::string hwaccel = "none";
  app.add_option("inputs", inputs, "Videos")->required();
  app.add_option("-j,--jobs", jobs, "Inputs decoded at once (0: as many as --threads allows)");
  app.add_option("--threads", threads, "Threads of the whole run (0: all cores)");
  app.add_option("--decoder-threads", decoder_threads, "FFmpeg's threads per input (0: panoloc's split)");
  app.add_option("--hwaccel", hwaccel, "Where videos are decoded, as panoloc's")
      ->check(CLI::IsMember({"none", "cuda", "auto"}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  pano::SetDecoderLogging(false);

  const int cores = threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int n_jobs = std::clamp(jobs > 0 ? jobs : cores, 1, static_cast<int>(inputs.size()));
  pano::FrameSourceOptions options;
  options.decoder_threads = decoder_threads > 0 ? decoder_threads : std::max(1, cores / n_jobs);  // as panoloc
  options.hardware = pano::ParseHardwareDecoding(hwaccel);

  std::atomic<size_t> next{0};
  std::atomic<long> frames{0}, on_device{0};
  std::mutex errors_mu;
  std::vector<std::string> errors;
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::thread> workers;
  for (int w = 0; w < n_jobs; ++w) {
    workers.emplace_back([&] {
      for (size_t i; (i = next++) < inputs.size();) {
        try {  // the thread's boundary
          pano::FrameSource source(inputs[i], options);
          on_device += source.hardware_decoding();
          cv::Mat grey;
          long n = 0;
          while (source.Read(&grey)) ++n;
          frames += n;
        } catch (const std::exception& e) {
          std::lock_guard<std::mutex> lock(errors_mu);
          errors.push_back(e.what());
        }
      }
    });
  }
  for (std::thread& t : workers) t.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const std::string& e : errors) std::fprintf(stderr, "bench_decode: %s\n", e.c_str());
  std::printf("inputs %zu, jobs %d, decoder threads %d, on NVDEC %ld: %ld frames in %.3f s, %.1f frames/s\n",
              inputs.size(), n_jobs, options.decoder_threads, on_device.load(), frames.load(), seconds,
              seconds > 0 ? frames / seconds : 0.0);
  return errors.empty() && frames > 0 ? 0 : 1;
}

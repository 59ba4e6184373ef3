// Panoramic Hough Transform (paper section 4.1): the whole-image transform
// against cv::HoughLines on the same edge image (ray-traced panoramas of the
// paper's room at 500 x 500 and 1600 x 1200, Canny edges), both with 1 px x
// 1 degree accumulators, on 1 and 2 threads; the tracking mode per predicted
// edge; the GPU batch when a CUDA device is present. BM_Ratio times both in
// the same loop (alternating, so both see the same machine load) and reports
// PH / HoughLines in wall and in CPU time.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <ctime>
#include <memory>
#include <random>

#include "hough/hough_fixtures.h"
#include "hough/scene_render.h"
#include "panotrack/hough/whole_image.h"
#include "panotrack/hough/whole_image_gpu.h"

namespace {

constexpr int kThreads = 2;
constexpr int kHoughLinesThreshold = 30;

// Image sizes: 0 the paper's 500 x 500 sensor; 1 the same mirror seen by a
// 1600 x 1200 camera (focal length scaled by 2.4, so the mirror fills the
// frame's height as at 500 x 500).
pano::Sensor SensorOfSize(int size) {
  if (size == 0) return pano::test::PaperSyntheticSensor();
  return pano::MakeSphereSensor(1600, 1200, 590.0 * 2.4, 799.5, 599.5, 1.0, 4.9, 15.1);
}

struct Setup {
  pano::Sensor sensor;
  std::shared_ptr<const pano::RadiusTable> table;
  pano::WholeImageOptions options;
  pano::PhWholeImage ph;
  cv::Mat image;
  pano::EdgeMap edges;
  explicit Setup(int size) : sensor(SensorOfSize(size)), table(pano::test::BuildTestTable(sensor)) {
    options.heights = {-30.0, 9.0, 13.0, 60.0};  // as in the test hough/whole_image
    options.distance_min = 20.0;
    options.distance_max = 600.0;
    options.r_bin = 1.0;
    options.theta_bin = M_PI / 180;
    options.keep_accumulator = false;  // peaks only, as HoughLines returns lines only
    ph = pano::PhWholeImage::Build(*table, options);
    image = pano::test::RenderRoom(sensor, pano::test::PaperRoom());
    edges = pano::ComputeEdgeMap(image);
  }
};

const Setup& Get(int size = 0) {
  static const Setup small(0);
  if (size == 0) return small;
  static const Setup large(1);
  return large;
}

void Threads(int n = kThreads) {
  omp_set_num_threads(n);
  cv::setNumThreads(n);
}

double ProcessCpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

void Sizes(benchmark::internal::Benchmark* b) {
  for (int size : {0, 1})
    for (int threads : {1, 2}) b->Args({size, threads});
  b->ArgNames({"size", "threads"});
}

void BM_PhWholeImage(benchmark::State& state) {
  const Setup& s = Get(static_cast<int>(state.range(0)));
  Threads(static_cast<int>(state.range(1)));
  int64_t votes = 0;
  int pixels = 0;
  size_t peaks = 0;
  for (auto _ : state) {
    pano::WholeImageResult r = s.ph.Run(s.edges);
    votes = r.n_votes;
    pixels = r.n_edge_pixels;
    peaks = r.peaks.size();
    benchmark::DoNotOptimize(r.peaks.data());
  }
  state.counters["edge_px"] = pixels;
  state.counters["votes"] = static_cast<double>(votes);
  state.counters["peaks"] = static_cast<double>(peaks);
  state.counters["votes_per_s"] =
      benchmark::Counter(static_cast<double>(votes), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_PhWholeImage)->Apply(Sizes)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_HoughLines(benchmark::State& state) {
  const Setup& s = Get(static_cast<int>(state.range(0)));
  Threads(static_cast<int>(state.range(1)));
  std::vector<cv::Vec2f> lines;
  for (auto _ : state) {
    cv::HoughLines(s.edges.mask, lines, 1, CV_PI / 180, kHoughLinesThreshold);
    benchmark::DoNotOptimize(lines.data());
  }
  const double votes = cv::countNonZero(s.edges.mask) * 180.0;
  state.counters["edge_px"] = cv::countNonZero(s.edges.mask);
  state.counters["votes_per_s"] = benchmark::Counter(votes, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["lines"] = static_cast<double>(lines.size());
}
BENCHMARK(BM_HoughLines)->Apply(Sizes)->Unit(benchmark::kMillisecond)->UseRealTime();

// Both on the same edge image in the same loop: ratio of their total times,
// wall and process CPU (with 2 threads the CPU time counts both threads).
void BM_Ratio(benchmark::State& state) {
  const Setup& s = Get(static_cast<int>(state.range(0)));
  Threads(static_cast<int>(state.range(1)));
  using Clock = std::chrono::steady_clock;
  double t_ph = 0, t_hl = 0, c_ph = 0, c_hl = 0;
  std::vector<cv::Vec2f> lines;
  for (auto _ : state) {
    const double ca = ProcessCpuSeconds();
    const auto a = Clock::now();
    pano::WholeImageResult r = s.ph.Run(s.edges);
    const auto b = Clock::now();
    const double cb = ProcessCpuSeconds();
    cv::HoughLines(s.edges.mask, lines, 1, CV_PI / 180, kHoughLinesThreshold);
    const auto c = Clock::now();
    const double cc = ProcessCpuSeconds();
    benchmark::DoNotOptimize(r.peaks.data());
    benchmark::DoNotOptimize(lines.data());
    t_ph += std::chrono::duration<double>(b - a).count();
    t_hl += std::chrono::duration<double>(c - b).count();
    c_ph += cb - ca;
    c_hl += cc - cb;
  }
  state.counters["ph_ms"] = 1e3 * t_ph / state.iterations();
  state.counters["houghlines_ms"] = 1e3 * t_hl / state.iterations();
  state.counters["ratio"] = t_ph / t_hl;
  state.counters["ph_cpu_ms"] = 1e3 * c_ph / state.iterations();
  state.counters["houghlines_cpu_ms"] = 1e3 * c_hl / state.iterations();
  state.counters["ratio_cpu"] = c_ph / c_hl;
}
BENCHMARK(BM_Ratio)->Apply(Sizes)->Unit(benchmark::kMillisecond)->UseRealTime();

// The PH transform's steps (records, voting, peaks), wall time per call.
void BM_PhStages(benchmark::State& state) {
  const Setup& s = Get(static_cast<int>(state.range(0)));
  Threads(static_cast<int>(state.range(1)));
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  double t_prep = 0, t_vote = 0, t_fin = 0;
  std::vector<pano::PhVoteRecord> records;
  std::vector<int32_t> padded;
  for (auto _ : state) {
    pano::WholeImageResult r;
    const auto a = Clock::now();
    s.ph.Prepare(s.edges, &records, &r);
    const auto b = Clock::now();
    padded.assign(s.ph.PaddedSize(), 0);
    s.ph.VoteCpu(records, padded.data());
    const auto c = Clock::now();
    s.ph.Finish(padded.data(), &r);
    const auto d = Clock::now();
    benchmark::DoNotOptimize(r.peaks.data());
    t_prep += ms(a, b);
    t_vote += ms(b, c);
    t_fin += ms(c, d);
  }
  state.counters["prepare_ms"] = t_prep / state.iterations();
  state.counters["vote_ms"] = t_vote / state.iterations();
  state.counters["finish_ms"] = t_fin / state.iterations();
}
BENCHMARK(BM_PhStages)->Apply(Sizes)->Unit(benchmark::kMillisecond)->UseRealTime();

// Edge map from the image (blur, Sobel, Canny): shared by both methods, not
// part of the ratio.
void BM_EdgeMap(benchmark::State& state) {
  Threads();
  static const cv::Mat img = pano::test::RenderRoom(Get().sensor, pano::test::PaperRoom());
  for (auto _ : state) {
    pano::EdgeMap e = pano::ComputeEdgeMap(img);
    benchmark::DoNotOptimize(e.mask.data);
  }
}
BENCHMARK(BM_EdgeMap)->Unit(benchmark::kMillisecond)->UseRealTime();

// Tracking mode: one predicted edge of 100 step-edge points, window +-6 px x
// +-4 degrees in 0.5 px x 0.5 degree bins (the localiser's per-edge cost).
void BM_TrackingPerEdge(benchmark::State& state) {
  const Setup& s = Get();
  static const pano::PhTable ph = pano::PhTable::Build(*s.table, -30.0);
  std::mt19937_64 rng(5);
  const pano::test::HLine line{-30.0, 80.0, 0.7};
  const auto pts = pano::test::LinePoints(s.sensor, line, 0.2, 0.9, static_cast<int>(state.range(0)), 0.2, rng);
  double r_true = 0, t_true = 0;
  pano::test::LineTruth(s.sensor, line, &r_true, &t_true);
  pano::TrackingWindow w;
  w.r_main = r_true + 1.3;
  w.theta_main = t_true + 0.02;
  for (auto _ : state) {
    pano::TrackingResult r = pano::TrackHorizontalLine(ph, w, pts);
    benchmark::DoNotOptimize(r);
  }
  state.counters["points"] = static_cast<double>(pts.size());
}
BENCHMARK(BM_TrackingPerEdge)->Arg(20)->Arg(100)->Arg(200)->Unit(benchmark::kMicrosecond);

// GPU: a batch of frames (prepare on the CPU, vote on the GPU, peaks on the CPU).
void BM_GpuBatch(benchmark::State& state) {
  std::string reason;
  if (!pano::CudaAvailable(&reason)) {
    state.SkipWithError(("no CUDA device: " + reason).c_str());
    return;
  }
  Threads();
  const Setup& s = Get();
  std::vector<pano::EdgeMap> frames(static_cast<size_t>(state.range(0)), s.edges);
  std::vector<pano::WholeImageResult> out;
  pano::GpuTiming t;
  double kernel_ms = 0;
  for (auto _ : state) {
    if (!pano::HoughWholeImageGpu(s.ph, frames, &out, &reason, &t)) {
      state.SkipWithError(reason.c_str());
      return;
    }
    kernel_ms += t.kernel_ms;
  }
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(frames.size()),
                                                      benchmark::Counter::kIsIterationInvariantRate);
  state.counters["kernel_ms_per_frame"] = kernel_ms / state.iterations() / frames.size();
}
BENCHMARK(BM_GpuBatch)->Arg(1)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();

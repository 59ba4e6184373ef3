// panosim rendering: one 500 x 500 frame of the paper-synthetic preset with
// 3 x 3 supersampling (no noise), 1 and 2 threads. The per-pixel rays
// are precomputed once (outside the timed loop), as panosim does per sequence.
#include <benchmark/benchmark.h>

#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"

namespace {

void BM_RenderPaperSynthetic(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  const pano::SequenceCase c = pano::MakePreset("paper-synthetic");
  pano::RenderOptions o = c.options;
  o.supersample = static_cast<int>(state.range(1));
  o.num_threads = threads;
  const pano::Scene scene = pano::Scene::FromMap(c.map, true);
  const pano::Renderer r(c.calib.sensor, scene, c.map.sensor_height, o);
  size_t i = 0;
  for (auto _ : state) {
    cv::Mat img = r.Render(c.poses[i % c.poses.size()], static_cast<int>(i));
    benchmark::DoNotOptimize(img.data);
    ++i;
  }
  state.counters["threads"] = threads;
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderPaperSynthetic)->Args({1, 3})->Args({2, 3})->Unit(benchmark::kMillisecond)->UseRealTime();

// The same with the paper-real options (640 x 480, noise, blur, gradient).
void BM_RenderPaperReal(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  const pano::SequenceCase c = pano::MakePreset("paper-real");
  pano::RenderOptions o = c.options;
  o.num_threads = threads;
  const pano::Scene scene = pano::Scene::FromMap(c.map, true);
  const pano::Renderer r(c.calib.sensor, scene, c.map.sensor_height, o);
  size_t i = 0;
  for (auto _ : state) {
    cv::Mat img = r.Render(c.poses[i % c.poses.size()], static_cast<int>(i));
    benchmark::DoNotOptimize(img.data);
    ++i;
  }
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderPaperReal)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Once per sequence: the per-subsample reflected rays.
void BM_RayTable(benchmark::State& state) {
  const pano::SequenceCase c = pano::MakePreset("paper-synthetic");
  for (auto _ : state) {
    pano::RayTable t(c.calib.sensor, 3);
    benchmark::DoNotOptimize(t.rays().data());
  }
}
BENCHMARK(BM_RayTable)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
BENCHMARK_MAIN();

// Throughput of panoloc's methods against decoding alone, on one panosim case
// folder (PANO_BENCH_CASE=DIR holding video.mp4, calib.yaml, map.yaml and
// case.yaml; tools/bench_vertex.sh renders them). In one run:
//  - BM_DecodeOnly: a plain cv::VideoCapture read loop over the video;
//  - BM_Panoloc/0 (junction), /1 (vertex): LocalizeVideo, the whole of
//    panoloc's per-video work (decoding ahead on its own thread, prediction,
//    tracking, triangulation, CSV), table loaded once outside the loop, with
//    panoloc's thread count for one video (cores - 1 for the landmarks);
//  - BM_VertexMeasure: the vertex tracker on every landmark predicted in a
//    frame (window warps, integral images, correlation), 1 and 2 threads;
//    BM_VertexFullWarp: the whole quasi-cylindrical view (not done per frame
//    by panoloc: only the search windows are warped), 1 and 2 threads.
// Every benchmark reports frames_per_s; the throughput ratio is panoloc's
// frames/s over decode-only's.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <thread>

#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/scene/scene.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/track/vertex_tracker.h"

namespace {

std::string CaseDir() {
  const char* d = std::getenv("PANO_BENCH_CASE");
  return d ? d : "";
}

void BM_DecodeOnly(benchmark::State& state) {
  const std::string dir = CaseDir();
  if (dir.empty()) return state.SkipWithError("set PANO_BENCH_CASE to a panosim case folder");
  long frames = 0;
  for (auto _ : state) {
    cv::VideoCapture cap(dir + "/video.mp4");
    if (!cap.isOpened()) return state.SkipWithError("cannot open video.mp4");
    cv::Mat frame;
    while (cap.read(frame)) {
      benchmark::DoNotOptimize(frame.data);
      ++frames;
    }
  }
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DecodeOnly)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

void BM_Panoloc(benchmark::State& state) {
  const std::string dir = CaseDir();
  if (dir.empty()) return state.SkipWithError("set PANO_BENCH_CASE to a panosim case folder");
  pano::VideoRunOptions run;
  run.localizer.method = state.range(0) ? pano::TrackingMethod::kVertex : pano::TrackingMethod::kJunction;
  pano::SharedResources res;
  res.calib_path = dir + "/calib.yaml";
  res.calib = pano::ReadCalibration(res.calib_path);
  res.map = pano::ReadMap(dir + "/map.yaml");
  res.table = pano::TableForMap(res.calib, res.map, true);
  pano::VideoJob job;
  job.input = dir + "/video.mp4";
  job.init = *pano::InitialPoseBeside(job.input);
  job.output = (std::filesystem::temp_directory_path() / "pano_bench_vertex.csv").string();
  // As panoloc does for one video: one core is left to the decoding thread.
  run.localizer.num_threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) - 1);
  long frames = 0, ok = 0;
  for (auto _ : state) {
    const pano::VideoSummary s = pano::LocalizeVideo(job, res, run);
    if (s.end == pano::VideoEnd::kFailed) return state.SkipWithError(s.error.c_str());
    frames += s.frames;
    ok += s.n_ok;
  }
  std::filesystem::remove(job.output);
  state.SetLabel(pano::TrackingMethodName(run.localizer.method));
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
  state.counters["ok_fraction"] = frames ? static_cast<double>(ok) / frames : 0.0;
}
BENCHMARK(BM_Panoloc)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

// One decoded frame, the tracker and the landmarks predicted at the case's
// initial pose.
struct Frame0 {
  pano::Calibration calib;
  pano::Map map;
  cv::Mat grey;
  std::vector<pano::Landmark> landmarks;
  bool ok = false;
  explicit Frame0(const std::string& dir) {
    calib = pano::ReadCalibration(dir + "/calib.yaml");
    map = pano::ReadMap(dir + "/map.yaml");
    cv::VideoCapture cap(dir + "/video.mp4");
    cv::Mat bgr;
    if (!cap.read(bgr)) return;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    landmarks = pano::LandmarksFromMap(map);
    ok = true;
  }
};

void BM_VertexFullWarp(benchmark::State& state) {
  const std::string dir = CaseDir();
  if (dir.empty()) return state.SkipWithError("set PANO_BENCH_CASE to a panosim case folder");
  const int threads = static_cast<int>(state.range(0));
  const Frame0 f(dir);
  if (!f.ok) return state.SkipWithError("cannot read the first frame");
  pano::VertexTracker t(f.calib.sensor, pano::VertexOptions());
  cv::Mat view;
  for (auto _ : state) {
    t.view().Warp(f.grey, &view, threads);
    benchmark::DoNotOptimize(view.data);
  }
  state.counters["threads"] = static_cast<double>(state.range(0));
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_VertexFullWarp)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_VertexMeasure(benchmark::State& state) {
  const std::string dir = CaseDir();
  if (dir.empty()) return state.SkipWithError("set PANO_BENCH_CASE to a panosim case folder");
  const int threads = static_cast<int>(state.range(0));
  const Frame0 f(dir);
  if (!f.ok) return state.SkipWithError("cannot read the first frame");
  pano::VertexTracker t(f.calib.sensor, pano::VertexOptions());
  t.BeginFrame(f.grey);
  const pano::Scene scene = pano::Scene::FromMap(f.map, false);
  const auto table = pano::TableForMap(f.calib, f.map, true);
  const std::vector<pano::PredictedLandmark> p =
      pano::PredictLandmarks(f.landmarks, f.map, scene, f.calib.sensor, *table,
                             *pano::InitialPoseBeside(dir + "/video.mp4"), pano::PredictionOptions());
  const int n = static_cast<int>(p.size());
  std::vector<pano::LandmarkMeasurement> m(p.size());
  for (auto _ : state) {
    t.BeginFrame(f.grey);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (int i = 0; i < n; ++i) m[i] = t.Measure(p[i], 8.0);
    benchmark::DoNotOptimize(m.data());
  }
  state.counters["landmarks"] = n;
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_VertexMeasure)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();

// panoloc's throughput against decoding alone, on the same video, in one run
// (issue: the ratio must be at least 0.8). The paper-synthetic preset is
// rendered once to a temporary folder; the E(D,Z) table is built once, as
// panocalib's --lut would have done.
//   bench_panoloc --benchmark_out=panoloc.json --benchmark_out_format=json
// tools/bench_panoloc.sh prints the ratio.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <thread>
#include <opencv2/videoio.hpp>

#include "panotrack/io/map.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"
#include "panotrack/pipeline/panoloc.h"

namespace {

struct Fixture {
  std::string dir;
  pano::SequenceCase c;
  std::shared_ptr<const pano::RadiusTable> table;
  // As in one panoloc run over several videos: the PH tables are built once.
  std::shared_ptr<pano::PhTableCache> ph_tables;
  Fixture() {
    dir = (std::filesystem::temp_directory_path() / "pano_bench_panoloc").string();
    c = pano::MakePreset(getenv("PANO_BENCH_PRESET") ? getenv("PANO_BENCH_PRESET") : "paper-synthetic");
    pano::SequenceWriteOptions w;
    w.overwrite = true;
    pano::WriteSequence(c, dir, w);
    table = pano::TableForMap(c.calib, pano::ReadMap(dir + "/map.yaml"), true);
    ph_tables = pano::MakeTrackingPhTables(table);
  }
};

const Fixture& Get() {
  static const Fixture f;
  return f;
}

void BM_DecodeOnly(benchmark::State& state) {
  const Fixture& f = Get();
  long frames = 0;
  for (auto _ : state) {
    cv::VideoCapture cap(f.dir + "/video.mp4", cv::CAP_FFMPEG);
    cv::Mat frame;
    while (cap.read(frame)) ++frames;
  }
  state.SetItemsProcessed(frames);
}
BENCHMARK(BM_DecodeOnly)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

void BM_Panoloc(benchmark::State& state) {
  const Fixture& f = Get();
  pano::SharedResources res;
  res.calib = f.c.calib;
  res.calib_path = f.dir + "/calib.yaml";
  res.map = pano::ReadMap(f.dir + "/map.yaml");
  res.table = f.table;
  res.ph_tables = f.ph_tables;
  pano::VideoJob job;
  job.input = f.dir + "/video.mp4";
  job.output = f.dir + "/est.csv";
  job.init = f.c.poses.front();
  job.gt = f.dir + "/gt.csv";
  pano::VideoRunOptions run;
  // As panoloc does for one video: one core is left to the decoding thread.
  run.localizer.num_threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) - 1);
  long frames = 0;
  double rms = 0;
  for (auto _ : state) {
    const pano::VideoSummary s = pano::LocalizeVideo(job, res, run);
    if (!s.ok) state.SkipWithError(s.error.c_str());
    frames += s.frames;
    rms = s.accuracy.rms;
  }
  state.SetItemsProcessed(frames);
  state.counters["position_rms"] = rms;
}
BENCHMARK(BM_Panoloc)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();

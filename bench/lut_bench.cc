// E(D,Z) table: building a 1024 x 1024 table (OpenMP) against one thread, and
// the cost of a lookup against the exact model's reflection solve.
#include <benchmark/benchmark.h>

#include <random>

#include "panotrack/lut/radius_table.h"

namespace {

pano::Sensor PaperSensor() {
  return pano::MakeSphereSensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1);
}
pano::LutRanges PaperRanges() { return {10.0, 450.0, -30.0, 90.0}; }

void BM_BuildTable1024(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  const pano::Sensor s = PaperSensor();
  for (auto _ : state) {
    pano::RadiusTable t = pano::RadiusTable::Build(s, PaperRanges(), pano::LutSize(), threads);
    benchmark::DoNotOptimize(t);
  }
  state.counters["threads"] = threads;
}
BENCHMARK(BM_BuildTable1024)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LookupRadius(benchmark::State& state) {
  static const pano::RadiusTable t = pano::RadiusTable::Build(PaperSensor(), PaperRanges());
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> d(20, 400), z(-25, 80);
  std::vector<std::pair<double, double>> q(4096);
  for (auto& p : q) p = {d(rng), z(rng)};
  size_t i = 0;
  for (auto _ : state) {
    double r = 0;
    benchmark::DoNotOptimize(t.radius(q[i].first, q[i].second, &r));
    benchmark::DoNotOptimize(r);
    i = (i + 1) & 4095;
  }
}
BENCHMARK(BM_LookupRadius);

void BM_ExactRadius(benchmark::State& state) {
  const pano::Sensor s = PaperSensor();
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> d(20, 400), z(-25, 80);
  std::vector<std::pair<double, double>> q(4096);
  for (auto& p : q) p = {d(rng), z(rng)};
  size_t i = 0;
  for (auto _ : state) {
    double r = 0;
    benchmark::DoNotOptimize(s.image_radius(q[i].first, q[i].second, &r));
    benchmark::DoNotOptimize(r);
    i = (i + 1) & 4095;
  }
}
BENCHMARK(BM_ExactRadius);

}  // namespace

BENCHMARK_MAIN();

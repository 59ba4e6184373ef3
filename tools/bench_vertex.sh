#!/usr/bin/env bash
# Vertex method throughput for BENCHMARKS.md ("## Vertex method throughput").
#
# Renders the paper presets with panosim, then runs bench_vertex on each video:
# in one run it times a plain cv::VideoCapture read loop (decode-only) and
# panoloc's per-video work (LocalizeVideo) with --method junction and
# --method vertex, repetitions interleaved at random so that both see the same
# machine load. Prints a markdown table: frames/s (median of the repetitions)
# and the throughput ratio = panoloc frames/s / decode-only frames/s.
#
# Usage: tools/bench_vertex.sh [BUILD_DIR] [REPETITIONS]
#   BUILD_DIR: holds bin/panosim and bin/bench_vertex (default: build)
#   PANO_BENCH_DIR: where the cases and JSON go (default: a temporary folder)
set -euo pipefail
build=${1:-build}
reps=${2:-5}
bin=$build/bin
for exe in panosim bench_vertex; do
  [[ -x $bin/$exe ]] || { echo "bench_vertex.sh: $bin/$exe not built (make -C $build $exe)" >&2; exit 1; }
done
work=${PANO_BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work"
for preset in paper-synthetic paper-real; do
  [[ -f $work/$preset/video.mp4 ]] || "$bin/panosim" sequence --preset "$preset" -o "$work/$preset" --force -q
  PANO_BENCH_CASE=$work/$preset "$bin/bench_vertex" \
    --benchmark_filter='BM_DecodeOnly|BM_Panoloc|BM_Vertex' \
    --benchmark_repetitions="$reps" --benchmark_enable_random_interleaving=true \
    --benchmark_out="$work/$preset.json" --benchmark_out_format=json >"$work/$preset.log" 2>&1
done
python3 - "$work" <<'PY'
import json, os, statistics, sys
work = sys.argv[1]
ctx = json.load(open(os.path.join(work, "paper-synthetic.json")))["context"]
print(f"Machine: {ctx.get('num_cpus')} cpus at {ctx.get('mhz_per_cpu')} MHz, load average "
      f"{', '.join(f'{x:.1f}' for x in ctx.get('load_avg', []))} at the start, {ctx.get('date')}; "
      f"median of the repetitions, decode-only and panoloc interleaved at random in one run.\n")
print("| preset | decode-only frames/s | junction frames/s | junction ratio | vertex frames/s | vertex ratio | vertex: all landmarks of a frame, search 8 px (ms, 1 / 2 threads) | whole view warp (ms, 1 / 2 threads) |")
print("|---|---|---|---|---|---|---|---|")
for preset in ("paper-synthetic", "paper-real"):
    runs = json.load(open(os.path.join(work, preset + ".json")))["benchmarks"]
    def med(prefix, key="frames_per_s"):
        v = [b[key] for b in runs if b.get("run_type") == "iteration" and b["name"].startswith(prefix)]
        return statistics.median(v) if v else float("nan")
    dec = med("BM_DecodeOnly")
    j, v = med("BM_Panoloc/0/"), med("BM_Panoloc/1/")
    warp = [1e3 / med(f"BM_VertexFullWarp/{t}/") for t in (1, 2)]
    meas = [1e3 / med(f"BM_VertexMeasure/{t}/") for t in (1, 2)]
    print(f"| {preset} | {dec:.0f} | {j:.0f} | {j/dec:.3f} | {v:.0f} | {v/dec:.3f} | "
          f"{meas[0]:.2f} / {meas[1]:.2f} | {warp[0]:.2f} / {warp[1]:.2f} |")
PY

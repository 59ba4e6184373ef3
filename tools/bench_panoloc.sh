#!/usr/bin/env bash
# panoloc throughput / decode-only throughput on the same video, one run.
# Usage: tools/bench_panoloc.sh [BUILD_DIR]   (PANO_BENCH_PRESET=paper-real for the other preset)
set -euo pipefail
build=${1:-build}
out=$(mktemp -d)
"$build/bin/bench_panoloc" --benchmark_out="$out/panoloc.json" --benchmark_out_format=json >/dev/null
python3 - "$out/panoloc.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
rate = {b["name"].split("/")[0]: b["items_per_second"] for b in d["benchmarks"]}
dec, loc = rate["BM_DecodeOnly"], rate["BM_Panoloc"]
ctx = d["context"]
print(f"machine: {ctx.get('num_cpus')} cpus at {ctx.get('mhz_per_cpu')} MHz, {ctx.get('date')}")
print(f"decode only : {dec:8.1f} frames/s")
print(f"panoloc     : {loc:8.1f} frames/s (decode + tracking + triangulation + CSV)")
print(f"ratio       : {loc/dec:.3f}  (target >= 0.8; the paper's prototype ran at 1.3 Hz)")
PY

#!/usr/bin/env bash
# Calibration figures quoted in BENCHMARKS.md ("panocalib calibration") and
# docs/calibration.md: panotrack's conic and sphere models against OpenCV's
# cv::omnidir::calibrate on the same detected corners, and the time of a whole
# `panocalib calibrate` run on the 15 real miniomni images.
#   tools/bench_calibration.sh [BUILD_DIR] [TARGETS.yaml]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build-calib}"
targets="${2:-$root/../shared/data/real/miniomni/targets.yaml}"
cmake --build "$build" -j2 --target panocalib calibrate_compare > /dev/null
echo "== same corners: conic, sphere, OpenCV omnidir"
"$build/bin/calibrate_compare" "$targets"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
for model in conic sphere; do
  echo "== panocalib calibrate --model $model (whole pipeline, wall time)"
  start=$(date +%s.%N)
  "$build/bin/panocalib" calibrate "$targets" -o "$out/$model.yaml" --model "$model" \
    --lut "$out/$model.lut" --report "$out/$model.png" > "$out/$model.txt" 2> "$out/$model.err"
  end=$(date +%s.%N)
  grep -E "RMS reprojection|boards used|no board|time:" "$out/$model.txt" || true
  echo "wall time $(echo "$end - $start" | bc) s (including the LUT and the report)"
done

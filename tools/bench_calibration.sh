#!/usr/bin/env bash
# Calibration figures quoted in BENCHMARKS.md ("panocalib calibration") and
# docs/calibration.md:
#   1. synthetic: `panosim targets --auto N --noise 2` for several seeds,
#      calibrated with known and with unknown board poses, errors against the
#      rendered truth (the issue's bounds: focal 0.5 %, centre 0.5 px, mirror
#      1 %, RMS 0.3 px; twice those with unknown poses);
#   2. real: panotrack's conic and sphere models against OpenCV's
#      cv::omnidir::calibrate on the same corners (calibrate_compare), and the
#      wall time of whole `panocalib calibrate` runs on the 15 miniomni images;
#   3. held-out: calibrate_compare's 5-fold cross-validation on the same
#      corners (each model fitted to 4/5 of the boards, only the held-out
#      boards' poses fitted through it; training and held-out RMS, the conic's
#      focal length per fold, the conic refitted with its focal held).
#   tools/bench_calibration.sh [BUILD_DIR] [TARGETS.yaml] [N_IMAGES] [SEEDS]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build-calib}"
targets="${2:-$root/../shared/data/real/miniomni/targets.yaml}"
n_images="${3:-14}"
seeds="${4:-1 2 3 4 5 6}"
cmake --build "$build" -j2 --target panocalib panosim calibrate_compare > /dev/null
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

# Top-level "key: value" of a calibration YAML.
value() { awk -v k="$2" -F': *' '$1 == k { print $2; exit }' "$1"; }
compare() {  # truth.yaml fitted.yaml label
  local t="$1" f="$2"
  awk -v label="$3" \
    -v f0="$(value "$t" focal_px)" -v f1="$(value "$f" focal_px)" \
    -v x0="$(value "$t" cx)" -v x1="$(value "$f" cx)" -v y0="$(value "$t" cy)" -v y1="$(value "$f" cy)" \
    -v r0="$(value "$t" mirror_radius)" -v r1="$(value "$f" mirror_radius)" \
    -v d0="$(value "$t" mirror_distance)" -v d1="$(value "$f" mirror_distance)" \
    -v rms="$(value "$f" rms_px)" -v used="$(value "$f" images_used)" -v fs="$(value "$f" focal_px_std)" \
    'BEGIN { printf "%-22s boards %2d  focal %+6.2f %% (std %.2f %%)  cx %+6.3f  cy %+6.3f px  radius %+6.2f %%  distance %+6.2f %%  RMS %.3f px\n",
             label, used, 100 * (f1 / f0 - 1), 100 * fs / f1, x1 - x0, y1 - y0, 100 * (r1 / r0 - 1), 100 * (d1 / d0 - 1), rms }'
}

echo "== synthetic: panosim targets --auto $n_images --noise 2 (paper-real sphere), errors against the truth"
for seed in $seeds; do
  d="$out/s$seed"
  "$build/bin/panosim" targets --calib "$root/calib/paper-real.yaml" --board 9,6,3 --auto "$n_images" \
    --noise 2 --seed "$seed" -o "$d" -q
  for kind in known unknown; do
    file="$d/targets.yaml"
    [ "$kind" = unknown ] && file="$d/targets_unknown.yaml"
    start=$(date +%s.%N)
    "$build/bin/panocalib" calibrate "$file" -o "$d/$kind.yaml" > "$d/$kind.txt"
    end=$(date +%s.%N)
    compare "$d/truth.yaml" "$d/$kind.yaml" "seed $seed, $kind poses" | tr -d '\n'
    echo "  $(echo "$end - $start" | bc) s"
  done
done

echo
echo "== real: same corners: conic, sphere, OpenCV omnidir; then 5-fold cross-validation"
"$build/bin/calibrate_compare" "$targets" | grep -v "^  [a-zA-Z0-9_]*\.\(png\|jpg\) \|^  omnidir:"
for model in conic sphere; do
  echo "== panocalib calibrate --model $model (whole pipeline, wall time)"
  start=$(date +%s.%N)
  "$build/bin/panocalib" calibrate "$targets" -o "$out/$model.yaml" --model "$model" \
    --lut "$out/$model.lut" --report "$out/$model.png" > "$out/$model.txt" 2> "$out/$model.err"
  end=$(date +%s.%N)
  grep -E "RMS reprojection|boards used|no board|time:" "$out/$model.txt" || true
  echo "wall time $(echo "$end - $start" | bc) s (including the LUT and the report)"
done

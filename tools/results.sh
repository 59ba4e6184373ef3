#!/usr/bin/env bash
# Reproduces the README's results table: renders the paper's experiments
# (and the harder presets) with panosim, localises them with panoloc (both
# methods) and prints a Markdown table beside the paper's figures.
# Usage: tools/results.sh [BUILD_DIR] [WORK_DIR]
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d)}
mkdir -p "$work"
bin="$build/bin"
for tool in panosim panoloc; do
  [ -x "$bin/$tool" ] || { echo "results.sh: $bin/$tool not found (build first)" >&2; exit 1; }
done
methods="junction"
if grep -q vertex <("$bin/panoloc" --help 2>/dev/null); then methods="junction vertex"; fi
# The paper's experiments, then real conditions (fast turns, motion blur, all
# factors together) and 3000-frame runs with kidnaps, without and with
# motion blur (about 5 minutes each to render on 2 cores; PRESETS=...
# chooses others).
presets=${PRESETS:-"paper-synthetic paper-real cluttered kidnap fast-turns motion-blur real-conditions long-run long-run-blur"}
declare -A paper_std=( ["paper-synthetic/junction"]="0.4" ["paper-synthetic/vertex"]="0.5"
                      ["paper-real/junction"]="3.7" ["paper-real/vertex"]="5" )
declare -A paper_out=( ["paper-synthetic/junction"]="0 %" ["paper-synthetic/vertex"]="3 %"
                      ["paper-real/junction"]="0" ["paper-real/vertex"]="1 frame" )
echo "| preset | method | frames ok | std | RMS | max | heading RMS (deg) | outliers | paper: std | paper: outliers |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for p in $presets; do
  # A folder already rendered there is reused (RENDER=1 renders it again).
  [[ -f $work/$p/video.mp4 && ${RENDER:-0} != 1 ]] || "$bin/panosim" sequence --preset "$p" -o "$work/$p" --force --quiet
  units=$(sed -n 's/^units: //p' "$work/$p/map.yaml")
  for m in $methods; do
    "$bin/panoloc" "$work/$p/video.mp4" --calib "$work/$p/calib.yaml" --map "$work/$p/map.yaml" \
      --method "$m" -o "$work/$p/$m.csv" --gt "$work/$p/gt.csv" --force -q --summary-json "$work/$p/$m.json"
    python3 - "$p" "$m" "$units" "${paper_std[$p/$m]:-}" "${paper_out[$p/$m]:-}" "$work/$p/$m.json" <<'PY'
import json, sys
preset, method, units, pstd, pout, path = sys.argv[1:7]
# panoloc's own accuracy summary (the one definition of std, RMS, outliers).
run = json.load(open(path))["inputs"][0]
if "accuracy" not in run:
    sys.exit(f"results.sh: no accuracy in {path}: {run.get('error')}")
a = run["accuracy"]
print(f"| {preset} | {method} | {a['tracked']}/{a['frames']} | {a['std']:.3f} {units} | {a['rms']:.3f} | "
      f"{a['max']:.3f} | {a['heading_rms_deg']:.3f} | {a['outliers']} ({a['outlier_percent']:.0f} %) | "
      f"{pstd + ' ' + units if pstd else '-'} | {pout or '-'} |")
PY
  done
done

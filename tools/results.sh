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
if "$bin/panoloc" --help 2>/dev/null | grep -q vertex; then methods="junction vertex"; fi
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
  "$bin/panosim" sequence --preset "$p" -o "$work/$p" --force --quiet
  units=$(sed -n 's/^units: //p' "$work/$p/map.yaml")
  for m in $methods; do
    summary=$("$bin/panoloc" "$work/$p/video.mp4" --calib "$work/$p/calib.yaml" --map "$work/$p/map.yaml" \
      --method "$m" -o "$work/$p/$m.csv" --gt "$work/$p/gt.csv" --force)
    python3 - "$p" "$m" "$units" "${paper_std[$p/$m]:-}" "${paper_out[$p/$m]:-}" "$summary" <<'PY'
import re, sys
preset, method, units, pstd, pout, summary = sys.argv[1:7]
# panoloc's own accuracy summary (the one definition of std, RMS, outliers).
num = r"([-0-9.]+)"
m = re.search(r"RMS " + num + r", std " + num + r", mean " + num + r", max " + num + r" \S+; heading error: RMS "
              + num + r", max " + num + r" deg; outliers (\d+) \(" + num + r" %\); frames tracked (\d+)/(\d+)", summary)
if not m:
    sys.exit("results.sh: no accuracy summary from panoloc:\n" + summary)
rms, std, mean, mx, hrms, hmax, outl, outp, ok, total = m.groups()
print(f"| {preset} | {method} | {ok}/{total} | {float(std):.3f} {units} | {float(rms):.3f} | {float(mx):.3f} | "
      f"{float(hrms):.3f} | {outl} ({float(outp):.0f} %) | {pstd + ' ' + units if pstd else '-'} | {pout or '-'} |")
PY
  done
done

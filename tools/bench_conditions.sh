#!/usr/bin/env bash
# panoloc's throughput on hard clips against the easy one, in one run: for
# each clip the frames/s of decoding alone (ffmpeg, 2 threads, to null) and of
# panoloc (junction and vertex methods), their ratio, and each clip's panoloc
# throughput relative to the easy clip's. Clips are rendered with panosim
# unless WORK_DIR already holds them (long-run takes about 5 minutes).
# Usage: tools/bench_conditions.sh [BUILD_DIR] [WORK_DIR]
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d)}
mkdir -p "$work"
bin="$build/bin"
clips=${CLIPS:-"paper-synthetic-1320 long-run long-run-blur motion-blur real-conditions"}
for c in $clips; do
  [ -f "$work/$c/video.mp4" ] && continue
  if [ "$c" = paper-synthetic-1320 ]; then
    # The easy clip: the paper's synthetic path, forth and back 10 times.
    "$bin/panosim" sequence --preset paper-synthetic -o "$work/ps66" --force --quiet --no-video --frames
    { echo "x,y,theta"; for k in 1 2 3 4 5 6 7 8 9 10; do
        awk -F, 'NR > 1 {print $3 "," $4 "," $5}' "$work/ps66/gt.csv"
        awk -F, 'NR > 1 {print $3 "," $4 "," $5}' "$work/ps66/gt.csv" | tac; done; } > "$work/ps1320.csv"
    "$bin/panosim" sequence --map "$work/ps66/map.yaml" --calib "$work/ps66/calib.yaml" --trajectory "$work/ps1320.csv" \
      -o "$work/$c" --force --quiet
  else
    "$bin/panosim" sequence --preset "$c" -o "$work/$c" --force --quiet
  fi
done
seconds() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1 || true; t1=$(date +%s.%N); echo "$t1 - $t0" | bc -l; }
frames() { grep -c ',' "$1/gt.csv" | awk '{print $1 - 1}'; }
echo "| clip | frames | decode only (frames/s) | method | panoloc (frames/s) | ratio to decode | relative to the easy clip |"
echo "|---|---:|---:|---|---:|---:|---:|"
declare -A easy
for c in $clips; do
  n=$(frames "$work/$c")
  dec=$(seconds ffmpeg -loglevel error -threads 2 -i "$work/$c/video.mp4" -f null -)
  for m in junction vertex; do
    loc=$(seconds "$bin/panoloc" "$work/$c/video.mp4" --calib "$work/$c/calib.yaml" --map "$work/$c/map.yaml" \
          --method "$m" -q --force -o "$work/$c/$m.csv")
    fps=$(echo "$n / $loc" | bc -l)
    [ "$c" = paper-synthetic-1320 ] && easy[$m]=$fps
    rel=$( [ -n "${easy[$m]:-}" ] && echo "$fps / ${easy[$m]}" | bc -l || echo 0)
    printf "| %s | %d | %.0f | %s | %.0f | %.2f | %.2f |\n" "$c" "$n" "$(echo "$n / $dec" | bc -l)" "$m" "$fps" \
      "$(echo "$dec / $loc" | bc -l)" "$rel"
  done
done

#!/usr/bin/env bash
# panoloc on concurrent 1080p streams, decoded on NVDEC and on the CPU,
# against the decode-only floor of the same decoding (bench_decode: panoloc's
# FrameSource, thread split and --hwaccel, no tracking), in one run. Renders
# its clip with panosim once (WORK_DIR keeps it): the paper's synthetic room
# seen at 1920 x 1080 (focal 1274.4 px), its path forth and back twice (264
# frames), noise sigma 2, x264 crf 18 (5.4 Mbit/s at 10 frames/s). A stream
# is COPIES copies of the clip in turn: STREAMS streams are one run with
# --jobs STREAMS over STREAMS x COPIES inputs; the single stream is one run
# with --jobs 1 over the first stream's copies. Times whole processes, REPEAT
# times each, interleaved, and prints a Markdown table of medians
# (ratio = panoloc frames/s over the floor's). Checks that the pose CSVs of
# the NVDEC and CPU runs are identical, and their accuracy against gt.csv.
#
# Usage: tools/bench_streams.sh [BUILD_DIR [WORK_DIR]]
# Environment: STREAMS (16), COPIES (4), REPEAT (3), HWACCELS ("cuda none").
set -euo pipefail

BUILD=${1:-build}
WORK=${2:-$(mktemp -d -t pano_bench_streams_XXXXXX)}
STREAMS=${STREAMS:-16}
COPIES=${COPIES:-4}
REPEAT=${REPEAT:-3}
read -r -a MODES <<<"${HWACCELS:-cuda none}"
PANOLOC=$BUILD/bin/panoloc
DECODE=$BUILD/bin/bench_decode
for tool in "$PANOLOC" "$DECODE"; do
  [[ -x $tool ]] || { echo "bench_streams: $tool not found (build panoloc and bench_decode)" >&2; exit 1; }
done
mkdir -p "$WORK"
echo "bench_streams: working in $WORK" >&2

render() {
  [[ -f $WORK/clip/video.mp4 ]] && return
  local panosim=$BUILD/bin/panosim
  [[ -x $panosim ]] || { echo "bench_streams: $panosim not found (needed to render the clip)" >&2; exit 1; }
  command -v ffmpeg >/dev/null || { echo "bench_streams: ffmpeg not found (needed to encode the clip)" >&2; exit 1; }
  "$panosim" sequence --preset paper-synthetic -o "$WORK/ps66" -q --force
  sed -e 's/^image_width:.*/image_width: 1920/' -e 's/^image_height:.*/image_height: 1080/' \
    -e 's/^focal_px:.*/focal_px: 1274.4/' -e 's/^cx:.*/cx: 959.5/' -e 's/^cy:.*/cy: 539.5/' \
    "$WORK/ps66/calib.yaml" >"$WORK/calib1080.yaml"
  { echo "x,y,theta"
    for _ in 1 2; do
      awk -F, 'NR > 1 {print $3 "," $4 "," $5}' "$WORK/ps66/gt.csv"
      awk -F, 'NR > 1 {print $3 "," $4 "," $5}' "$WORK/ps66/gt.csv" | tac
    done; } >"$WORK/path264.csv"
  "$panosim" sequence --map "$WORK/ps66/map.yaml" --calib "$WORK/calib1080.yaml" --trajectory "$WORK/path264.csv" \
    --noise 2 --supersample 1 --frames --no-video -o "$WORK/render" -q --force
  ffmpeg -nostdin -loglevel error -y -framerate 10 -i "$WORK/render/frames/frame_%04d.png" -c:v libx264 -crf 18 \
    -pix_fmt yuv420p "$WORK/render/video.mp4"
  mkdir -p "$WORK/clip"
  cp "$WORK/render/video.mp4" "$WORK/render/gt.csv" "$WORK/render/case.yaml" "$WORK/render/calib.yaml" \
    "$WORK/render/map.yaml" "$WORK/clip/"
  rm -rf "$WORK/render/frames"
}
render
FRAMES_PER_CLIP=$(($(wc -l <"$WORK/clip/gt.csv") - 1))

# The streams: s<stream><copy>/video.mp4 with the clip's gt.csv and case.yaml.
rm -rf "$WORK/s"
INPUTS=() FIRST=()
for ((i = 0; i < STREAMS; ++i)); do
  for ((k = 1; k <= COPIES; ++k)); do
    d=$WORK/s/s$(printf %02d $i)_$k
    mkdir -p "$d"
    cp "$WORK/clip/video.mp4" "$d/video.mp4"  # distinct files (panoloc refuses one file twice)
    cp "$WORK/clip/gt.csv" "$WORK/clip/case.yaml" "$d/"
    INPUTS+=("$d/video.mp4")
    ((i == 0)) && FIRST+=("$d/video.mp4")
  done
done
PANOLOC_ARGS=(--calib "$WORK/clip/calib.yaml" --map "$WORK/clip/map.yaml" --table-cache "$WORK/cache" --gt auto -q --force)
# A warm table cache.
"$PANOLOC" "${PANOLOC_ARGS[@]}" -o "$WORK/warm.csv" "${FIRST[0]}"

now() { date +%s.%N; }
# run KEY COMMAND...: appends the wall time to $WORK/t_KEY.
run() {
  local key=$1; shift
  local t0; t0=$(now)
  "$@" >/dev/null
  echo "$(now) $t0" | awk '{printf "%.4f\n", $1 - $2}' >>"$WORK/t_$key"
}
rm -f "$WORK"/t_*
for ((r = 0; r < REPEAT; ++r)); do
  for mode in "${MODES[@]}"; do
    run "one_floor_$mode" "$DECODE" --jobs 1 --hwaccel "$mode" "${FIRST[@]}"
    rm -rf "$WORK/o1_$mode"
    run "one_panoloc_$mode" "$PANOLOC" "${PANOLOC_ARGS[@]}" --hwaccel "$mode" --jobs 1 --out-dir "$WORK/o1_$mode" \
      "${FIRST[@]}"
    run "n_floor_$mode" "$DECODE" --jobs "$STREAMS" --hwaccel "$mode" "${INPUTS[@]}"
    rm -rf "$WORK/on_$mode"
    run "n_panoloc_$mode" "$PANOLOC" "${PANOLOC_ARGS[@]}" --hwaccel "$mode" --jobs "$STREAMS" \
      --out-dir "$WORK/on_$mode" --summary-json "$WORK/on_$mode.json" "${INPUTS[@]}"
  done
done

median() { sort -g "$WORK/t_$1" | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
echo "| streams | decoding | decode-only frames/s | panoloc frames/s | ratio |"
echo "|---:|---|---:|---:|---:|"
for set in one n; do
  if [[ $set == one ]]; then n=1; else n=$STREAMS; fi
  frames=$((n * COPIES * FRAMES_PER_CLIP))
  for mode in "${MODES[@]}"; do
    floor=$(median "${set}_floor_$mode")
    loc=$(median "${set}_panoloc_$mode")
    awk -v n="$n" -v m="$mode" -v f="$frames" -v a="$floor" -v b="$loc" \
      'BEGIN {printf "| %d | %s | %.0f | %.0f | %.2f |\n", n, (m == "cuda" ? "NVDEC" : m == "none" ? "CPU" : m), f / a, f / b, a / b}'
  done
done
# The poses do not depend on where the frames were decoded.
if [[ " ${MODES[*]} " == *" cuda "* && " ${MODES[*]} " == *" none "* ]]; then
  if diff -r -q "$WORK/on_cuda" "$WORK/on_none" >/dev/null; then
    echo "pose CSVs of the NVDEC and CPU runs: identical ($((STREAMS * COPIES)) inputs)"
  else
    echo "pose CSVs of the NVDEC and CPU runs: DIFFER"; exit 1
  fi
fi
python3 - "$WORK/on_${MODES[0]}.json" <<'PY'
import json, sys
inputs = json.load(open(sys.argv[1]))["inputs"]
acc = [i["accuracy"] for i in inputs]
print("accuracy (%s): %d inputs, decoders %s, %d/%d frames ok, RMS at most %.3f units, %d outliers" % (
    sys.argv[1].rsplit("/", 1)[-1], len(inputs), sorted({i["decoder"] for i in inputs}),
    sum(i["ok"] for i in inputs), sum(i["frames"] for i in inputs), max(a["rms"] for a in acc),
    sum(a["outliers"] for a in acc)))
PY

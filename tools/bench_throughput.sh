#!/usr/bin/env bash
# panoloc's throughput against the decoding floor, in one run. Renders its
# clips with panosim (once; WORK_DIR keeps them), then times whole processes,
# interleaved, REPEAT times each, and prints a Markdown table of medians:
#   noisy   the paper's synthetic room, its path forth and back 10 times
#           (1320 frames, 500 x 500), noise sigma NOISE, x264 crf 18;
#   hires   the same room and path 5 times (660 frames) seen at 1600 x 1200
#           (focal 1416 px), noise sigma NOISE, crf 18;
#   batch   4 videos (the noisy clip's quarters, each started without a
#           pose) in one panoloc run with --jobs 2;
#   hard    the long-run preset: 3000 frames, turns up to 10 degrees per
#           frame, two kidnaps;
#   short   the 66-frame paper-synthetic clip with a warm table cache;
#   search  120 frames of the same room at poses drawn from the noisy
#           clip's path in a fixed shuffled order: every frame a kidnap,
#           found by a room-wide search (its cost, not a target).
# The floor is `ffmpeg -threads 2 -i VIDEO -f null -`; for the batch, the
# faster of the 4 videos one after another with 2 threads each and two at a
# time with 1 thread each. panoloc runs with its defaults (--threads 0,
# the table cache warm). ratio = floor wall time / panoloc wall time.
# Also checks that the pose CSVs of repeated runs are identical.
#
# Usage: tools/bench_throughput.sh [BUILD_DIR [WORK_DIR]]
# Environment: REPEAT (5), NOISE (4), CLIPS ("noisy hires batch hard short search"),
#   PANOLOC_ARGS (extra panoloc options, e.g. "--method vertex").
set -euo pipefail

BUILD=${1:-build}
WORK=${2:-$(mktemp -d -t pano_bench_throughput_XXXXXX)}
REPEAT=${REPEAT:-5}
NOISE=${NOISE:-4}
CLIPS=${CLIPS:-"noisy hires batch hard short search"}
read -r -a EXTRA <<<"${PANOLOC_ARGS:-}"
PANOLOC=$BUILD/bin/panoloc
PANOSIM=$BUILD/bin/panosim
for tool in "$PANOLOC" "$PANOSIM"; do
  [[ -x $tool ]] || { echo "bench_throughput: $tool not found (build panoloc and panosim)" >&2; exit 1; }
done
command -v ffmpeg >/dev/null || { echo "bench_throughput: ffmpeg not found" >&2; exit 1; }
mkdir -p "$WORK"
echo "bench_throughput: working in $WORK" >&2

# x264 at crf 18 from a folder of PNG frames (what a camera recording at
# high quality looks like; panosim's own writer leaves the rate to OpenCV).
encode() {  # FRAMES_DIR FIRST COUNT OUT
  ffmpeg -nostdin -loglevel error -y -framerate 10 -start_number "$2" -i "$1/frame_%04d.png" -frames:v "$3" \
    -c:v libx264 -crf 18 -pix_fmt yuv420p "$4"
}
# The paper-synthetic path forth and back K times, as a trajectory CSV.
path_times() {  # K OUT
  { echo "x,y,theta"
    for ((k = 0; k < $1; ++k)); do
      awk -F, 'NR > 1 {print $3 "," $4 "," $5}' "$WORK/ps66/gt.csv"
      awk -F, 'NR > 1 {print $3 "," $4 "," $5}' "$WORK/ps66/gt.csv" | tac
    done; } >"$2"
}
# 120 poses of the noisy clip's path in a fixed shuffled order (7919 k
# modulo the prime 1321 permutes 1 .. 1320).
path_jumps() {  # OUT
  { echo "x,y,theta"
    awk -F, 'NR > 1 {print ((NR * 7919) % 1321) "," $0}' "$WORK/path1320.csv" | sort -t, -k1,1n | awk 'NR <= 120' |
      cut -d, -f2-; } >"$1"
}
render() {
  [[ -f $WORK/ps66/video.mp4 ]] || "$PANOSIM" sequence --preset paper-synthetic -o "$WORK/ps66" -q --force
  if [[ ! -f $WORK/noisy/video.mp4 ]]; then
    path_times 10 "$WORK/path1320.csv"
    "$PANOSIM" sequence --map "$WORK/ps66/map.yaml" --calib "$WORK/ps66/calib.yaml" --trajectory "$WORK/path1320.csv" \
      --noise "$NOISE" --frames --no-video -o "$WORK/noisy" -q --force
    encode "$WORK/noisy/frames" 0 1320 "$WORK/noisy/video.mp4"
  fi
  if [[ ! -f $WORK/hires/video.mp4 ]]; then
    path_times 5 "$WORK/path660.csv"
    sed -e 's/^image_width:.*/image_width: 1600/' -e 's/^image_height:.*/image_height: 1200/' \
      -e 's/^focal_px:.*/focal_px: 1416.0/' -e 's/^cx:.*/cx: 799.5/' -e 's/^cy:.*/cy: 599.5/' \
      "$WORK/ps66/calib.yaml" >"$WORK/calib1600.yaml"
    "$PANOSIM" sequence --map "$WORK/ps66/map.yaml" --calib "$WORK/calib1600.yaml" --trajectory "$WORK/path660.csv" \
      --noise "$NOISE" --supersample 1 --frames --no-video -o "$WORK/hires" -q --force
    encode "$WORK/hires/frames" 0 660 "$WORK/hires/video.mp4"
  fi
  for q in 0 1 2 3; do
    [[ -f $WORK/batch/q$q.mp4 ]] && continue
    mkdir -p "$WORK/batch"
    encode "$WORK/noisy/frames" $((q * 330)) 330 "$WORK/batch/q$q.mp4"
  done
  [[ -f $WORK/hard/video.mp4 ]] || "$PANOSIM" sequence --preset long-run -o "$WORK/hard" -q --force
  if [[ ! -f $WORK/search/video.mp4 ]]; then
    path_jumps "$WORK/jumps120.csv"
    "$PANOSIM" sequence --map "$WORK/ps66/map.yaml" --calib "$WORK/ps66/calib.yaml" --trajectory "$WORK/jumps120.csv" \
      --noise "$NOISE" -o "$WORK/search" -q --force
  fi
}

measure() {  # wall seconds of a command
  /usr/bin/time -f "%e" -o "$WORK/time.txt" "$@" >/dev/null 2>"$WORK/stderr.txt" ||
    { echo "bench_throughput: failed: $*" >&2; cat "$WORK/stderr.txt" >&2; exit 1; }
  cat "$WORK/time.txt"
}
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
decode() { ffmpeg -nostdin -loglevel error -threads "${2:-2}" -i "$1" -f null -; }
decode_pairs() { printf '%s\n' "$@" | xargs -P 2 -I{} ffmpeg -nostdin -loglevel error -threads 1 -i {} -f null -; }
decode_serial() { for v in "$@"; do decode "$v"; done; }

# panoloc's command for a clip, writing into DIR.
panoloc_cmd() {  # CLIP OUT_DIR
  local d=$WORK/$1 calib=$WORK/$1/calib.yaml
  case $1 in
    noisy | hard | search) echo "$PANOLOC" --calib "$calib" --map "$d/map.yaml" "$d/video.mp4" -o "$2/poses.csv" ;;
    hires) echo "$PANOLOC" --calib "$WORK/calib1600.yaml" --map "$WORK/ps66/map.yaml" "$d/video.mp4" -o "$2/poses.csv" ;;
    short) echo "$PANOLOC" --calib "$WORK/ps66/calib.yaml" --map "$WORK/ps66/map.yaml" "$WORK/ps66/video.mp4" \
      -o "$2/poses.csv" ;;
    batch) echo "$PANOLOC" --calib "$WORK/ps66/calib.yaml" --map "$WORK/ps66/map.yaml" --jobs 2 \
      "$d/q0.mp4" "$d/q1.mp4" "$d/q2.mp4" "$d/q3.mp4" --out-dir "$2" ;;
  esac
}
frames_of() {
  case $1 in noisy | batch) echo 1320 ;; hires) echo 660 ;; hard) echo 3000 ;; short) echo 66 ;; search) echo 120 ;; esac
}

render
echo
echo "| clip | frames | decode only s | panoloc s | decode-only / panoloc |"
echo "|---|---:|---:|---:|---:|"
for clip in $CLIPS; do
  read -r -a cmd <<<"$(panoloc_cmd "$clip" "$WORK/out-$clip")"
  cmd+=(--force -q --table-cache "$WORK/cache" "${EXTRA[@]}")
  mkdir -p "$WORK/out-$clip" "$WORK/ref-$clip"
  # A first run warms the table cache and gives the reference poses.
  read -r -a ref <<<"$(panoloc_cmd "$clip" "$WORK/ref-$clip")"
  "${ref[@]}" --force -q --table-cache "$WORK/cache" "${EXTRA[@]}" >/dev/null 2>&1 || true
  dec=() loc=()
  for ((i = 0; i < REPEAT; ++i)); do
    case $clip in
      batch)
        s=$(measure bash -c "$(declare -f decode); $(declare -f decode_serial); decode_serial $WORK/batch/q{0,1,2,3}.mp4")
        p=$(measure bash -c "$(declare -f decode_pairs); decode_pairs $WORK/batch/q{0,1,2,3}.mp4")
        dec+=("$(awk -v a="$s" -v b="$p" 'BEGIN { print (a < b) ? a : b }')") ;;
      short) dec+=("$(measure ffmpeg -nostdin -loglevel error -threads 2 -i "$WORK/ps66/video.mp4" -f null -)") ;;
      *) dec+=("$(measure ffmpeg -nostdin -loglevel error -threads 2 -i "$WORK/$clip/video.mp4" -f null -)") ;;
    esac
    /usr/bin/time -f "%e" -o "$WORK/time.txt" "${cmd[@]}" >/dev/null 2>"$WORK/stderr.txt" || true
    loc+=("$(cat "$WORK/time.txt" | tail -1)")
    for f in "$WORK/ref-$clip"/*.csv; do
      cmp -s "$f" "$WORK/out-$clip/$(basename "$f")" ||
        { echo "bench_throughput: $clip: $(basename "$f") differs from the first run's" >&2; exit 1; }
    done
  done
  d=$(printf '%s\n' "${dec[@]}" | median)
  l=$(printf '%s\n' "${loc[@]}" | median)
  printf "| %s | %d | %.3f | %.3f | **%.2f** |\n" "$clip" "$(frames_of "$clip")" "$d" "$l" \
    "$(awk -v d="$d" -v l="$l" 'BEGIN { print d / l }')"
done

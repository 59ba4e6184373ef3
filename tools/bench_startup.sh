#!/usr/bin/env bash
# panoloc's start-up and memory: on the 66-frame paper-synthetic clip, the
# wall time of decoding alone (ffmpeg -threads 2 ... -f null -) against
# panoloc with a cold table cache (the E(D,Z) table built and stored), a warm
# one (loaded) and none (--no-table-cache); then panoloc's peak RSS on the
# 3000-frame long-run clip and on the same clip looped to 30000 frames.
# Prints a Markdown table (medians of REPEAT runs).
#
# Usage: tools/bench_startup.sh [BUILD_DIR [WORK_DIR]]
#   BUILD_DIR  holds bin/panoloc and bin/panosim (default: build)
#   WORK_DIR   clips and caches; kept, and clips found there are reused
#              (default: a new temporary folder)
# Environment: REPEAT (5), THREADS (2: panoloc --threads, ffmpeg -threads),
#   LOOPS (10: copies of the 3000-frame clip in the long one; 0 skips the
#   memory part), SUPERSAMPLE (1: panosim --supersample of the long clip,
#   which takes minutes to render; the preset's own is 3).
set -euo pipefail

BUILD=${1:-build}
WORK=${2:-$(mktemp -d -t pano_bench_startup_XXXXXX)}
REPEAT=${REPEAT:-5}
THREADS=${THREADS:-2}
LOOPS=${LOOPS:-10}
SUPERSAMPLE=${SUPERSAMPLE:-1}
PANOLOC=$BUILD/bin/panoloc
PANOSIM=$BUILD/bin/panosim
for tool in "$PANOLOC" "$PANOSIM"; do
  [[ -x $tool ]] || { echo "bench_startup: $tool not found (build panoloc and panosim)" >&2; exit 1; }
done
for tool in ffmpeg /usr/bin/time; do
  command -v "$tool" >/dev/null || { echo "bench_startup: $tool not found" >&2; exit 1; }
done
mkdir -p "$WORK"
echo "bench_startup: working in $WORK" >&2

SHORT=$WORK/short
[[ -f $SHORT/video.mp4 ]] || "$PANOSIM" sequence --preset paper-synthetic -o "$SHORT" -q --force

# Wall seconds, CPU seconds (user + system) and peak RSS (KiB) of a
# command: "WALL CPU KIB".
measure() {
  /usr/bin/time -f "%e %U %S %M" -o "$WORK/time.txt" "$@" >/dev/null 2>&1
  awk 'END { printf "%s %.2f %s\n", $1, $2 + $3, $4 }' "$WORK/time.txt"
}
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

SHORT_RUN=("$PANOLOC" --calib "$SHORT/calib.yaml" --map "$SHORT/map.yaml" "$SHORT/video.mp4" --force -q
  --threads "$THREADS")

decode=() cold=() warm=() none=()
cpu_decode=() cpu_cold=() cpu_warm=() cpu_none=()
"${SHORT_RUN[@]}" -o "$WORK/warmup.csv" --table-cache "$WORK/cache-warm"
for ((i = 0; i < REPEAT; ++i)); do
  # Interleaved, so that a load on the machine touches every kind alike.
  read -r wall cpu _ < <(measure ffmpeg -nostdin -loglevel error -threads "$THREADS" -i "$SHORT/video.mp4" -f null -)
  decode+=("$wall") cpu_decode+=("$cpu")
  rm -rf "$WORK/cache-cold"
  read -r wall cpu _ < <(measure "${SHORT_RUN[@]}" -o "$WORK/cold.csv" --table-cache "$WORK/cache-cold")
  cold+=("$wall") cpu_cold+=("$cpu")
  read -r wall cpu _ < <(measure "${SHORT_RUN[@]}" -o "$WORK/warm.csv" --table-cache "$WORK/cache-warm")
  warm+=("$wall") cpu_warm+=("$cpu")
  read -r wall cpu _ < <(measure "${SHORT_RUN[@]}" -o "$WORK/none.csv" --no-table-cache)
  none+=("$wall") cpu_none+=("$cpu")
  cmp -s "$WORK/cold.csv" "$WORK/warm.csv" || { echo "bench_startup: cold and warm poses differ" >&2; exit 1; }
done
cd=$(printf '%s\n' "${cpu_decode[@]}" | median)
cc=$(printf '%s\n' "${cpu_cold[@]}" | median)
cw=$(printf '%s\n' "${cpu_warm[@]}" | median)
cn=$(printf '%s\n' "${cpu_none[@]}" | median)
d=$(printf '%s\n' "${decode[@]}" | median)
c=$(printf '%s\n' "${cold[@]}" | median)
w=$(printf '%s\n' "${warm[@]}" | median)
n=$(printf '%s\n' "${none[@]}" | median)
ratio() { awk -v d="$1" -v t="$2" 'BEGIN { printf "%.2f", (t > 0) ? d / t : 0 }'; }

echo
echo "66-frame paper-synthetic clip, median of $REPEAT runs, --threads $THREADS (ffmpeg -threads $THREADS):"
echo
echo "| run | wall s | decode-only / run (wall) | CPU s | decode-only / run (CPU) |"
echo "|---|---|---|---|---|"
echo "| ffmpeg decode only | $d | 1.00 | $cd | 1.00 |"
echo "| panoloc, no table cache | $n | $(ratio "$d" "$n") | $cn | $(ratio "$cd" "$cn") |"
echo "| panoloc, cold table cache (built, stored) | $c | $(ratio "$d" "$c") | $cc | $(ratio "$cd" "$cc") |"
echo "| panoloc, warm table cache (loaded) | $w | $(ratio "$d" "$w") | $cw | $(ratio "$cd" "$cw") |"

((LOOPS > 0)) || exit 0
LONG=$WORK/long
[[ -f $LONG/video.mp4 ]] ||
  "$PANOSIM" sequence --preset long-run -o "$LONG" -q --force --supersample "$SUPERSAMPLE"
LOOPED=$WORK/long_x$LOOPS.mp4
[[ -f $LOOPED ]] ||
  ffmpeg -nostdin -loglevel error -y -stream_loop $((LOOPS - 1)) -i "$LONG/video.mp4" -c copy "$LOOPED"
rss() {  # rss VIDEO: "WALL CPU KIB"
  measure "$PANOLOC" --calib "$LONG/calib.yaml" --map "$LONG/map.yaml" "$1" -o "$WORK/long.csv" --force -q \
    --threads "$THREADS" --table-cache "$WORK/cache-warm"
}
read -r t1 _ m1 < <(rss "$LONG/video.mp4")
read -r t2 _ m2 < <(rss "$LOOPED")
frames2=$((3000 * LOOPS))
echo
echo "Peak RSS (one run each, warm table cache):"
echo
echo "| frames | wall s | peak RSS MiB |"
echo "|---|---|---|"
awk -v t="$t1" -v m="$m1" 'BEGIN { printf "| 3000 | %s | %.1f |\n", t, m / 1024 }'
awk -v f="$frames2" -v t="$t2" -v m="$m2" -v m1="$m1" \
  'BEGIN { printf "| %d | %s | %.1f (%+.1f %%) |\n", f, t, m / 1024, 100 * (m - m1) / m1 }'

#!/usr/bin/env bash
# Two ways of localising compared on maps as they are measured: two builds
# (a change against the code before it), or one build under two sets of
# panoloc flags (FLAGS_A, FLAGS_B: an option against its default). Both run
# tools/bench_maps.sh on the same renders: the rooms of tools/bench_rooms.sh
# (ROOMS, RC=yes adds their real-conditions videos) and the panosim presets
# in PRESETS, rendered once by side A. Prints, per preset, side A's and side
# B's frames tracked (of those that show the room), wrong frames and ok
# frames outside their 3-sigma ellipse (bench_maps.sh's criteria), then
# every wrong frame that only one side reported, and how many pose CSVs
# differ at all (most changes touch few frames: the rest must be the same
# byte for byte).
# Usage: tools/compare_maps.sh BUILD_A BUILD_B [WORK_DIR]
#   FLAGS_A="" FLAGS_B=""  ROOMS="office lab" RC=yes|no (no)  PRESETS=""
#   SIGMAS SEEDS STATED METHODS START: as tools/bench_maps.sh
set -euo pipefail
[[ $# -ge 2 ]] || { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
build_a=$1
build_b=$2
work=${3:-$(mktemp -d)}
here=$(cd "$(dirname "$0")/.." && pwd)
for b in "$build_a" "$build_b"; do
  for tool in panosim panoloc; do
    [ -x "$b/bin/$tool" ] || { echo "compare_maps.sh: $b/bin/$tool not found (build first)" >&2; exit 1; }
  done
done
rooms=${ROOMS-"office lab"}
presets=${PRESETS:-}
[[ -n $rooms || -n $presets ]] || { echo "compare_maps.sh: nothing to run (ROOMS and PRESETS are empty)" >&2; exit 1; }
python=/usr/bin/python3
[ -x "$python" ] || python=python3
mkdir -p "$work/a" "$work/b"
rm -f "$work/a/wrong.csv" "$work/b/wrong.csv"

# Side A renders what it runs.
: >"$work/a/table.md"
if [[ -n $rooms ]]; then
  ROOMS="$rooms" PANOLOC_FLAGS="${FLAGS_A:-}" WRONG_LIST="$work/a/wrong.csv" \
    bash "$here/tools/bench_rooms.sh" "$build_a" "$work/a" >>"$work/a/table.md"
fi
if [[ -n $presets ]]; then
  PRESETS="$presets" PANOLOC_FLAGS="${FLAGS_A:-}" WRONG_LIST="$work/a/wrong.csv" \
    bash "$here/tools/bench_maps.sh" "$build_a" "$work/a" >>"$work/a/table.md"
fi

# Side B on the same renders (and the same perturbed maps: bench_maps.sh
# draws them from the same seeds).
all=""
for d in "$work"/a/*/; do
  p=$(basename "$d")
  [[ $p == no-start-* || ! -f $d/video.mp4 ]] && continue
  mkdir -p "$work/b/$p"
  for f in video.mp4 calib.yaml map.yaml map_true.yaml gt.csv case.yaml; do
    [[ -e $d/$f ]] && ln -sf "$(cd "$d" && pwd)/$f" "$work/b/$p/$f"
  done
  all="$all $p"
done
PRESETS="$all" PANOLOC_FLAGS="${FLAGS_B:-}" WRONG_LIST="$work/b/wrong.csv" \
  bash "$here/tools/bench_maps.sh" "$build_b" "$work/b" >"$work/b/table.md"

"$python" - "$work" <<'PY'
import collections, filecmp, glob, os, re, sys
work = sys.argv[1]
def table(side):
    rows = {}
    for line in open(f"{work}/{side}/table.md"):
        f = [x.strip() for x in line.strip().strip("|").split("|")]
        m = re.match(r"[\d.]+ % \((\d+)/(\d+)\)", f[5]) if len(f) >= 10 else None
        if not m:
            continue
        ok = int(m.group(1))
        inside = float(f[9].split()[0]) if f[9].split()[0] != "nan" else 100.0
        rows[tuple(f[:5])] = (ok, int(m.group(2)), int(f[8]), ok - round(ok * inside / 100.0))
    return rows
def wrong(side):
    out = {}
    path = f"{work}/{side}/wrong.csv"
    for line in open(path) if os.path.exists(path) else []:
        csv, frame, err, maha, n = line.strip().split(",")
        out[(os.path.relpath(csv, f"{work}/{side}"), int(frame))] = (float(err), float(maha), int(n))
    return out
a, b = table("a"), table("b")
print("| preset | runs | tracked A | tracked B | of | wrong A | wrong B | outside 3 sigma A | B | rows differing |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
totals = collections.OrderedDict()
for key in a:
    if key not in b:
        continue
    t = totals.setdefault(key[0], [0] * 9)
    x, y = a[key], b[key]
    for i, v in enumerate((1, x[0], y[0], x[1], x[2], y[2], x[3], y[3], x != y)):
        t[i] += v
for preset, t in totals.items():
    print("| " + " | ".join([preset] + [str(v) for v in t]) + " |")
wa, wb = wrong("a"), wrong("b")
for name, only, other in (("A", wa, wb), ("B", wb, wa)):
    for (csv, frame), (err, maha, n) in sorted(only.items()):
        if (csv, frame) not in other:
            print(f"wrong in {name} only: {csv} frame {frame}: {err:.2f} off, {maha:.1f} sigma, {n} landmarks")
differ = same = 0
for path in sorted(glob.glob(f"{work}/a/*/*-start-*.csv")):
    other = f"{work}/b/" + os.path.relpath(path, f"{work}/a")
    if os.path.exists(other):
        if filecmp.cmp(path, other, shallow=False):
            same += 1
        else:
            differ += 1
            print("differs:", os.path.relpath(path, f"{work}/a"))
print(f"pose CSVs: {differ} differ, {same} the same")
PY

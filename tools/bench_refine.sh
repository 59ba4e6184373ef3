#!/usr/bin/env bash
# Map refinement end to end (panomap refine). For each room: render the
# 300-frame map-error preset (map.yaml off by sigma 1 map unit per
# coordinate, map_true.yaml the truth), localise it with panoloc on the
# surveyed map, refine the map from that video and its poses, and print
#  (a) the RMS corner error against the truth, surveyed -> refined;
#  (b) panoloc's position RMS on a second sequence of the same room (another
#      trajectory and seed, not used by the refinement) with the true, the
#      surveyed and the refined map.
# The surveyed map is tracked with panoloc's integrity bound off
# (--alert-fraction 0): the bound assumes an exact map, and with 1 unit of
# survey error most frames would be held back. Rounds (ROUNDS, default 2):
# each later round re-localises the first video on the last refined map
# (default settings) and refines the surveyed map again from those poses.
# Corner RMS is given raw and after the gauge (the shift, turn and scaling
# that no image sees and the survey's priors fix: the refined map inherits
# the survey's mean error there); the second sequence's RMS likewise carries
# that offset (its std is the localisation noise about it).
# Usage: tools/bench_refine.sh [BUILD_DIR] [WORK_DIR]
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d)}
mkdir -p "$work"
bin="$build/bin"
for tool in panosim panoloc panomap; do
  [ -x "$bin/$tool" ] || { echo "bench_refine.sh: $bin/$tool not found (build first)" >&2; exit 1; }
done
rounds=${ROUNDS:-2}
# room preset : second sequence (same room and sensor, another path)
cases=${CASES:-"paper-real:fast-turns paper-synthetic:paper-synthetic"}

# RMS of panoloc's positions against the ground truth (its own accuracy summary).
rms_of() {
  python3 -c 'import json,sys; a=json.load(open(sys.argv[1]))["inputs"][0]; print("%.3f/%.3f/%d" % (a["accuracy"]["rms"], a["accuracy"]["std"], a["accuracy"]["tracked"]) if "accuracy" in a else "nan/nan/0")' "$1"
}
# RMS distance between the rectangle corners of two maps.
corner_rms() {
  python3 - "$1" "$2" <<'PY'
import math, sys, yaml
import numpy as np
a, b = (yaml.safe_load(open(p)) for p in sys.argv[1:3])
rb = {r["id"]: r for r in b["rectangles"]}
P, Q = [], []
for r in a["rectangles"]:
    q = rb[r["id"]]
    for e in ("from", "to"):
        for k in (0, 1):
            P.append([r[e][0], r[e][1], r["z"][k] - a["sensor_height"]])
            Q.append([q[e][0], q[e][1], q["z"][k] - b["sensor_height"]])
P, Q = np.array(P), np.array(Q)
# The gauge: x' = a x - b y + tx, y' = b x + a y + ty, z' = a z (least squares).
A = np.zeros((3 * len(P), 4))
A[0::3] = np.c_[P[:, 0], -P[:, 1], np.ones(len(P)), np.zeros(len(P))]
A[1::3] = np.c_[P[:, 1], P[:, 0], np.zeros(len(P)), np.ones(len(P))]
A[2::3, 0] = P[:, 2]
y = Q.reshape(-1)
g = np.linalg.lstsq(A, y, rcond=None)[0]
raw = math.sqrt(((P - Q) ** 2).sum(1).mean())
aligned = math.sqrt(((A @ g - y) ** 2).sum() / len(P))
print("%.3f %.3f" % (raw, aligned))
PY
}
localise() {  # video map out.csv gt.csv [panoloc options]
  local v=$1 m=$2 o=$3 g=$4
  shift 4
  # panoloc exits 1 when it tracks under 10 % of the frames: still a figure.
  "$bin/panoloc" "$v" --calib "$(dirname "$v")/calib.yaml" --map "$m" -o "$o" --gt "$g" --force -q \
    --summary-json "${o%.csv}.json" "$@" || true
  rms_of "${o%.csv}.json"
}

echo "| room | units | frames ok (surveyed map) | corner RMS surveyed | refined | factor | after gauge: surveyed | refined | factor | 2nd seq RMS/std/ok: true map | surveyed map | refined map | RMS refined/true |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for c in $cases; do
  room=${c%%:*}
  second=${c#*:}
  p="$room-map-error"
  d="$work/$p"
  s="$work/$second"
  [ -f "$d/video.mp4" ] || "$bin/panosim" sequence --preset "$p" -o "$d" --force --quiet
  [ -f "$s/video.mp4" ] || "$bin/panosim" sequence --preset "$second" -o "$s" --force --quiet
  units=$(sed -n 's/^units: //p' "$d/map.yaml")
  first=$(localise "$d/video.mp4" "$d/map.yaml" "$d/poses.csv" "$d/gt.csv" --alert-fraction 0)
  map="$d/map.yaml"
  poses="$d/poses.csv"
  for r in $(seq 1 "$rounds"); do
    "$bin/panomap" refine --map "$d/map.yaml" --calib "$d/calib.yaml" --poses "$poses" "$d/video.mp4" \
      -o "$d/refined$r.yaml" --report "$d/report$r.csv" --map-sigma 1 --force > "$d/refine$r.txt"
    map="$d/refined$r.yaml"
    if [ "$r" -lt "$rounds" ]; then
      localise "$d/video.mp4" "$map" "$d/poses$r.csv" "$d/gt.csv" > /dev/null
      poses="$d/poses$r.csv"
    fi
  done
  before=$(corner_rms "$d/map.yaml" "$d/map_true.yaml")
  after=$(corner_rms "$map" "$d/map_true.yaml")
  t=$(localise "$s/video.mp4" "$d/map_true.yaml" "$s/true.csv" "$s/gt.csv")
  m=$(localise "$s/video.mp4" "$d/map.yaml" "$s/surveyed.csv" "$s/gt.csv")
  f=$(localise "$s/video.mp4" "$map" "$s/refined.csv" "$s/gt.csv")
  python3 - "$room" "$units" "$first" "$before" "$after" "$t" "$m" "$f" <<'PY'
import sys
room, units, first, before, after, t, m, f = sys.argv[1:9]
(b, bg), (a, ag) = (map(float, x.split()) for x in (before, after))
ok = first.split("/")[2]
ratio = float(f.split("/")[0]) / float(t.split("/")[0])
print(f"| {room} | {units} | {ok}/300 | {b:.3f} | {a:.3f} | {b / a:.1f}x | {bg:.3f} | {ag:.3f} | {bg / ag:.1f}x | "
      f"{t} | {m} | {f} | {ratio:.1f} |")
PY
done

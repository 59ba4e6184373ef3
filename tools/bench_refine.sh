#!/usr/bin/env bash
# Map refinement end to end (panomap refine). For each room: render the
# 300-frame map-error preset (map.yaml off by sigma SIGMA map units per
# coordinate, default 1, and stating it as its survey_sigma; map_true.yaml
# the truth), localise it with panoloc on the
# surveyed map, refine the map from that video with poses from three
# sources, and print for each
#  (a) the RMS corner error against the truth, surveyed -> refined, raw and
#      after the gauge (the shift, turn and scaling that no image sees and
#      only the priors fix: what is left is the error of the room's shape),
#      with the gauge floor the refinement itself reports;
#  (b) panoloc's position RMS on a second sequence of the same room (another
#      trajectory and seed, not used by the refinement) with the refined map,
#      raw and after a rigid 2-D alignment of the trajectory to the ground
#      truth (removing the gauge the map passes on to the poses).
# Pose sources: "panoloc" (the surveyed map's poses; ROUNDS rounds, each
# later one re-localising on the last refined map and refining the surveyed
# map again), "gt" (panosim's gt.csv with the default --pose-sigma auto: a
# reference trajectory, its positions held with a tenth of --map-sigma, fix
# the gauge) and "gt, --pose-sigma 0" (the survey fixes the gauge). The true and the surveyed map give the reference
# rows. The refinement's --map-sigma is the map's survey_sigma.
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
sigma=${SIGMA:-1}
python=/usr/bin/python3
[ -x "$python" ] || python=python3
# room preset : second sequence (same room and sensor, another path)
cases=${CASES:-"paper-real:fast-turns paper-synthetic:paper-synthetic"}

# panoloc's position RMS against the ground truth, raw and after the rigid
# 2-D transform that best aligns its ok rows to the truth, and the rows ok.
traj_rms() {  # poses.csv gt.csv
  "$python" - "$1" "$2" <<'PY'
import csv, math, sys
import numpy as np
rows = {int(r["frame"]): r for r in csv.DictReader(open(sys.argv[1])) if r["status"] == "ok"}
gt = {int(r["frame"]): r for r in csv.DictReader(open(sys.argv[2]))}
f = sorted(k for k in rows if k in gt)
if len(f) < 3:
    print("nan nan %d" % len(f)); sys.exit()
P = np.array([[float(rows[k]["x"]), float(rows[k]["y"])] for k in f])
Q = np.array([[float(gt[k]["x"]), float(gt[k]["y"])] for k in f])
raw = math.sqrt(((P - Q) ** 2).sum(1).mean())
# Kabsch in 2-D (no scale).
pc, qc = P.mean(0), Q.mean(0)
u, _, vt = np.linalg.svd((P - pc).T @ (Q - qc))
d = np.sign(np.linalg.det(u @ vt))
R = (u @ np.diag([1, d]) @ vt).T
aligned = math.sqrt((((P - pc) @ R.T + qc - Q) ** 2).sum(1).mean())
print("%.3f %.3f %d" % (raw, aligned, len(f)))
PY
}
# RMS distance between the rectangle corners of two maps, raw and after the gauge.
corner_rms() {
  "$python" - "$1" "$2" <<'PY'
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
  local v=$1 m=$2 o=$3
  shift 4
  # panoloc exits 1 when it tracks under 10 % of the frames: still a figure.
  "$bin/panoloc" "$v" --calib "$(dirname "$v")/calib.yaml" --map "$m" -o "$o" --force -q "$@" || true
}
# One table row: room, pose source, map, its refine log (or -), second sequence dir.
row() {
  local room=$1 source=$2 map=$3 log=$4 d=$5 s=$6 tag=$7
  localise "$s/video.mp4" "$map" "$s/$tag.csv" "$s/gt.csv"
  local c raw aligned n craw cgauge floor="-"
  c=$(corner_rms "$map" "$d/map_true.yaml")
  [ "$log" = - ] || floor=$(sed -n 's/.*corner RMS floor \([0-9.e+-]*\).*/\1/p' "$log")
  read -r raw aligned n < <(traj_rms "$s/$tag.csv" "$s/gt.csv")
  read -r craw cgauge <<< "$c"
  echo "| $room | $source | $craw | $cgauge | $floor | $raw | $aligned | $n |"
}

echo "| room | poses (map) | corner RMS | after gauge | gauge floor | 2nd seq RMS | after rigid alignment | 2nd seq frames ok |"
echo "|---|---|---|---|---|---|---|---|"
for c in $cases; do
  room=${c%%:*}
  second=${c#*:}
  p="$room-map-error"
  d="$work/$p-s$sigma"
  s="$work/$second"
  [ -f "$d/video.mp4" ] || "$bin/panosim" sequence --preset "$p" --map-sigma "$sigma" -o "$d" --force --quiet
  [ -f "$s/video.mp4" ] || "$bin/panosim" sequence --preset "$second" -o "$s" --force --quiet
  localise "$d/video.mp4" "$d/map.yaml" "$d/poses.csv" "$d/gt.csv"
  refine() {  # name poses.csv [panomap options]
    local name=$1 poses=$2
    shift 2
    "$bin/panomap" refine --map "$d/map.yaml" --calib "$d/calib.yaml" --poses "$poses" "$d/video.mp4" \
      -o "$d/refined_$name.yaml" --report "$d/report_$name.csv" --force "$@" > "$d/refine_$name.txt"
  }
  poses="$d/poses.csv"
  for r in $(seq 1 "$rounds"); do
    refine "panoloc$r" "$poses"
    if [ "$r" -lt "$rounds" ]; then
      localise "$d/video.mp4" "$d/refined_panoloc$r.yaml" "$d/poses$r.csv" "$d/gt.csv"
      poses="$d/poses$r.csv"
    fi
  done
  refine gt "$d/gt.csv"
  refine gt_noprior "$d/gt.csv" --pose-sigma 0
  row "$room" "(true map)" "$d/map_true.yaml" - "$d" "$s" loc_true
  row "$room" "(surveyed map)" "$d/map.yaml" - "$d" "$s" loc_surveyed
  ok=$("$python" -c 'import csv,sys; print(sum(r["status"]=="ok" for r in csv.DictReader(open(sys.argv[1]))))' "$d/poses.csv")
  for r in $(seq 1 "$rounds"); do
    row "$room" "panoloc ($ok/300 ok), round $r" "$d/refined_panoloc$r.yaml" "$d/refine_panoloc$r.txt" "$d" "$s" "loc_panoloc$r"
  done
  row "$room" "gt, --pose-sigma 0" "$d/refined_gt_noprior.yaml" "$d/refine_gt_noprior.txt" "$d" "$s" loc_gt_noprior
  row "$room" "gt (reference: --pose-sigma auto)" "$d/refined_gt.yaml" "$d/refine_gt.txt" "$d" "$s" loc_gt
done

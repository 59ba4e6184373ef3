#!/usr/bin/env bash
# panoloc on a long random walk with kidnaps: a robot wandering a room at
# walking pace, turning slowly most of the time (about 1 degree per frame,
# now and then faster), carried off to a random pose at two frames. The
# walk is rendered with panosim in a preset's room (default paper-real) and
# localised with both methods; prints the frames tracked, every run of lost
# frames longer than MAX_LOSS (default 5) with where it happened, how many
# frames each kidnap took to recover, the RMS and the wrong frames (further
# off than 1 % of the mean landmark distance and 5x the median error, or
# than 10 % of it) and the ok frames inside their 3-sigma position ellipse.
# MAP_SIGMA > 0 localises against a map as measured: panosim moves every
# corner coordinate by N(0, MAP_SIGMA) (seed MAP_SEED) and states it as the
# map's survey sigma; the room rendered is the true one.
# Usage: tools/bench_random_walk.sh [BUILD_DIR] [WORK_DIR]
#   PRESET=paper-real FRAMES=3000 SEED=1 KIDNAPS="1000 2000" METHODS="junction vertex"
#   MAP_SIGMA=0 MAP_SEED=1
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d)}
bin="$build/bin"
for tool in panosim panoloc; do
  [ -x "$bin/$tool" ] || { echo "bench_random_walk.sh: $bin/$tool not found (build first)" >&2; exit 1; }
done
preset=${PRESET:-paper-real}
frames=${FRAMES:-3000}
seed=${SEED:-1}
kidnaps=${KIDNAPS:-"1000 2000"}
methods=${METHODS:-"junction vertex"}
max_loss=${MAX_LOSS:-5}
map_sigma=${MAP_SIGMA:-0}
map_seed=${MAP_SEED:-1}
python=/usr/bin/python3
[ -x "$python" ] || python=python3
dir="$work/walk-$preset-$frames-$seed"
map_args=()
if [[ $map_sigma != 0 ]]; then
  dir="$dir-map$map_sigma-$map_seed"
  map_args=(--map-sigma "$map_sigma" --map-seed "$map_seed")
fi
mkdir -p "$work"
if [[ ! -f $dir/video.mp4 ]]; then
  [[ -f $work/$preset-room/map.yaml ]] || "$bin/panosim" sequence --preset "$preset" -o "$work/$preset-room" --force --quiet
  "$python" - "$work/$preset-room/map.yaml" "$frames" "$seed" "$kidnaps" > "$work/walk-$seed.csv" <<'PY'
import sys, math, yaml, numpy as np
m = yaml.safe_load(open(sys.argv[1]))
n, seed, kidnaps = int(sys.argv[2]), int(sys.argv[3]), [int(k) for k in sys.argv[4].split()]
rng = np.random.default_rng(seed)
lo, hi = np.array(m["room"]["min"], float), np.array(m["room"]["max"], float)
size = float(np.max(hi - lo))
margin = 0.14 * size  # clear of the walls and their rectangles
blocks = []  # free-standing rectangles: keep away from their bottom edges
for r in m.get("rectangles", []):
    a, b = np.array(r["from"], float), np.array(r["to"], float)
    if min(a.min() - lo.min(), hi.max() - a.max(), b.min() - lo.min(), hi.max() - b.max()) > 1e-6:
        blocks.append((a, b))
def free(p):
    if np.any(p < lo + margin) or np.any(p > hi - margin):
        return False
    for a, b in blocks:
        t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0, 1)
        if np.linalg.norm(p - (a + t * (b - a))) < 0.08 * size:
            return False
    return True
def random_free():
    while True:
        p = lo + margin + rng.random(2) * (hi - lo - 2 * margin)
        if free(p):
            return p
p, heading, turn = random_free(), rng.uniform(-math.pi, math.pi), 0.0
step = 0.006 * size  # about 1.3 cm a frame in a 2.2 m room
print("x,y,theta")
for i in range(n):
    if i in kidnaps:
        p, heading, turn = random_free(), rng.uniform(-math.pi, math.pi), 0.0
    print(f"{p[0]:.4f},{p[1]:.4f},{math.remainder(heading, 2 * math.pi):.6f}")
    # Slow turns (about 1 degree a frame), now and then a faster one, never
    # above 10 degrees a frame.
    limit = math.radians(10)
    turn = 0.9 * turn + 0.1 * rng.normal(0, math.radians(1.5 if rng.random() > 0.05 else 8))
    turn = max(-limit, min(limit, turn))
    speed = step * (0.5 + rng.random())
    q = p + speed * np.array([math.cos(heading + turn), math.sin(heading + turn)])
    if not free(q):
        # Blocked: stop and turn towards the middle of the room.
        centre = 0.5 * (lo + hi)
        want = math.atan2(centre[1] - p[1], centre[0] - p[0])
        turn = max(-limit, min(limit, math.remainder(want - heading, 2 * math.pi)))
        q = p
    heading += turn
    p = q
PY
  "$bin/panosim" sequence --map "$work/$preset-room/map.yaml" --calib "$work/$preset-room/calib.yaml" \
    --trajectory "$work/walk-$seed.csv" --fps 10 "${map_args[@]}" -o "$dir" --force --quiet
fi
for m in $methods; do
  "$bin/panoloc" "$dir/video.mp4" --calib "$dir/calib.yaml" --map "$dir/map.yaml" --method "$m" \
    -o "$dir/$m.csv" --force -q ${PANOLOC_FLAGS:-} || true
  "$python" - "$dir" "$m" "$max_loss" "$kidnaps" <<'PY'
import sys, csv, math, yaml, numpy as np
folder, method, max_loss, kidnaps = sys.argv[1], sys.argv[2], int(sys.argv[3]), [int(k) for k in sys.argv[4].split()]
gt = list(csv.DictReader(open(folder + "/gt.csv")))
rows = list(csv.DictReader(open(f"{folder}/{method}.csv")))
import os
truth = yaml.safe_load(open(folder + ("/map_true.yaml" if os.path.exists(folder + "/map_true.yaml") else "/map.yaml")))
corners = np.array([c for r in truth["rectangles"] for c in (r["from"], r["to"])], float)
ok = [r["status"] == "ok" for r in rows]
err, dist, inside = [], [], []
for r, g in zip(rows, gt):
    if r["status"] == "ok":
        gx, gy = float(g["x"]), float(g["y"])
        ex, ey = float(r["x"]) - gx, float(r["y"]) - gy
        err.append(math.hypot(ex, ey))
        dist.append(np.mean(np.hypot(corners[:, 0] - gx, corners[:, 1] - gy)))
        sx, sy = float(r.get("std_x") or "nan"), float(r.get("std_y") or "nan")
        inside.append(sx > 0 and sy > 0 and (ex / sx) ** 2 + (ey / sy) ** 2 <= 9)
err, dist = np.array(err), np.array(dist)
wrong = int(np.sum(((err > 0.01 * dist) & (err > 5 * np.median(err))) | (err > 0.1 * dist)))
runs, start = [], None
for i, good in enumerate(ok + [True]):
    if not good and start is None:
        start = i
    if good and start is not None:
        runs.append((start, i - start))
        start = None
long_runs = [(s, l) for s, l in runs if l > max_loss and s not in kidnaps]
def turn_at(i):
    a, b = float(gt[max(0, i - 1)]["theta_rad"]), float(gt[i]["theta_rad"])
    return abs(math.degrees(math.remainder(b - a, 2 * math.pi)))
recover = []
for k in kidnaps:
    j = k
    while j < len(ok) and not ok[j]:
        j += 1
    recover.append(j - k)
print(f"{method}: tracked {sum(ok)}/{len(ok)} ({100.0 * sum(ok) / len(ok):.1f} %), RMS {np.sqrt(np.mean(err ** 2)):.3f}, "
      f"max {err.max():.3f}, wrong {wrong}, inside 3 sigma {100.0 * np.mean(inside):.1f} %; lost runs {len(runs)}, longest {sorted((l for _, l in runs), reverse=True)[:6]}; "
      f"kidnaps recovered after {recover} frames")
for s, l in long_runs:
    g = gt[s]
    print(f"  lost {l} frames from frame {s} at ({float(g['x']):.1f}, {float(g['y']):.1f}), turning {turn_at(s):.1f} deg/frame")
PY
done

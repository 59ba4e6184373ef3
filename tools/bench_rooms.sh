#!/usr/bin/env bash
# panoloc in rooms other than the paper's, on exact and measured maps: the
# worked examples docs/examples/office-map.yaml (4.2 x 3.6 m; a door, a
# window and boards whose tops image at the mirror's limb),
# docs/examples/lab-map.yaml (6 x 4 m; four identical windows, a column
# that hides part of the room), docs/examples/workshop-map.yaml (7.2 x
# 4.8 m; a free-standing bench, a pillar) and docs/examples/studio-map.yaml
# (7.5 x 5 m; a low sofa standing free, most landmarks metres away), seen
# by the paper-real sensor along a loop of 300 frames (the office: an
# ellipse about the middle, 1.4 - 3.3 cm a frame; the lab: a rounded
# rectangle about the column, 3.6 cm a frame; the workshop: a figure
# eight, up to 7 cm a frame, with a stop and a slow turn in place; the
# studio: a wavy ellipse that passes 20 cm from the sofa, up to 5 cm a
# frame), the heading wiggling about the path (25, 15, 30 and 40 degrees).
# Each room is rendered with noise 3 and a 3 x 3 blur ("office", "lab",
# "workshop", "studio") and, with RC=yes, with every factor of
# real-conditions too ("office-rc" ...: exposure 0.5, auto-exposure 0.2,
# texture 0.1, 2 people, 3 covered and 3 dropped frames, noise 4).
# Then tools/bench_maps.sh runs on them (its SIGMAS, SEEDS, STATED, METHODS
# and START apply) and prints its table.
# Usage: tools/bench_rooms.sh [BUILD_DIR] [WORK_DIR]
#   RC=yes|no (no)  ROOMS="office lab workshop studio"
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d)}
mkdir -p "$work"
here=$(cd "$(dirname "$0")/.." && pwd)
bin="$build/bin"
[ -x "$bin/panosim" ] || { echo "bench_rooms.sh: $bin/panosim not found (build first)" >&2; exit 1; }
python=/usr/bin/python3
[ -x "$python" ] || python=python3
rooms=${ROOMS:-"office lab workshop studio"}
rc=${RC:-no}
[[ $rc == yes || $rc == no ]] || { echo "bench_rooms.sh: RC must be yes or no" >&2; exit 1; }

# The loops, one pose per frame (x, y, theta).
"$python" - "$work" <<'PY'
import sys, numpy as np
work = sys.argv[1]
n = 300
def write(name, x, y, th):
    with open(f"{work}/{name}-trajectory.csv", "w") as f:
        f.write("x,y,theta\n")
        for a, b, c in zip(x, y, th):
            f.write(f"{a:.4f},{b:.4f},{c:.6f}\n")
k = np.arange(n)
t = 2 * np.pi * k / n
write("office", 200 + 120 * np.cos(t), 150 + 70 * np.sin(t),
      np.arctan2(70 * np.cos(t), -120 * np.sin(t)) + np.radians(25) * np.sin(0.37 * k))
# A superellipse (exponent 0.5) about the lab's column, at constant speed.
tt = np.linspace(0, 2 * np.pi, 20000, endpoint=False)
X = 300 + 190 * np.sign(np.cos(tt)) * np.abs(np.cos(tt)) ** 0.5
Y = 200 + 120 * np.sign(np.sin(tt)) * np.abs(np.sin(tt)) ** 0.5
s = np.concatenate([[0], np.cumsum(np.hypot(np.diff(X), np.diff(Y)))])
u = np.linspace(0, s[-1], n, endpoint=False)
x, y = np.interp(u, s, X), np.interp(u, s, Y)
write("lab", x, y, np.unwrap(np.arctan2(np.gradient(y), np.gradient(x))) + np.radians(15) * np.sin(0.23 * k))
# A figure eight through the workshop, slowing to a stop at frame 150 and
# turning 25 degrees in place there (frames 135 - 165).
v = np.ones(n)
v[135:165] = np.clip(np.abs(np.arange(135, 165) - 150) / 15.0, 0, 1) ** 2
u = np.concatenate([[0], np.cumsum(v[:-1])])
u = u / (u[-1] + v[-1]) * 2 * np.pi
x, y = 370 + 230 * np.sin(u), 240 + 110 * np.sin(2 * u)
th = np.unwrap(np.arctan2(220 * np.cos(2 * u), 230 * np.cos(u))) + np.radians(30) * np.sin(0.19 * k)
write("workshop", x, y, th + np.radians(25) * np.clip((k - 135) / 30.0, 0, 1))
# A wavy ellipse through the studio, passing 20 cm south of the sofa.
x, y = 360 + 180 * np.cos(t) + 30 * np.sin(3 * t), 200 + 110 * np.sin(t)
write("studio", x, y, np.unwrap(np.arctan2(np.gradient(y), np.gradient(x))) + np.radians(40) * np.sin(0.07 * k))
PY

presets=""
for room in $rooms; do
  map="$here/docs/examples/$room-map.yaml"
  [ -f "$map" ] || { echo "bench_rooms.sh: no room $map" >&2; exit 1; }
  render() {  # name, extra panosim options
    local name=$1; shift
    [[ -f $work/$name/video.mp4 ]] || "$bin/panosim" sequence --map "$map" --calib "$here/calib/paper-real.yaml" \
      --trajectory "$work/$room-trajectory.csv" --blur "$@" -o "$work/$name" --force --quiet
    presets="$presets $name"
  }
  render "$room" --noise 3
  if [[ $rc == yes ]]; then
    render "$room-rc" --noise 4 --exposure 0.5 --auto-exposure 0.2 --texture 0.1 --people 2 --covered-frames 3 \
      --dropped-frames 3
  fi
done
PRESETS="$presets" bash "$here/tools/bench_maps.sh" "$build" "$work"

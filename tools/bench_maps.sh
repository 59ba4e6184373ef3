#!/usr/bin/env bash
# panoloc on maps as they are measured: each preset rendered once with
# panosim, then localised (junction and vertex methods) against its exact
# map and against maps whose every rectangle end point and height is moved
# by independent N(0, sigma) errors (three seeds per level, floor contacts
# kept on the floor), with the survey sigma stated in the map (yes), not
# stated (no), or stated as 0 though the map was perturbed (zero).
# Prints one Markdown row per preset, method, level and statement: frames
# tracked (of those that show the room), position RMS, the frames reported
# ok further off than 1 % of the mean landmark distance and 5x the median
# error, or than 10 % of it ("wrong"), and the fraction of ok frames inside
# their reported 3-sigma position ellipse (std_x, std_y columns). "limit" is
# what the map itself allows: the position RMS of poses solved by least
# squares on the map as measured from noise-free bearings to every
# rectangle's vertical edges, seen from each true pose (each bearing weighed
# by its distance squared, as a survey error's effect on it falls with
# distance); "x limit" is RMS / limit.
# START=no: no start pose (the case.yaml's initial pose is not given; the
# first frame is found by the room-wide search).
# WRONG_LIST=FILE: each wrong frame is appended to FILE as a CSV line
# (csv, frame, error, Mahalanobis distance, landmarks).
# Usage: tools/bench_maps.sh [BUILD_DIR] [WORK_DIR]
#   PRESETS="paper-real fast-turns" SIGMAS="0.5 1 2" SEEDS="1 2 3" STATED="yes no" METHODS="junction vertex"
#   START=yes|no
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d)}
mkdir -p "$work"
bin="$build/bin"
for tool in panosim panoloc; do
  [ -x "$bin/$tool" ] || { echo "bench_maps.sh: $bin/$tool not found (build first)" >&2; exit 1; }
done
presets=${PRESETS:-"paper-real fast-turns"}
sigmas=${SIGMAS:-"0 0.5 1 2"}
seeds=${SEEDS:-"1 2 3"}
stated=${STATED:-"yes"}
methods=${METHODS:-"junction vertex"}
start=${START:-yes}
[[ $start == yes || $start == no ]] || { echo "bench_maps.sh: START must be yes or no" >&2; exit 1; }
python=/usr/bin/python3
[ -x "$python" ] || python=python3

echo "| preset | method | map sigma | stated | seed | tracked | RMS | limit | x limit | max | wrong | inside 3 sigma |"
echo "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"
for p in $presets; do
  [[ -f $work/$p/video.mp4 ]] || "$bin/panosim" sequence --preset "$p" -o "$work/$p" --force --quiet
  video="$work/$p/video.mp4"
  if [[ $start == no ]]; then
    # The video alone in a folder of its own: no case.yaml beside it or one
    # folder up (where panoloc looks for a start pose).
    mkdir -p "$work/no-start-$p"
    ln -sf "$(cd "$work/$p" && pwd)/video.mp4" "$work/no-start-$p/video.mp4"
    video="$work/no-start-$p/video.mp4"
  fi
  for s in $sigmas; do
    for seed in $seeds; do
      for st in $stated; do
        [[ $s == 0 && $seed != "${seeds%% *}" ]] && continue
        map="$work/$p/map-s$s-$seed-$st.yaml"
        "$python" - "$work/$p/map.yaml" "$s" "$seed" "$st" "$map" <<'PY'
import sys, yaml, numpy as np
src, sigma, seed, stated, out = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
m = yaml.safe_load(open(src))
rng = np.random.default_rng(1000 + seed)
for r in m.get("rectangles", []):
    r["from"] = [float(v + rng.normal(0, sigma)) for v in r["from"]]
    r["to"] = [float(v + rng.normal(0, sigma)) for v in r["to"]]
    z0, z1 = r["z"]
    dz0, dz1 = rng.normal(0, sigma), rng.normal(0, sigma)
    z0 = z0 if z0 == 0 else max(0.0, z0 + dz0)  # standing on the floor: a contact
    r["z"] = [float(z0), float(max(z0 + sigma, z1 + dz1))]
for b in m.get("boxes", []):
    d = rng.normal(0, sigma, 6)
    b["min"] = [float(b["min"][0] + d[0]), float(b["min"][1] + d[1]), b["min"][2]]
    b["max"] = [float(b["max"][0] + d[2]), float(b["max"][1] + d[3]), float(b["max"][2] + d[4])]
m.pop("survey_sigma", None)
if stated == "yes":
    m["survey_sigma"] = sigma
elif stated == "zero":  # a rendered map's "exact" left in place after perturbing it
    m["survey_sigma"] = 0.0
yaml.safe_dump(m, open(out, "w"), sort_keys=False)
PY
        for m in $methods; do
          csv="$work/$p/$m-s$s-$seed-$st-start-$start.csv"
          "$bin/panoloc" "$video" --calib "$work/$p/calib.yaml" --map "$map" --method "$m" \
            -o "$csv" --force -q ${PANOLOC_FLAGS:-} || true
          "$python" - "$work/$p" "$csv" "$p" "$m" "$s" "$st" "$seed" "$map" <<'PY'
import os, sys, csv, yaml, numpy as np
folder, path, preset, method, sigma, stated, seed, measured_map = sys.argv[1:9]
gt = {int(r["frame"]): r for r in csv.DictReader(open(folder + "/gt.csv"))}
rows = list(csv.DictReader(open(path)))
case = yaml.safe_load(open(folder + "/case.yaml")) if os.path.exists(folder + "/case.yaml") else {}
def find(node, key):
    if isinstance(node, dict):
        if key in node:
            return node[key]
        for v in node.values():
            found = find(v, key)
            if found is not None:
                return found
    return None
covered = set(find(case, "covered_frames") or [])
fps = float(case.get("fps", 10.0))
truth = yaml.safe_load(open(folder + ("/map_true.yaml" if os.path.exists(folder + "/map_true.yaml") else "/map.yaml")))
corners = []
for r in truth.get("rectangles", []):
    corners += [r["from"], r["to"]]
corners = np.array(corners, float)
measured = np.array([p for r in yaml.safe_load(open(measured_map)).get("rectangles", []) for p in (r["from"], r["to"])], float)
def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi
def ideal_error(x, y, theta):
    """Position error of the pose solved on the measured map from the true, noise-free bearings of every edge."""
    d = corners - (x, y)
    azimuth = np.arctan2(d[:, 1], d[:, 0]) - theta
    pose = np.array([x, y, theta])
    for _ in range(20):  # Gauss-Newton from the true pose
        v = measured - pose[:2]
        r2 = np.sum(v * v, axis=1)
        residual = wrap(np.arctan2(v[:, 1], v[:, 0]) - pose[2] - azimuth)
        jac = np.c_[v[:, 1] / r2, -v[:, 0] / r2, -np.ones(len(r2))]
        step = np.linalg.solve(jac.T @ (r2[:, None] * jac), -jac.T @ (r2 * residual))
        pose += step
        if np.abs(step).max() < 1e-12:
            break
    return np.hypot(pose[0] - x, pose[1] - y)
ideal = []
shows, ok, err, dist, maha, frames = 0, 0, [], [], [], []
for r in rows:
    f = int(r["frame"])
    g = gt.get(f)
    if g is None:
        continue
    # A covered frame shows no room (the gt's time tells the true frame).
    if round(float(g["time_s"]) * fps) in covered:
        continue
    shows += 1
    ideal.append(ideal_error(float(g["x"]), float(g["y"]), float(g["theta_rad"])))
    if r["status"] != "ok":
        continue
    ok += 1
    gx, gy = float(g["x"]), float(g["y"])
    ex, ey = float(r["x"]) - gx, float(r["y"]) - gy
    err.append(np.hypot(ex, ey))
    dist.append(np.mean(np.hypot(corners[:, 0] - gx, corners[:, 1] - gy)))
    sx, sy = float(r.get("std_x") or "nan"), float(r.get("std_y") or "nan")
    # Distance in standard deviations (NaN without a covariance: outside).
    maha.append(np.hypot(ex / sx, ey / sy) if sx > 0 and sy > 0 else float("nan"))
    frames.append((f, int(r["n_landmarks"])))
err = np.array(err)
med = np.median(err) if len(err) else 0
# Also wrong whatever the median: a pose in another place of the room (a
# run that tracked the room's twin throughout has a median as large).
dist = np.array(dist)
is_wrong = ((err > 0.01 * dist) & (err > 5 * med)) | (err > 0.1 * dist) if len(err) else np.zeros(0, bool)
wrong = int(np.sum(is_wrong))
if os.environ.get("WRONG_LIST"):
    with open(os.environ["WRONG_LIST"], "a") as out:
        for k in np.flatnonzero(is_wrong):
            out.write(f"{path},{frames[k][0]},{err[k]:.3f},{maha[k]:.2f},{frames[k][1]}\n")
rms = np.sqrt(np.mean(err ** 2)) if len(err) else float("nan")
mx = err.max() if len(err) else float("nan")
fin = 100.0 * np.mean(np.array(maha) <= 3) if maha else float("nan")
limit = np.sqrt(np.mean(np.square(ideal))) if ideal else float("nan")
times = f"{rms / limit:.2f}" if limit > 0 else "-"
print(f"| {preset} | {method} | {sigma} | {stated} | {seed} | {100.0 * ok / max(1, shows):.1f} % ({ok}/{shows}) | "
      f"{rms:.3f} | {limit:.3f} | {times} | {mx:.3f} | {wrong} | {fin:.1f} % |", flush=True)
PY
        done
      done
    done
  done
done

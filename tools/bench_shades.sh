#!/usr/bin/env bash
# panoloc with the map's landmark shades (a) as rendered, (b) removed
# (unknown: the edges' polarities are learned from the images) and (c)
# inverted (1 - shade: every predicted polarity wrong), on panosim presets,
# both methods. Prints one Markdown table: frames tracked, position RMS, its
# ratio to (a), and wrong "ok" frames (off by more than 1 % of the mean
# distance to the map's landmarks).
# Usage: tools/bench_shades.sh [BUILD_DIR] [WORK_DIR]
# (PRESETS="..." and VARIANTS="correct none inverted" choose what runs.)
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d)}
mkdir -p "$work"
bin="$build/bin"
for tool in panosim panoloc; do
  [ -x "$bin/$tool" ] || { echo "bench_shades.sh: $bin/$tool not found (build first)" >&2; exit 1; }
done
presets=${PRESETS:-"paper-synthetic paper-real cluttered kidnap fast-turns motion-blur real-conditions"}
echo "| preset | method | shades | frames ok | RMS | RMS / (a) | wrong ok | map shades contradicted |"
echo "|---|---|---|---|---|---|---|---|"
for p in $presets; do
  [ -f "$work/$p/video.mp4" ] || "$bin/panosim" sequence --preset "$p" -o "$work/$p" --force --quiet
  python3 - "$work/$p" <<'PY'
import sys, yaml
d = sys.argv[1]
m = yaml.safe_load(open(f"{d}/map.yaml"))
for variant in ("none", "inverted"):
    v = yaml.safe_load(open(f"{d}/map.yaml"))
    for key in ("rectangles", "boxes"):
        for item in v.get(key) or []:
            if "shade" not in item:
                continue
            if variant == "none":
                del item["shade"]
            else:
                item["shade"] = round(1.0 - item["shade"], 6)
    yaml.safe_dump(v, open(f"{d}/map-{variant}.yaml", "w"), sort_keys=False)
PY
  for m in junction vertex; do
    for variant in ${VARIANTS:-correct none inverted}; do
      map="$work/$p/map.yaml"
      [ "$variant" = correct ] || map="$work/$p/map-$variant.yaml"
      out="$work/$p/$m-$variant"
      "$bin/panoloc" "$work/$p/video.mp4" --calib "$work/$p/calib.yaml" --map "$map" --method "$m" \
        -o "$out.csv" --gt "$work/$p/gt.csv" --force --summary-json "$out.json" > "$out.log" 2>&1 || true
      python3 - "$p" "$m" "$variant" "$work/$p" "$out" <<'PY'
import csv, json, math, sys, yaml
preset, method, variant, d, out = sys.argv[1:6]
run = json.load(open(out + ".json"))["inputs"][0]
a = run.get("accuracy")
if a is None:
    print(f"| {preset} | {method} | {variant} | error: {run.get('error')} | | | | |")
    sys.exit(0)
m = yaml.safe_load(open(f"{d}/map.yaml"))
corners = []
for r in m.get("rectangles") or []:
    corners += [r["from"], r["to"]]
for b in m.get("boxes") or []:
    for x in (b["min"][0], b["max"][0]):
        for y in (b["min"][1], b["max"][1]):
            corners.append([x, y])
gt = {int(r["frame"]): r for r in csv.DictReader(open(f"{d}/gt.csv"))}
wrong = 0
for r in csv.DictReader(open(out + ".csv")):
    g = gt.get(int(r["frame"]))
    if r["status"] != "ok" or g is None:
        continue
    gx, gy = float(g["x"]), float(g["y"])
    mean_distance = sum(math.hypot(c[0] - gx, c[1] - gy) for c in corners) / len(corners)
    if math.hypot(float(r["x"]) - gx, float(r["y"]) - gy) > 0.01 * mean_distance:
        wrong += 1
ratio = "-"
if variant != "correct":
    base = json.load(open(out.rsplit("-", 1)[0] + "-correct.json"))["inputs"][0].get("accuracy")
    if base and base["rms"] > 0:
        ratio = f"{a['rms'] / base['rms']:.2f}"
notes = [l.split("map shade")[0].strip() for l in open(out + ".log") if "map shade looks inverted" in l]
print(f"| {preset} | {method} | {variant} | {a['tracked']}/{a['frames']} | {a['rms']:.4g} | {ratio} | {wrong} | "
      f"{len(notes)} |")
PY
    done
  done
done

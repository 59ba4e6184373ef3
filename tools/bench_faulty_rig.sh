#!/usr/bin/env bash
# A real rig end to end, as a user calibrates and localises it: for each
# faulty preset (faulty-rig: sphere 1.4 mm off the camera's axis, camera
# tilted 0.6 degrees, sensor 0.4 degrees, k1 -0.03, k2 0.005; faulty-rig-2x:
# twice those) and the aligned paper-real rig,
#   1. panosim renders 14 chessboard images (unknown poses, noise 2), the
#      preset's 57-frame sequence and a second clip of 60 frames of the robot
#      turning on the spot elsewhere in the room;
#   2. panocalib calibrate fits the rig from the boards (--free auto: the
#      sphere's decentre; k1, k2);
#   3. panocalib tilt --decentre measures the sensor's tilt and refits the
#      mirror's offset from the turning clip in the mapped room;
#   4. panoloc localises the 57-frame sequence (not used by steps 2-3) with
#      the calibrations of steps 2 and 3 and with the true one, both methods.
# Prints a Markdown table of position RMS, outliers and frames tracked.
# Usage: tools/bench_faulty_rig.sh [BUILD_DIR [WORK_DIR]]
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d -t pano_bench_faulty_XXXXXX)}
bin=$build/bin
for tool in panosim panocalib panoloc; do
  [[ -x $bin/$tool ]] || { echo "bench_faulty_rig: $bin/$tool not found (build first)" >&2; exit 1; }
done
mkdir -p "$work"
echo "bench_faulty_rig: working in $work" >&2
presets=${PRESETS:-"paper-real faulty-rig faulty-rig-2x"}
python3 -c "
import math
print('x,y,theta')
for k in range(60): print('%.3f,%.3f,%.6f' % (70, 60, k * 6 * math.pi / 180))" > "$work/turn.csv"
summary() {  # JSON -> "rms outliers tracked/frames"
  python3 -c 'import json,sys; a=json.load(open(sys.argv[1]))["inputs"][0]; acc=a["accuracy"]; print("%.4f %d %d/%d" % (acc["rms"], acc["outliers"], acc["tracked"], a["frames"]))' "$1"
}
echo "| rig | calibration | method | position RMS (cm) | outliers | tracked |"
echo "|---|---|---|---:|---:|---:|"
for p in $presets; do
  d=$work/$p
  mkdir -p "$d"
  [[ -f $d/seq/video.mp4 ]] || "$bin/panosim" sequence --preset "$p" -o "$d/seq" -q --force
  [[ -f $d/targets/targets_unknown.yaml ]] ||
    "$bin/panosim" targets --preset "$p" --board 9,6,3 --auto 14 --noise 2 --seed 7 -o "$d/targets" -q --force
  render=$(python3 -c 'import yaml,sys; r=yaml.safe_load(open(sys.argv[1]))["render"]; print("--noise %s %s --gradient %s --gradient-angle %s --camera-radius %s" % (r["noise_sigma"], "--blur" if r["blur_3x3"] else "", r["gradient"], r["gradient_angle"], r["camera_radius_px"]))' "$d/seq/case.yaml")
  [[ -f $d/turn/video.mp4 ]] || "$bin/panosim" sequence --map "$d/seq/map.yaml" --calib "$d/seq/calib.yaml" \
    --trajectory "$work/turn.csv" $render -o "$d/turn" -q --force
  free=auto
  [[ $p == paper-real ]] && free=none
  "$bin/panocalib" calibrate "$d/targets/targets_unknown.yaml" --free "$free" --distortion 2 -o "$d/boards.yaml" \
    --force -q
  tilt_args=(--decentre)
  [[ $p == paper-real ]] && tilt_args=()
  "$bin/panocalib" tilt --calib "$d/boards.yaml" --map "$d/seq/map.yaml" "$d/turn/video.mp4" -o "$d/tilted.yaml" \
    --frames 60 --max-trials 200 --tolerance 0.001 "${tilt_args[@]}" --force -q
  for c in seq/calib.yaml boards.yaml tilted.yaml; do
    for m in junction vertex; do
      "$bin/panoloc" "$d/seq/video.mp4" --calib "$d/$c" --map "$d/seq/map.yaml" --gt "$d/seq/gt.csv" --method "$m" \
        -o "$d/out.csv" --summary-json "$d/out.json" --force -q --no-table-cache || true
      read -r rms outliers tracked < <(summary "$d/out.json")
      case $c in seq/calib.yaml) name="true" ;; boards.yaml) name="boards (calibrate)" ;; *) name="boards + tilt" ;; esac
      echo "| $p | $name | $m | $rms | $outliers | $tracked |"
    done
  done
done

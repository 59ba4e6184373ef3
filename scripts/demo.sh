#!/usr/bin/env bash
# The main job on the built-in demo, from a fresh machine: installs the
# dependencies (Debian packages, as root), builds, then
#   1. renders the paper's synthetic sequence (66 frames, 500 x 500, H.264),
#   2. renders chessboard images through the same sensor,
#   3. calibrates the sensor from those images (board poses unknown),
#   4. localises through the video with that calibration and prints the
#      accuracy against the ground truth.
# Outputs go to demo-output/ (or $DEMO_DIR).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$jobs" >/dev/null
bin=build/bin
demo=${DEMO_DIR:-demo-output}
mkdir -p "$demo"

echo "== 1/4 panosim: the paper's synthetic sequence"
"$bin/panosim" sequence --preset paper-synthetic -o "$demo/sequence" --force --quiet
echo "   $demo/sequence/video.mp4, gt.csv, map.yaml, calib.yaml (the true sensor)"

echo "== 2/4 panosim: 14 chessboard images through the same sensor (noise sigma 2 grey levels)"
"$bin/panosim" targets --calib calib/paper-synthetic.yaml --board 9,6,3 --auto 14 --noise 2 \
  -o "$demo/targets" --force --quiet

echo "== 3/4 panocalib: calibrate from the images, board poses unknown"
"$bin/panocalib" calibrate "$demo/targets/targets_unknown.yaml" -o "$demo/calib.yaml" \
  --lut "$demo/sensor.lut" --report "$demo/calibration.png" --force

echo "== 4/4 panoloc: localise through the video with that calibration"
"$bin/panoloc" "$demo/sequence/video.mp4" --calib "$demo/calib.yaml" --map "$demo/sequence/map.yaml" \
  -o "$demo/poses.csv" --gt "$demo/sequence/gt.csv" --plot "$demo/trajectory.png" \
  --debug-video "$demo/debug.mp4" --force
echo "   poses: $demo/poses.csv; trajectory plot: $demo/trajectory.png; annotated video: $demo/debug.mp4"

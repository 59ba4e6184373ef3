#!/usr/bin/env bash
# panocalib against OpenCV's omnidir on a folder of chessboard images, as a
# user would run each: system-level K-fold cross-validation (image i, in the
# folder's natural order, held out in fold i mod K).
#   - panotrack: `panocalib calibrate TRAIN_FOLDER --board --square` with its
#     default flags (plus any CALIBRATE_ARGS), then `panocalib evaluate
#     --no-refine` on the held-out images (only each board's pose fitted
#     through the calibration, the detector's corners scored);
#   - omnidir: bin/omnidir_cv (cv::omnidir::calibrate on the training boards'
#     findChessboardCornersSB corners, each held-out board's pose fitted
#     through it), on the same folds.
# Prints each fold's held-out RMS for both, failed folds, the overall
# held-out RMS (pooled over corners) and the same on the boards both scored.
# Usage: tools/compare_omnidir.sh INPUT --board COLSxROWS --square S [--units U]
#          [--folds K] [--build DIR] [--work DIR] [-- CALIBRATE_ARGS...]
# INPUT: a folder of images, or a target file (its images, in its order).
set -euo pipefail
usage() { echo "usage: tools/compare_omnidir.sh INPUT --board COLSxROWS --square S [--units U] [--folds K] [--build DIR] [--work DIR] [-- CALIBRATE_ARGS...]" >&2; exit 1; }
[[ $# -ge 1 ]] || usage
input=$1; shift
board='' square='' units=cm folds=5 build=build work=''
extra=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --board) board=$2; shift 2 ;;
    --square) square=$2; shift 2 ;;
    --units) units=$2; shift 2 ;;
    --folds) folds=$2; shift 2 ;;
    --build) build=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) usage ;;
  esac
done
bin=$build/bin
for tool in panocalib omnidir_cv; do
  [[ -x $bin/$tool ]] || { echo "compare_omnidir: $bin/$tool not found (build it first)" >&2; exit 1; }
done
py=/usr/bin/python3
work=${work:-$(mktemp -d -t pano_compare_omnidir_XXXXXX)}
mkdir -p "$work"
echo "compare_omnidir: working in $work" >&2

# The images in order: a target file's list, or the folder's natural order.
$py - "$input" > "$work/images.txt" <<'PY'
import os, re, sys, yaml
p = sys.argv[1]
if os.path.isdir(p):
    ext = ('.png', '.jpg', '.jpeg', '.bmp', '.tif', '.tiff', '.pgm', '.ppm', '.webp')
    key = lambda s: [int(t) if t.isdigit() else t for t in re.split(r'(\d+)', s)]
    names = sorted((f for f in os.listdir(p) if f.lower().endswith(ext)), key=key)
    print('\n'.join(os.path.abspath(os.path.join(p, f)) for f in names))
else:
    d = yaml.safe_load(open(p))
    base = os.path.dirname(os.path.abspath(p))
    print('\n'.join(os.path.join(base, im['file']) for im in d['images']))
PY
mapfile -t images < "$work/images.txt"
[[ ${#images[@]} -ge $folds ]] || { echo "compare_omnidir: ${#images[@]} images, fewer than $folds folds" >&2; exit 1; }
board_args=(--board "$board" --square "$square" --units "$units")
[[ -n $board && -n $square ]] || usage

# The same images, numbered in order in one folder, for the omnidir tool.
rm -rf "$work/all"; mkdir -p "$work/all"
for i in "${!images[@]}"; do
  f=${images[$i]}
  ln -s "$f" "$work/all/$(printf 'img_%03d' "$i").${f##*.}"
done
"$bin/omnidir_cv" "$work/all" "${board_args[@]}" --folds "$folds" --json "$work/omnidir.json" > "$work/omnidir.txt"

for ((k = 0; k < folds; ++k)); do
  d=$work/fold_$k
  rm -rf "$d"; mkdir -p "$d/train" "$d/test"
  for i in "${!images[@]}"; do
    f=${images[$i]}
    name=$(printf 'img_%03d' "$i").${f##*.}
    if ((i % folds == k)); then ln -s "$f" "$d/test/$name"; else ln -s "$f" "$d/train/$name"; fi
  done
  t0=$(date +%s.%N)
  if "$bin/panocalib" calibrate "$d/train" "${board_args[@]}" "${extra[@]}" -o "$d/calib.yaml" -q --force \
       --summary-json "$d/calibrate.json" 2> "$d/calibrate.err"; then
    echo "$(date +%s.%N) - $t0" | bc > "$d/seconds"
    "$bin/panocalib" evaluate --calib "$d/calib.yaml" "$d/test" "${board_args[@]}" --no-refine -q --force \
      --summary-json "$d/evaluate.json" 2> "$d/evaluate.err" || true
  fi
done

$py - "$work" "$folds" "${extra[*]:-}" <<'PY'
import json, math, os, sys
work, folds, extra = sys.argv[1], int(sys.argv[2]), sys.argv[3]
om = json.load(open(os.path.join(work, 'omnidir.json')))
om_img = {os.path.splitext(e['file'])[0]: e for e in om['per_image'] if e.get('fitted')}
om_fold = {f['fold']: f for f in om['folds']}
pt_img, rows, failed = {}, [], []
for k in range(folds):
    d = os.path.join(work, 'fold_%d' % k)
    ev = os.path.join(d, 'evaluate.json')
    if not os.path.exists(os.path.join(d, 'calibrate.json')):
        err = open(os.path.join(d, 'calibrate.err')).read().strip().splitlines()
        failed.append(k)
        rows.append((k, None, 'calibrate failed: ' + (err[-1] if err else '?')))
        continue
    cal = json.load(open(os.path.join(d, 'calibrate.json')))
    secs = float(open(os.path.join(d, 'seconds')).read())
    if not os.path.exists(ev):
        failed.append(k)
        rows.append((k, None, 'evaluate failed'))
        continue
    e = json.load(open(ev))
    s2 = n = 0
    for im in e['per_image']:
        if im['rms_px'] is None:
            continue
        name = os.path.splitext(im['file'])[0]
        pt_img[name] = im
        s2 += im['rms_px'] ** 2 * im['corners']
        n += im['corners']
    rows.append((k, math.sqrt(s2 / n) if n else float('nan'),
                 '%s, train %.3f px, %d boards, %.0f s' % (cal['model'], cal['rms_px'], cal['boards_used'], secs)))

def pooled(imgs, names):
    s2 = sum(imgs[x]['rms_px'] ** 2 * imgs[x]['corners'] for x in names)
    n = sum(imgs[x]['corners'] for x in names)
    return (math.sqrt(s2 / n) if n else float('nan')), len(names)

print('calibrate args: %s' % (extra or '(defaults)'))
print('| fold | panocalib held-out (px) | omnidir held-out (px) | panocalib fit |')
print('|---:|---:|---:|---|')
for k, rms, what in rows:
    o = om_fold.get(k, {})
    orms = o.get('heldout_rms_px')
    print('| %d | %s | %s | %s |' % (k, 'failed' if rms is None else '%.4f' % rms,
                                    'failed' if orms is None else '%.4f' % orms, what))
pt_all, npt = pooled(pt_img, list(pt_img))
om_all, nom = pooled(om_img, list(om_img))
common = sorted(set(pt_img) & set(om_img))
pt_c, nc = pooled(pt_img, common)
om_c, _ = pooled(om_img, common)
print('overall held-out RMS: panocalib %.4f px (%d boards, %d failed folds), omnidir %.4f px (%d boards, %d failed folds)'
      % (pt_all, npt, len(failed), om_all, nom, om['failed_folds']))
print('on the %d boards both scored: panocalib %.4f px, omnidir %.4f px, ratio %.3f' % (nc, pt_c, om_c, pt_c / om_c if om_c else float('nan')))
PY

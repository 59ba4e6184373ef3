#!/usr/bin/env bash
# Hostile-input audit of the four programs (panoloc, panocalib, panomap,
# panosim), tried as a new user would: missing, empty, damaged, truncated and
# absurd files; absurd, negative, huge and NaN flag values; unknown flags and
# subcommands; outputs onto every kind of input, onto folders and special
# files, into a read-only folder and onto a full disk (/dev/full).
#
#   tests/cli/audit.sh [BUILD_DIR]        (default: build)
#
# Its inputs are made in a temporary folder with panosim (a short sequence,
# board images) and by damaging copies of them. Every case runs under
# `timeout` in a folder of its own and is classified:
#   BAD   a crash (a signal, exit >= 128, sanitizer or "Segmentation" text),
#         a timeout, an input modified or deleted (every input is
#         checksummed before and after each case), exit 0 for a plainly
#         invalid input, or an output left behind half-written after a
#         failure (a temporary or .partial file, an empty or torn file);
#   WEAK  a failure whose message is not one line naming the program and the
#         file or flag at fault, FFmpeg's own lines without -v, or
#         "unexpected error";
#   GOOD  otherwise.
# Prints one line per case and the counts; exits 1 when any case is BAD.
# Environment: AUDIT_TIMEOUT (seconds a case may take, default 60),
# AUDIT_FILTER (a regex: run only the cases whose line matches it),
# AUDIT_KEEP=1 (keep the temporary folder), AUDIT_VERBOSE=1 (print each
# case's command and output).
set -uo pipefail
export LC_ALL=C

build=${1:-build}
BIN=$(cd "$build/bin" 2>/dev/null && pwd) || { echo "audit.sh: no $build/bin (build the programs first)" >&2; exit 2; }
for p in panoloc panocalib panomap panosim; do
  [ -x "$BIN/$p" ] || { echo "audit.sh: $BIN/$p not built" >&2; exit 2; }
done
TMO=${AUDIT_TIMEOUT:-60}
FILTER=${AUDIT_FILTER:-}
T=$(mktemp -d "${TMPDIR:-/tmp}/pano-audit.XXXXXX")
cleanup() {
  chmod -R u+w "$T" 2>/dev/null
  if [ "${AUDIT_KEEP:-0}" = 1 ]; then echo "kept $T"; else rm -rf "$T"; fi
  [ -n "${fifo_reader:-}" ] && kill "$fifo_reader" 2>/dev/null
  return 0
}
trap cleanup EXIT
IN=$T/in        # every input of every case: checksummed around each case
PRISTINE=$T/pristine
RUN=$T/run      # one folder per case, its working directory
LOG=$T/log
export HOME=$T/home XDG_CACHE_HOME=$T/cache
mkdir -p "$IN" "$RUN" "$LOG" "$HOME" "$XDG_CACHE_HOME"
chmod 1777 "$HOME" "$XDG_CACHE_HOME"

# ---------------------------------------------------------------- inputs
die() { echo "audit.sh: $*" >&2; exit 2; }
sim() { "$BIN/panosim" "$@" -q -j2 --supersample 1 >/dev/null 2>"$T/sim.err" || die "panosim $*: $(cat "$T/sim.err")"; }

# A short sequence (11 frames of paper-real's room): video, frames, gt.csv,
# map, calibration, case.yaml.
sim sequence --preset paper-real -o "$T/full"
head -12 "$T/full/gt.csv" >"$IN/traj.csv"
sim sequence --map "$T/full/map.yaml" --calib "$T/full/calib.yaml" --trajectory "$IN/traj.csv" -o "$IN/seq" --frames
S=$IN/seq
cp "$S/map.yaml" "$IN/map.yaml"
cp "$S/calib.yaml" "$IN/calib.yaml"
# Board images with known poses, and panoloc's poses of the sequence.
sim targets --calib "$IN/calib.yaml" --board 6,4,2 --auto 6 -o "$IN/tg"
"$BIN/panoloc" "$S/video.mp4" --calib "$IN/calib.yaml" --map "$IN/map.yaml" -o "$IN/poses.csv" -q ||
  die "panoloc on the sequence failed"
# A video of the boards (the images as frames).
"$BIN/panocalib" unwarp "$IN/tg/cal_%03d.png" --calib "$IN/calib.yaml" -o "$T/unused.mp4" -q 2>/dev/null
cp "$S/gt.csv" "$IN/est.smoothed.csv"
printf 'time,x,y,theta\n' >"$IN/odo.csv"
awk -F, 'NR > 1 { printf "%s,%s,%s,%s\n", $2, $3, $4, $5 }' "$S/gt.csv" >>"$IN/odo.csv"
"$BIN/panocalib" lut --calib "$IN/calib.yaml" --map "$IN/map.yaml" --size 128 -o "$IN/table.lut" -q ||
  die "panocalib lut failed"

# Damaged and absurd files.
D=$IN/bad
mkdir -p "$D"
: >"$D/empty.mp4"; : >"$D/empty.yaml"; : >"$D/empty.csv"; : >"$D/empty.png"
# Random bytes, the same every run, starting with control characters and line breaks.
python3 -c 'import random, sys; r = random.Random(40); sys.stdout.buffer.write(b"\x0c\r\x1b[2J\x00" + bytes(r.getrandbits(8) for _ in range(65536)))' >"$D/random.bin"
cp "$D/random.bin" "$D/random.mp4"; cp "$D/random.bin" "$D/random.yaml"; cp "$D/random.bin" "$D/random.csv"
cp "$D/random.bin" "$D/random.png"
echo "not a video at all" >"$D/text.mp4"
vsz=$(stat -c %s "$S/video.mp4")
head -c $((vsz / 2)) "$S/video.mp4" >"$D/half.mp4"
head -c $((vsz - 200)) "$S/video.mp4" >"$D/tail_cut.mp4"
python3 - "$S/video.mp4" "$D" <<'EOF'
import sys
src, d = sys.argv[1], sys.argv[2]
data = bytearray(open(src, 'rb').read())
n = len(data)
z = bytearray(data)
for i in range(n // 3, n // 3 + 3000): z[i] = 0
open(d + '/zeroed.mp4', 'wb').write(z)
f = bytearray(data)
for i in range(n // 2, n, 97): f[i] ^= 0xFF
open(d + '/flipped.mp4', 'wb').write(f)
EOF
psz=$(stat -c %s "$S/frames/frame_0003.png")
# Frame folders: empty, a truncated frame, a frame of another size, a text file among frames.
mkdir -p "$D/noframes" "$D/fr_trunc" "$D/fr_size" "$D/fr_text"
for k in 0 1 2 3 4 5; do for f in fr_trunc fr_size fr_text; do cp "$S/frames/frame_000$k.png" "$D/$f/"; done; done
head -c $((psz / 2)) "$S/frames/frame_0003.png" >"$D/fr_trunc/frame_0003.png"
python3 - "$D/fr_size/frame_0004.png" <<'EOF'
import sys, zlib, struct
w, h = 320, 240
raw = b''.join(b'\x00' + bytes([128]) * w for _ in range(h))
def chunk(t, d): return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
png = b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 0, 0, 0, 0)) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b'')
open(sys.argv[1], 'wb').write(png)
EOF
echo "notes" >"$D/fr_text/README.txt"

calib_with() {  # calib_with NAME 'sed expression': a damaged copy of the calibration
  sed -e "$2" "$IN/calib.yaml" >"$D/$1"
}
calib_with cal_nan_f.yaml 's/^focal_px:.*/focal_px: .nan/'
calib_with cal_neg_f.yaml 's/^focal_px:.*/focal_px: -590/'
calib_with cal_zero_f.yaml 's/^focal_px:.*/focal_px: 0/'
calib_with cal_inf_f.yaml 's/^focal_px:.*/focal_px: .inf/'
calib_with cal_cx_huge.yaml 's/^cx:.*/cx: 1e308/'
calib_with cal_cx_out.yaml 's/^cx:.*/cx: 5000/'
calib_with cal_w0.yaml 's/^image_width:.*/image_width: 0/'
calib_with cal_w_huge.yaml 's/^image_width:.*/image_width: 2000000000/'
calib_with cal_w_neg.yaml 's/^image_width:.*/image_width: -640/'
calib_with cal_w_text.yaml 's/^image_width:.*/image_width: wide/'
calib_with cal_model.yaml 's/^model:.*/model: teapot/'
calib_with cal_r0.yaml 's/^mirror_radius:.*/mirror_radius: 0/'
calib_with cal_dist_small.yaml 's/^mirror_distance:.*/mirror_distance: 2/'
calib_with cal_no_focal.yaml '/^focal_px:/d'
calib_with cal_aspect0.yaml 's/^aspect:.*/aspect: 0/'
calib_with cal_dup.yaml 's/^cx:\(.*\)/cx:\1\ncx: 100/'
calib_with cal_tab.yaml 's/^cy:/\tcy:/'
calib_with cal_list.yaml 's/^focal_px:.*/focal_px: [1, 2, 3]/'
calib_with cal_units.yaml 's/^units:.*/units: parsecs/'
calib_with cal_lut_missing.yaml '$a lut: nowhere.lut'
head -c 120 "$IN/calib.yaml" >"$D/cal_half.yaml"
printf '%s\n' "$(printf '[%.0s' $(seq 1 20000))" >"$D/deep.yaml"
{ echo 'a: &a ["x","x","x","x","x","x","x","x","x"]'
  prev=a
  for k in b c d e f g h i j k l m n o p q; do echo "$k: &$k [*$prev,*$prev,*$prev,*$prev,*$prev,*$prev,*$prev,*$prev,*$prev]"; prev=$k; done
  echo "model: *q"; } >"$D/bomb.yaml"
printf 'model: sphere\nunits: \xff\xfe\n' >"$D/cal_badutf8.yaml"

map_with() { sed -e "$2" "$IN/map.yaml" >"$D/$1"; }
map_with map_nan.yaml '0,/from: \[20.0, 0.5\]/s//from: [.nan, 0.5]/'
map_with map_huge.yaml '0,/from: \[20.0, 0.5\]/s//from: [1e300, 0.5]/'
map_with map_inf.yaml '0,/to: \[50.0, 0.5\]/s//to: [.inf, 0.5]/'
map_with map_room_inv.yaml 's/^  max: \[220.0, 220.0\]/  max: [-220.0, -220.0]/'
map_with map_z_inv.yaml '0,/z: \[10.0, 60.0\]/s//z: [60.0, 10.0]/'
map_with map_dup_id.yaml 's/id: s2/id: s1/'
map_with map_no_rect.yaml '/^rectangles:/,$d'
map_with map_h0.yaml 's/^  height: 200.0/  height: 0/'
map_with map_sensor_neg.yaml 's/^sensor_height:.*/sensor_height: -35/'
map_with map_sigma_neg.yaml 's/^survey_sigma:.*/survey_sigma: -1/'
map_with map_shade.yaml '0,/shade: 0.12/s//shade: 7/'
map_with map_zero_len.yaml '0,/to: \[50.0, 0.5\]/s//to: [20.0, 0.5]/'
{ sed '/^rectangles:/,$d' "$IN/map.yaml"; echo "rectangles:"
  for k in $(seq 1 20000); do printf '  - id: r%d\n    from: [%d.0, 0.5]\n    to: [%d.5, 0.5]\n    z: [10.0, 60.0]\n    shade: 0.12\n' "$k" $((k % 200)) $((k % 200)); done
} >"$D/map_20000.yaml"
head -c 400 "$IN/map.yaml" >"$D/map_half.yaml"

printf 'frame,time_s,x,y,theta_rad,status,n_landmarks,residual\n' >"$D/gt_header.csv"
head -4 "$S/gt.csv" >"$D/gt_short.csv"
sed '3s/.*/2,0.2,nan,nan,nan,ok,51,0/' "$S/gt.csv" >"$D/gt_nan.csv"
sed '3s/.*/2,0.2,1e308,-1e308,1e308,ok,51,0/' "$S/gt.csv" >"$D/gt_huge.csv"
sed '3s/.*/2,0.2,40,/' "$S/gt.csv" >"$D/gt_torn.csv"
{ head -1 "$S/gt.csv"; tail -n +2 "$S/gt.csv" | tac; } >"$D/gt_reversed.csv"
{ cat "$S/gt.csv"; tail -n +2 "$S/gt.csv"; } >"$D/gt_long.csv"
printf 'time,x,y,theta\n0,0,0,0\n0,nan,0,0\n' >"$D/odo_nan.csv"
printf 'time,x,y,theta\n5,0,0,0\n1,1,0,0\n' >"$D/odo_backwards.csv"
printf 'x,y,theta\n40,35,nan\n' >"$D/traj_nan.csv"
printf 'x,y,theta\n1e300,35,0\n' >"$D/traj_huge.csv"
printf 'x,y,theta\n' >"$D/traj_header.csv"
printf 'x,y,theta\n40,35,0\n' >"$D/traj_one.csv"
printf '1 0 1\n2 0 1\n' >"$D/points.txt"
printf '300 200\n100 100\n' >"$D/pixels.txt"
printf '1 0 nan\n1e308 1e308 1e308\n0 0 0\n' >"$D/points_bad.txt"
printf 'u v\n1 2 3 4\nx y\n' >"$D/pixels_bad.txt"

tgt_with() {  # tgt_with NAME 'sed expression': a damaged copy of the target file beside the images
  sed -e "$2" "$IN/tg/targets.yaml" >"$IN/tg/$1"
}
tgt_with tg_missing.yaml 's/cal_002.png/cal_999.png/'
tgt_with tg_dir.yaml 's/cal_002.png/./'
tgt_with tg_self.yaml 's/cal_002.png/tg_self.yaml/'
tgt_with tg_cols0.yaml 's/cols: 6/cols: 0/'
tgt_with tg_cols_huge.yaml 's/cols: 6/cols: 100000000/'
tgt_with tg_square_neg.yaml 's/square: 2.0/square: -2/'
tgt_with tg_square_nan.yaml 's/square: 2.0/square: .nan/'
tgt_with tg_noimages.yaml '/^images:/,$d'
tgt_with tg_rvec_nan.yaml '0,/rvec: \[/s//rvec: [.nan, /'
tgt_with tg_abs.yaml "s|cal_003.png|$D/random.png|"
tgt_with tg_devzero.yaml 's|cal_001.png|/dev/zero|'
tgt_with tg_type.yaml 's/type: chessboard/type: dartboard/'
tgt_with tg_charuco.yaml 's/type: chessboard/type: charuco/'
mkdir -p "$D/tg_bad"
cp "$IN/tg/"cal_00[0-4].png "$D/tg_bad/"
head -c 3000 "$IN/tg/cal_001.png" >"$D/tg_bad/cal_001.png"
cp "$D/random.bin" "$D/tg_bad/cal_002.png"

mkdir -p "$IN/dir" "$IN/ro"
mkfifo "$T/fifo"
chmod -R a+rX "$T"
chmod 555 "$IN/ro"
cp -a "$IN" "$PRISTINE"

manifest() { (cd "$IN" && find . -type f -print0 | sort -z | xargs -0 sha256sum; find . -type d | sort) 2>/dev/null; }
manifest >"$T/manifest"
restore() {
  chmod -R u+w "$IN" 2>/dev/null
  rm -rf "$IN" && cp -a "$PRISTINE" "$IN"
}

# ----------------------------------------------------------------- cases
n=0 n_good=0 n_weak=0 n_bad=0
bad_list=() weak_list=()
AS_NOBODY=0   # 1: the next case runs as an unprivileged user (read-only folders mean something)
STDIN=/dev/null

# names LINE KEY: whether the error line names KEY, one of KEY's
# |-separated alternatives, or the flag without its dashes as a library
# names it ("options: noise: ...").
names() {
  local k
  local IFS='|'
  for k in $2; do
    [[ $1 == *"$k"* ]] && return 0
    if [[ $k == -* ]]; then
      local bare=${k#--}
      bare=${bare#-}
      [[ $1 == *" $bare:"* ]] && return 0
    fi
  done
  return 1
}

# c EXPECT KEY PROGRAM ARGS...
#   EXPECT: fail (plainly invalid: exit 0 is BAD), ok (valid: must succeed),
#           any (either, but a failure must be one clear line)
#   KEY: a text the error line must hold (the file or flag at fault; a|b:
#        either); - for none
c() {
  local expect=$1 key=$2 prog=$3
  shift 3
  n=$((n + 1))
  local id
  id=$(printf '%03d' "$n")
  local text="$prog $*"
  text=${text//$IN\//}
  text=${text//$T\//}
  if [ -n "$FILTER" ] && ! [[ "$id $text" =~ $FILTER ]]; then AS_NOBODY=0; STDIN=/dev/null; return; fi
  local dir=$RUN/$id
  mkdir -p "$dir"
  chmod 777 "$dir"
  local wrap=()
  if [ "$AS_NOBODY" = 1 ] && [ "$(id -u)" = 0 ] && command -v setpriv >/dev/null; then
    wrap=(setpriv --reuid=65534 --regid=65534 --clear-groups)
  fi
  touch "$T/stamp"
  (cd "$dir" && exec "${wrap[@]}" timeout -k 5 "$TMO" "$BIN/$prog" "$@") <"$STDIN" >"$LOG/$id.out" 2>"$LOG/$id.err"
  local rc=$?
  AS_NOBODY=0
  STDIN=/dev/null
  local verdict=GOOD why=""
  local err
  err=$(tr '\r' '\n' <"$LOG/$id.err" | grep -v '^ *$' | grep -v ': [0-9]*/[0-9]* frames\|^panosim: frame [0-9]*/\|: tilt: trial [0-9]*' || true)
  local nlines
  # Notes and warnings before the error are information, not noise.
  local errors
  errors=$(printf '%s' "$err" | grep -v ': note: \|: warning: ' || true)
  [ -z "$errors" ] && errors=$err
  nlines=$(printf '%s' "$errors" | grep -c '' || true)
  local first=${errors%%$'\n'*}
  # BAD
  if [ $rc -eq 124 ] || [ $rc -eq 137 ]; then
    verdict=BAD why="timeout after ${TMO} s"
  elif [ $rc -ge 128 ]; then
    verdict=BAD why="killed by signal $((rc - 128))"
  elif grep -qE 'Segmentation|AddressSanitizer|LeakSanitizer|runtime error:|terminate called|core dumped|Aborted|stack smashing|double free|free\(\): ' "$LOG/$id.err" "$LOG/$id.out"; then
    verdict=BAD why="crash text"
  fi
  local changed
  changed=$(manifest | diff - "$T/manifest" | grep '^>' | sed 's/^> [0-9a-f]*  *//' | head -3 | tr '\n' ' ')
  if [ "$verdict" = GOOD ] && [ -n "$changed" ]; then
    verdict=BAD why="an input was modified or deleted: $changed"
  fi
  if [ "$verdict" = GOOD ] && [ $rc -eq 0 ] && [ "$expect" = fail ]; then
    verdict=BAD why="exit 0 for an invalid input"
  fi
  if [ "$verdict" = GOOD ] && [ $rc -ne 0 ]; then
    # What a failed run left behind: new files in its folder or among the inputs.
    local left
    left=$( (cd "$dir" && find . -type f; cd "$IN" && find . -newer "$T/stamp" ! -type d | sed 's|^\.|IN|') 2>/dev/null)
    local f
    while IFS= read -r f; do
      [ -z "$f" ] && continue
      local path=$dir/$f
      [[ $f == IN/* ]] && path=$IN/${f#IN/}
      case "$f" in
        *.partial | *.tmp | *.tmp.* | *~ | */.*.tmp* | *.part)
          verdict=BAD why="left behind after a failure: $f" ;;
        *)
          if [ ! -s "$path" ]; then verdict=BAD why="empty output left after a failure: $f"
          elif [[ $f == *.csv || $f == *.yaml || $f == *.txt ]] && [ "$(tail -c 1 "$path" | od -An -c | tr -d ' ')" != '\n' ]; then
            verdict=BAD why="torn output left after a failure: $f"
          elif [ "$prog" != panoloc ]; then
            verdict=BAD why="output left after a failure: $f"
          fi ;;  # panoloc keeps the rows of an input that broke off (documented)
      esac
    done <<<"$left"
  fi
  if [ "$verdict" = GOOD ] && [ $rc -ne 0 ] && [ "$expect" = ok ]; then
    verdict=WEAK why="failed on a valid request"
  fi
  if [ "$verdict" = GOOD ]; then
    if grep -qE '^\[[a-z0-9_,]+ @ 0x|^\[(h264|hevc|mov|mp4|png|mjpeg|swscaler|image2)' "$LOG/$id.err"; then
      verdict=WEAK why="FFmpeg's own lines"
    elif [ $rc -ne 0 ]; then
      if [ "$nlines" -eq 0 ]; then verdict=WEAK why="no message on stderr"
      elif [ "$nlines" -gt 1 ]; then verdict=WEAK why="$nlines lines"
      elif [[ $first != "$prog"* ]]; then verdict=WEAK why="does not name the program"
      elif [[ $first == *"unexpected error"* ]]; then verdict=WEAK why="unexpected error"
      elif [ "$key" != - ] && ! names "$first" "$key"; then
        verdict=WEAK why="does not name $key"
      fi
    fi
  fi
  local msg=$first
  [ ${#msg} -gt 160 ] && msg="${msg:0:157}..."
  printf '%-4s %s %-4s rc=%-3s %s\n' "$verdict" "$id" "$expect" "$rc" "$text"
  case $verdict in
    GOOD) n_good=$((n_good + 1)) ;;
    WEAK) n_weak=$((n_weak + 1)); weak_list+=("$id $why: $text")
          printf '           %s | %s\n' "$why" "$msg" ;;
    BAD) n_bad=$((n_bad + 1)); bad_list+=("$id $why: $text")
         printf '           %s | %s\n' "$why" "$msg" ;;
  esac
  if [ "${AUDIT_VERBOSE:-0}" = 1 ]; then sed 's/^/           > /' "$LOG/$id.err" | head -20; fi
  if ! manifest | cmp -s - "$T/manifest"; then restore; fi
  return 0
}

CAL=$IN/calib.yaml
MAP=$IN/map.yaml
V=$S/video.mp4
F=$S/frames
P="$S/frames/frame_%04d.png"
TG=$IN/tg/targets.yaml
LOC=(--calib "$CAL" --map "$MAP")

echo "== programs without their arguments, unknown flags and subcommands"
for prog in panoloc panocalib panomap panosim; do
  c fail - "$prog"
  c fail --bogus "$prog" --bogus
  if [ "$prog" = panoloc ]; then c fail - "$prog" frobnicate; else c fail frobnicate "$prog" frobnicate; fi
  c ok - "$prog" --version
  c ok - "$prog" --help
done
for sub in project backproject lut calibrate evaluate tilt export unwarp; do
  c fail - panocalib "$sub"
  c fail --bogus panocalib "$sub" --bogus x --calib "$CAL"
done
for sub in check refine build; do
  c fail - panomap "$sub"
  c fail --bogus panomap "$sub" --bogus "$V" --calib "$CAL" --map "$MAP"
done
for sub in still sequence targets; do
  c fail - panosim "$sub"
  c fail --bogus panosim "$sub" --bogus -o x
done
c fail --calib panoloc "$V" --map "$MAP" -o a.csv
c fail -o panoloc "$V" "${LOC[@]}" -o a.csv -o b.csv
c fail --init panoloc "$V" "${LOC[@]}" --init 1,2 -o a.csv
c fail --method panoloc "$V" "${LOC[@]}" --method magic -o a.csv
c fail --hwaccel panoloc "$V" "${LOC[@]}" --hwaccel quantum -o a.csv
c fail --threads panoloc "$V" "${LOC[@]}" --threads many -o a.csv
c fail --fps panoloc "$V" "${LOC[@]}" --fps -o a.csv
c fail - panoloc "$V" "${LOC[@]}" -o a.csv --out-dir od

echo "== missing, empty and damaged inputs: panoloc"
c fail nowhere.mp4 panoloc "$IN/nowhere.mp4" "${LOC[@]}" -o a.csv
c fail empty.mp4 panoloc "$D/empty.mp4" "${LOC[@]}" -o a.csv
c fail random.mp4 panoloc "$D/random.mp4" "${LOC[@]}" -o a.csv
c fail text.mp4 panoloc "$D/text.mp4" "${LOC[@]}" -o a.csv
c fail half.mp4 panoloc "$D/half.mp4" "${LOC[@]}" -o a.csv
c fail tail_cut.mp4 panoloc "$D/tail_cut.mp4" "${LOC[@]}" -o a.csv
c fail zeroed.mp4 panoloc "$D/zeroed.mp4" "${LOC[@]}" -o a.csv
c fail flipped.mp4 panoloc "$D/flipped.mp4" "${LOC[@]}" -o a.csv
c fail noframes panoloc "$D/noframes" "${LOC[@]}" -o a.csv
c fail fr_trunc panoloc "$D/fr_trunc" "${LOC[@]}" -o a.csv
c fail fr_size panoloc "$D/fr_size" "${LOC[@]}" -o a.csv
c any - panoloc "$D/fr_text" "${LOC[@]}" -o a.csv
c fail frame_%04d panoloc "$D/noframes/frame_%04d.png" "${LOC[@]}" -o a.csv
c fail random.png panoloc "$D/random.png" "${LOC[@]}" -o a.csv
c fail '%' panoloc "$S/frames/frame_%d%d%n.png" "${LOC[@]}" -o a.csv
c fail - panoloc - "${LOC[@]}" -o a.csv
STDIN=$D/random.bin c fail - panoloc - "${LOC[@]}" -o a.csv
c fail /dev/null panoloc /dev/null "${LOC[@]}" -o a.csv
c fail /dev/zero panoloc /dev/zero "${LOC[@]}" -o a.csv
c fail rtsp panoloc "rtsp://127.0.0.1:1/none" "${LOC[@]}" -o a.csv
c fail /dev/video9 panoloc /dev/video9 "${LOC[@]}" -o a.csv
for f in empty.yaml random.yaml nowhere.yaml cal_nan_f.yaml cal_neg_f.yaml cal_zero_f.yaml cal_inf_f.yaml \
  cal_cx_huge.yaml cal_cx_out.yaml cal_w0.yaml cal_w_huge.yaml cal_w_neg.yaml cal_w_text.yaml cal_model.yaml \
  cal_r0.yaml cal_dist_small.yaml cal_no_focal.yaml cal_aspect0.yaml cal_dup.yaml cal_tab.yaml cal_list.yaml \
  cal_units.yaml cal_half.yaml deep.yaml bomb.yaml cal_badutf8.yaml; do
  c fail "$f" panoloc "$V" --calib "$D/$f" --map "$MAP" -o a.csv
done
c any - panoloc "$V" --calib "$D/cal_lut_missing.yaml" --map "$MAP" -o a.csv
c fail dir panoloc "$V" --calib "$IN/dir" --map "$MAP" -o a.csv
c fail video.mp4 panoloc "$V" --calib "$CAL" --map "$V" -o a.csv
for f in empty.yaml random.yaml map_nan.yaml map_huge.yaml map_inf.yaml map_room_inv.yaml map_z_inv.yaml \
  map_dup_id.yaml map_no_rect.yaml map_h0.yaml map_sensor_neg.yaml map_sigma_neg.yaml map_shade.yaml \
  map_zero_len.yaml map_half.yaml deep.yaml bomb.yaml; do
  c fail "$f" panoloc "$V" --calib "$CAL" --map "$D/$f" -o a.csv
done
c any - panoloc "$V" --calib "$CAL" --map "$D/map_20000.yaml" -o a.csv
for f in empty.csv random.csv gt_header.csv gt_short.csv gt_nan.csv gt_huge.csv gt_torn.csv gt_reversed.csv gt_long.csv; do
  c fail "$f" panoloc "$V" "${LOC[@]}" -o a.csv --gt "$D/$f"
done
c fail noframes panoloc "$D/noframes" "${LOC[@]}" -o a.csv --gt auto
for f in empty.csv random.csv odo_nan.csv odo_backwards.csv nowhere.csv; do
  c fail "$f" panoloc "$V" "${LOC[@]}" -o a.csv --odometry "$D/$f"
done
c ok - panoloc "$V" "${LOC[@]}" -o a.csv --odometry "$IN/odo.csv"

echo "== absurd flag values: panoloc"
for v in -1 100000 1e9 nan 99999999999999999999; do c fail --threads panoloc "$V" "${LOC[@]}" -o a.csv --threads "$v"; done
c any - panoloc "$V" "${LOC[@]}" -o a.csv -j 100000
for v in -1 nan; do c fail -j panoloc "$V" "${LOC[@]}" -o a.csv -j "$v"; done
for v in 0 -1 nan inf 1e-300 1e300; do c fail --scale panoloc "$V" "${LOC[@]}" -o a.csv --scale "$v"; done
for v in -5 nan inf 1e-300 1e300; do c fail --fps panoloc "$V" "${LOC[@]}" -o a.csv --fps "$v"; done
for v in -1 nan inf 1e300; do c fail --search-px panoloc "$V" "${LOC[@]}" -o a.csv --search-px "$v"; done
for v in -1 nan 1e300; do c fail --min-step panoloc "$V" "${LOC[@]}" -o a.csv --min-step "$v"; done
for v in -1 2 nan; do c fail --alert-fraction panoloc "$V" "${LOC[@]}" -o a.csv --alert-fraction "$v"; done
for v in -1 nan; do c fail --alert-limit panoloc "$V" "${LOC[@]}" -o a.csv --alert-limit "$v"; done
for v in -1 nan inf; do c fail --survey-sigma panoloc "$V" "${LOC[@]}" -o a.csv --survey-sigma "$v"; done
for v in -1 nan 1e300; do c fail --tum-scale panoloc "$V" "${LOC[@]}" -o a.csv --tum a.tum --tum-scale "$v"; done
c any - panoloc "$V" "${LOC[@]}" -o a.csv --smooth-lag 0
for v in -1 1000000000; do c fail --smooth-lag panoloc "$V" "${LOC[@]}" -o a.csv --smooth-lag "$v"; done
for v in -1 nan; do c fail --odometry-scale panoloc "$V" "${LOC[@]}" -o a.csv --odometry "$IN/odo.csv" --odometry-scale "$v"; done
for v in -1 1000000000000; do c fail --decode-memory panoloc "$V" "${LOC[@]}" -o a.csv --decode-memory "$v"; done
for v in nan,nan,nan 1e300,0,0 40,35,inf; do c fail --init panoloc "$V" "${LOC[@]}" -o a.csv --init "$v"; done
c any - panoloc "$V" "${LOC[@]}" -o a.csv --init 1000,1000,0
c any - panoloc "$V" "${LOC[@]}" -o a.csv --init 40,35,1000000
c any - panoloc "$V" "${LOC[@]}" -o a.csv --hwaccel cuda
c any --table-cache panoloc "$V" "${LOC[@]}" -o a.csv --table-cache "$V"
c fail --smooth panoloc "$V" "${LOC[@]}" -o - --smooth

echo "== outputs onto inputs: panoloc"
c fail video.mp4 panoloc "$V" "${LOC[@]}" -o "$V" --force
c fail frame_0001.png panoloc "$F" "${LOC[@]}" -o "$F/frame_0001.png" --force
c fail frame_0010.png panoloc "$F" "${LOC[@]}" -o a.csv --plot "$F/frame_0010.png" --force
c fail frame_0005.png panoloc "$P" "${LOC[@]}" -o "$F/frame_0005.png" --force
c fail frame_0002.png panoloc "$F" "${LOC[@]}" -o a.csv --tum "$F/frame_0002.png" --force
c fail frame_0003.png panoloc "$F" "${LOC[@]}" -o a.csv --summary-json "$F/frame_0003.png" --force
c fail frame_0004.png panoloc "$P" "${LOC[@]}" -o a.csv --debug-video "$F/frame_0004.png" --force
c fail calib.yaml panoloc "$V" "${LOC[@]}" -o "$CAL" --force
c fail map.yaml panoloc "$V" "${LOC[@]}" -o a.csv --plot "$MAP" --force
c fail gt.csv panoloc "$V" "${LOC[@]}" -o "$S/gt.csv" --gt "$S/gt.csv" --force
c fail gt.csv panoloc "$V" "${LOC[@]}" -o a.csv --gt auto --tum "$S/gt.csv" --force
c fail odo.csv panoloc "$V" "${LOC[@]}" -o "$IN/odo.csv" --odometry "$IN/odo.csv" --force
c fail case.yaml panoloc "$V" "${LOC[@]}" -o a.csv --summary-json "$S/case.yaml" --force
c fail video.mp4 panoloc "$V" "${LOC[@]}" -o a.csv --debug-video "$V" --force
c fail est.smoothed.csv panoloc "$V" "${LOC[@]}" -o "$IN/est.csv" --smooth --gt "$IN/est.smoothed.csv" --force
ln -s "$CAL" "$RUN/cal_link.yaml"
c fail calib.yaml panoloc "$V" "${LOC[@]}" -o "$RUN/cal_link.yaml" --force
c fail a.csv panoloc "$V" "${LOC[@]}" -o a.csv --plot a.csv
c fail --out-dir panoloc "$V" "${LOC[@]}" --out-dir "$V"
c fail - panoloc "$V" "$V" "${LOC[@]}" -o a.csv
c fail video.mp4 panoloc "$V" "$D/../seq/video.mp4" "${LOC[@]}" --out-dir od
c fail poses.csv panoloc "$V" "${LOC[@]}" -o "$IN/poses.csv"
c any - panoloc "$F" "${LOC[@]}" --out-dir "$S" --force
echo "== outputs onto folders and special files: panoloc"
c fail dir panoloc "$V" "${LOC[@]}" -o "$IN/dir"
c fail dir panoloc "$V" "${LOC[@]}" -o a.csv --plot "$IN/dir" --force
c ok - panoloc "$V" "${LOC[@]}" -o /dev/null
c ok - panoloc "$V" "${LOC[@]}" -o /dev/null --plot /dev/null --summary-json /dev/null --tum /dev/null
c fail /dev/full panoloc "$V" "${LOC[@]}" -o /dev/full
c fail /dev/full panoloc "$V" "${LOC[@]}" -o a.csv --plot /dev/full
c fail /dev/full panoloc "$V" "${LOC[@]}" -o a.csv --summary-json /dev/full
c fail nodir panoloc "$V" "${LOC[@]}" -o "$T/nodir/a/b.csv"
c fail - panoloc "$V" "${LOC[@]}" -o ""
AS_NOBODY=1 AS_NOBODY=1 c fail ro panoloc "$V" "${LOC[@]}" --out-dir "$IN/ro"
AS_NOBODY=1 c fail ro panoloc "$V" "${LOC[@]}" -o a.csv --plot "$IN/ro/p.png"
c fail /proc panoloc "$V" "${LOC[@]}" -o /proc/version
# A reader for the FIFO (its own fds: none of the script's output left open).
timeout 120 cat "$T/fifo" </dev/null >/dev/null 2>&1 &
fifo_reader=$!
c ok - panoloc "$V" "${LOC[@]}" -o "$T/fifo"
kill "$fifo_reader" 2>/dev/null; wait "$fifo_reader" 2>/dev/null; fifo_reader=
c fail dir/ panoloc "$V" "${LOC[@]}" -o "$IN/dir/"

echo "== panocalib"
c ok - panocalib project --calib "$CAL" --point 10,0,5
for v in nan,0,0 1e308,1e308,1e308 0,0,0 inf,0,0; do c any - panocalib project --calib "$CAL" --point "$v"; done
c fail --point panocalib project --calib "$CAL" --point 1,2
c any - panocalib project --calib "$CAL" --points "$D/points_bad.txt"
c fail random.bin panocalib project --calib "$CAL" --points "$D/random.bin"
c fail nowhere panocalib project --calib "$CAL" --points "$D/nowhere.txt"
STDIN=$D/random.bin c fail - panocalib backproject --calib "$CAL" --pixels -
c fail pixels_bad.txt panocalib backproject --calib "$CAL" --pixels "$D/pixels_bad.txt"
for v in nan,nan -1e308,5 1e308,1e308; do c any - panocalib backproject --calib "$CAL" --pixel "$v"; done
c fail points.txt panocalib project --calib "$CAL" --points "$D/points.txt" -o "$D/points.txt" --force
c fail calib.yaml panocalib backproject --calib "$CAL" --pixels "$D/pixels.txt" -o "$CAL" --force
c fail /dev/full panocalib project --calib "$CAL" --points "$D/points.txt" -o /dev/full
for f in empty.yaml random.yaml cal_nan_f.yaml cal_cx_huge.yaml cal_w_huge.yaml cal_model.yaml deep.yaml bomb.yaml; do
  c fail "$f" panocalib project --calib "$D/$f" --point 10,0,5
done
c ok - panocalib lut --calib "$CAL" -o t.lut --size 64
for v in 0 -1 1 100000000 nan; do c fail --size panocalib lut --calib "$CAL" -o t.lut --size "$v"; done
c fail calib.yaml panocalib lut --calib "$CAL" -o "$CAL" --force
c fail map.yaml panocalib lut --calib "$CAL" --map "$MAP" -o "$MAP" --force
c fail map_huge.yaml panocalib lut --calib "$CAL" --map "$D/map_huge.yaml" -o t.lut
c fail dir panocalib lut --calib "$CAL" -o "$IN/dir" --size 64
c fail /dev/full panocalib lut --calib "$CAL" -o /dev/full --size 64
AS_NOBODY=1 c fail ro panocalib lut --calib "$CAL" -o "$IN/ro/t.lut" --size 64
c ok - panocalib calibrate "$TG" -o c.yaml -j2 -q
c fail cal_001.png panocalib calibrate "$TG" -o "$IN/tg/cal_001.png" --force
c fail cal_002.png panocalib calibrate "$TG" -o c.yaml --report "$IN/tg/cal_002.png" --force
c fail cal_003.png panocalib calibrate "$TG" -o c.yaml --lut "$IN/tg/cal_003.png" --force
c fail cal_004.png panocalib calibrate "$TG" -o c.yaml --summary-json "$IN/tg/cal_004.png" --force
c fail cal_000.png panocalib calibrate "$IN/tg" --board 6x4 --square 2 -o "$IN/tg/cal_000.png" --force
c fail targets.yaml panocalib calibrate "$TG" -o "$TG" --force
c fail c.yaml panocalib calibrate "$TG" -o c.yaml --report c.yaml
c fail dir panocalib calibrate "$TG" -o "$IN/dir"
c fail /dev/full panocalib calibrate "$TG" -o /dev/full
AS_NOBODY=1 c fail ro panocalib calibrate "$TG" -o "$IN/ro/c.yaml"
c fail cal_999.png panocalib calibrate "$IN/tg/tg_missing.yaml" -o c.yaml
c fail tg/. panocalib calibrate "$IN/tg/tg_dir.yaml" -o c.yaml
c fail random.png panocalib calibrate "$IN/tg/tg_abs.yaml" -o c.yaml
c fail /dev/zero panocalib calibrate "$IN/tg/tg_devzero.yaml" -o c.yaml
for f in tg_self.yaml tg_cols0.yaml tg_cols_huge.yaml tg_square_neg.yaml tg_square_nan.yaml \
  tg_noimages.yaml tg_rvec_nan.yaml tg_type.yaml tg_charuco.yaml; do
  c fail "$f" panocalib calibrate "$IN/tg/$f" -o c.yaml
done
c fail empty.yaml panocalib calibrate "$D/empty.yaml" -o c.yaml
c fail random.yaml panocalib calibrate "$D/random.yaml" -o c.yaml
c fail deep.yaml panocalib calibrate "$D/deep.yaml" -o c.yaml
c fail noframes panocalib calibrate "$D/noframes" --board 6x4 --square 2 -o c.yaml
c fail tg_bad panocalib calibrate "$D/tg_bad" --board 6x4 --square 2 -o c.yaml
c fail half.mp4 panocalib calibrate "$D/half.mp4" --board 6x4 --square 2 -o c.yaml
c fail zeroed.mp4 panocalib calibrate "$D/zeroed.mp4" --board 6x4 --square 2 -o c.yaml
c fail --board panocalib calibrate "$IN/tg" -o c.yaml
for v in 0x0 -6x4 6x 100000x100000 charuco:0x0 abc 6x4x3; do c fail --board panocalib calibrate "$IN/tg" --board "$v" --square 2 -o c.yaml; done
for v in 0 -2 nan inf; do c fail --square panocalib calibrate "$IN/tg" --board 6x4 --square "$v" -o c.yaml; done
for v in -1 nan; do c fail --huber panocalib calibrate "$TG" --huber "$v" -o c.yaml; done
for v in -1 nan; do c fail --max-rms panocalib calibrate "$TG" --max-rms "$v" -o c.yaml; done
for v in -5 0; do c fail --max-iterations panocalib calibrate "$TG" --max-iterations "$v" -o c.yaml; done
c fail --model panocalib calibrate "$TG" --model banana -o c.yaml
c fail --free panocalib calibrate "$TG" --free wings -o c.yaml
c fail --distortion panocalib calibrate "$TG" --distortion 7 -o c.yaml
c fail --asphere-terms panocalib calibrate "$TG" --model asphere --asphere-terms 9 -o c.yaml
# -j, --jobs and --threads are one option.
for v in -1 100000 nan; do c fail '--jobs|--threads' panocalib calibrate "$TG" --threads "$v" -o c.yaml; done
c fail --every panocalib calibrate "$D/../seq/video.mp4" --board 6x4 --square 2 --every -3 -o c.yaml
c ok - panocalib evaluate "$TG" --calib "$CAL" -q
c fail cal_003.png panocalib evaluate "$TG" --calib "$CAL" --summary-json "$IN/tg/cal_003.png" --force
c fail calib.yaml panocalib evaluate "$TG" --calib "$CAL" --summary-json "$CAL" --force
c fail half.mp4 panocalib evaluate "$D/half.mp4" --calib "$CAL" --board 6x4 --square 2
c fail tg_bad panocalib evaluate "$D/tg_bad" --calib "$CAL" --board 6x4 --square 2
for f in cal_nan_f.yaml cal_cx_huge.yaml cal_w0.yaml; do c fail "$f" panocalib evaluate "$TG" --calib "$D/$f"; done
c fail cal_999.png panocalib evaluate "$IN/tg/tg_missing.yaml" --calib "$CAL"
c fail /dev/full panocalib evaluate "$TG" --calib "$CAL" --summary-json /dev/full
c ok - panocalib export --calib "$CAL" --opencv -o cv.yml
c fail calib.yaml panocalib export --calib "$CAL" --opencv -o "$CAL" --force
c fail cv.txt panocalib export --calib "$CAL" --opencv -o cv.txt
for v in -1 nan 1e300; do c fail --distance panocalib export --calib "$CAL" --opencv -o cv.yml --distance "$v"; done
c ok - panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o u.png
c fail frame_0000.png panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o "$F/frame_0000.png" --force
c fail frame_%04d.png panocalib unwarp "$P" --calib "$CAL" -o "$F/frame_0001.png" --force
c fail video.mp4 panocalib unwarp "$V" --calib "$CAL" -o "$V" --force
for v in 0x0 -5x5 100000x100000 axb 1x1; do c fail --size panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o u.png --size "$v"; done
for v in 0 -10 180 nan 1e300; do c fail --fov panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o u.png --perspective --fov "$v"; done
c fail --elevation panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o u.png --elevation 50,-50
c fail --elevation panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o u.png --elevation nan,10
c fail --distance panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o u.png --distance -5
c fail random.png panocalib unwarp "$D/random.png" --calib "$CAL" -o u.png
c fail frame_0003.png panocalib unwarp "$D/fr_trunc/frame_0003.png" --calib "$CAL" -o u.png
c fail empty.png panocalib unwarp "$D/empty.png" --calib "$CAL" -o u.png
c fail frame_0004.png panocalib unwarp "$D/fr_size/frame_0004.png" --calib "$CAL" -o u.png
c fail u.xyz panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o u.xyz
c fail half.mp4 panocalib unwarp "$D/half.mp4" --calib "$CAL" -o u.mp4
c fail zeroed.mp4 panocalib unwarp "$D/zeroed.mp4" --calib "$CAL" -o u.mp4
c fail /dev/full panocalib unwarp "$F/frame_0000.png" --calib "$CAL" -o /dev/full
c ok - panocalib tilt "$V" --calib "$CAL" --map "$MAP" -o tilt.yaml --frames 6 --max-trials 4 -q
c fail calib.yaml panocalib tilt "$V" --calib "$CAL" --map "$MAP" -o "$CAL" --force --frames 6 --max-trials 4
c fail map.yaml panocalib tilt "$V" --calib "$CAL" --map "$MAP" -o "$MAP" --force --frames 6 --max-trials 4
c any - panocalib tilt "$V" --calib "$CAL" --map "$MAP" -o tilt.yaml --frames 1000000000 --max-trials 4
for v in -1 0; do c fail --frames panocalib tilt "$V" --calib "$CAL" --map "$MAP" -o tilt.yaml --frames "$v" --max-trials 4; done
for v in -1 nan; do c fail --step panocalib tilt "$V" --calib "$CAL" --map "$MAP" -o tilt.yaml --step "$v" --max-trials 4; done
c fail --tolerance panocalib tilt "$V" --calib "$CAL" --map "$MAP" -o tilt.yaml --tolerance -1 --max-trials 4
c fail --max-trials panocalib tilt "$V" --calib "$CAL" --map "$MAP" -o tilt.yaml --max-trials -4
c fail half.mp4 panocalib tilt "$D/half.mp4" --calib "$CAL" --map "$MAP" -o tilt.yaml --frames 6 --max-trials 4
c fail zeroed.mp4 panocalib tilt "$D/zeroed.mp4" --calib "$CAL" --map "$MAP" -o tilt.yaml --frames 6 --max-trials 4

echo "== panomap"
c ok - panomap check "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" --no-unmapped -q
c fail frame_0002.png panomap check "$F" --map "$MAP" --calib "$CAL" --pose 40,35,0 -o "$F/frame_0002.png" --force
c fail frame_0003.png panomap check "$P" --map "$MAP" --calib "$CAL" --pose 40,35,0 --report "$F/frame_0003.png" --force
c fail video.mp4 panomap check "$V" --map "$MAP" --calib "$CAL" --pose 40,35,0 -o "$V" --force
c fail gt.csv panomap check "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" --report "$S/gt.csv" --force
c fail map.yaml panomap check "$V" --map "$MAP" --calib "$CAL" --pose 40,35,0 --report "$MAP" --force
c fail --pose panomap check "$V" --map "$MAP" --calib "$CAL" --pose nan,nan,nan
c fail --pose panomap check "$V" --map "$MAP" --calib "$CAL" --pose 1,2
c fail --pose panomap check "$V" --map "$MAP" --calib "$CAL" --pose 40,35,0 --poses "$S/gt.csv"
for v in -1 nan 1e300; do c fail --search panomap check "$V" --map "$MAP" --calib "$CAL" --pose 40,35,0 --search "$v"; done
for v in -1 2 nan; do c fail --min-found panomap check "$V" --map "$MAP" --calib "$CAL" --pose 40,35,0 --min-found "$v"; done
c fail --bias-floor panomap check "$V" --map "$MAP" --calib "$CAL" --pose 40,35,0 --bias-floor -1
for f in gt_short.csv gt_nan.csv gt_torn.csv random.csv empty.csv; do
  c fail "$f" panomap check "$V" --map "$MAP" --calib "$CAL" --poses "$D/$f"
done
c fail frame_0003.png panomap check "$D/fr_trunc/frame_0003.png" --map "$MAP" --calib "$CAL" --pose 40,35,0
c fail frame_0003.png panomap check "$D/fr_trunc" --map "$MAP" --calib "$CAL" --pose 40,35,0
for f in half.mp4 zeroed.mp4 empty.mp4 random.mp4; do c fail "$f" panomap check "$D/$f" --map "$MAP" --calib "$CAL" --pose 40,35,0; done
for f in map_nan.yaml map_huge.yaml map_no_rect.yaml bomb.yaml; do c fail "$f" panomap check "$V" --map "$D/$f" --calib "$CAL" --pose 40,35,0; done
c fail /dev/full panomap check "$V" --map "$MAP" --calib "$CAL" --pose 40,35,0 --report /dev/full
c fail dir panomap check "$V" --map "$MAP" --calib "$CAL" --pose 40,35,0 --report "$IN/dir"
c ok - panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml -q
c fail map.yaml panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o "$MAP" --force
c fail gt.csv panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml --report "$S/gt.csv" --force
c fail frame_0001.png panomap build "$F" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o "$F/frame_0001.png" --force
c any - panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml --min-views 1000000000
for v in -1 0; do c fail --min-views panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml --min-views "$v"; done
for v in -1 nan; do c fail --min-parallax panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml --min-parallax "$v"; done
for v in -1 nan; do c fail --max-std panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml --max-std "$v"; done
c fail --min-score panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml --min-score 5
c fail --id-prefix panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml --id-prefix ""
c fail --start panomap build "$V" --map "$MAP" --calib "$CAL" --start nan,0,0 -o b.yaml
c fail half.mp4 panomap build "$D/half.mp4" --map "$MAP" --calib "$CAL" --poses "$S/gt.csv" -o b.yaml
c fail gt_short.csv panomap build "$V" --map "$MAP" --calib "$CAL" --poses "$D/gt_short.csv" -o b.yaml
c ok - panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml -j2 -q
c fail map.yaml panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o "$MAP" --force
c fail poses.csv panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml --report "$IN/poses.csv" --force
c fail video.mp4 panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o "$V" --force
c fail frame_0000.png panomap refine "$F" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o "$F/frame_0000.png" --force
c fail --poses panomap refine "$V" "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml
for v in -1 0 nan; do c fail --map-sigma panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml --map-sigma "$v"; done
for v in -1 nan loud; do c fail --pose-sigma panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml --pose-sigma "$v"; done
for v in 0 1000; do c fail --passes panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml --passes "$v"; done
c fail --reject-sigmas panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml --reject-sigmas 1
for v in -1 100000; do c fail '--jobs|--threads' panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml --threads "$v"; done
for f in gt_short.csv gt_nan.csv random.csv; do
  c fail "$f" panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$D/$f" -o r.yaml
done
c fail half.mp4 panomap refine "$D/half.mp4" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o r.yaml
c fail /dev/full panomap refine "$V" --map "$MAP" --calib "$CAL" --poses "$IN/poses.csv" -o /dev/full

echo "== panosim"
c ok - panosim still --preset paper-real -o s.png --supersample 1
c fail --preset panosim still --preset nonsense -o s.png
c fail --supersample panosim still --preset paper-real -o s.png --supersample 100
c fail --supersample panosim still --preset paper-real -o s.png --supersample 0
for v in -1 nan 1e300; do c fail --noise panosim still --preset paper-real -o s.png --noise "$v"; done
for v in 1 -1 nan; do c fail --gradient panosim still --preset paper-real -o s.png --gradient "$v"; done
for v in -1 2 nan; do c fail --texture panosim still --preset paper-real -o s.png --texture "$v"; done
c fail --camera-radius panosim still --preset paper-real -o s.png --camera-radius -5
c fail --camera-radius panosim still --preset paper-real -o s.png --camera-radius nan
for v in -1 1000000000 nan; do c fail --frame panosim still --preset paper-real -o s.png --frame "$v"; done
for v in nan,0,0 1e300,0,0; do c fail --pose panosim still --map "$MAP" --calib "$CAL" --pose "$v" -o s.png; done
c fail --decentre panosim still --preset paper-real -o s.png --decentre nan,0
c fail --camera-tilt panosim still --preset paper-real -o s.png --camera-tilt 1000,0
c fail --sensor-tilt panosim still --preset paper-real -o s.png --sensor-tilt nan,0
c fail --distortion panosim still --preset paper-real -o s.png --distortion 1e300,0
c fail --asphere panosim still --preset paper-real -o s.png --asphere nan
c fail --jobs panosim still --preset paper-real -o s.png -j 1000000
c fail --jobs panosim still --preset paper-real -o s.png -j -3
c fail map.yaml panosim still --map "$MAP" --calib "$CAL" --pose 40,35,0 -o "$MAP" --force
c fail calib.yaml panosim still --map "$MAP" --calib "$CAL" --pose 40,35,0 -o "$CAL" --force
for f in cal_nan_f.yaml cal_w_huge.yaml cal_model.yaml empty.yaml bomb.yaml; do
  c fail "$f" panosim still --map "$MAP" --calib "$D/$f" --pose 40,35,0 -o s.png
done
for f in map_nan.yaml map_huge.yaml map_room_inv.yaml map_no_rect.yaml; do
  c fail "$f" panosim still --map "$D/$f" --calib "$CAL" --pose 40,35,0 -o s.png
done
c fail /dev/full panosim still --preset paper-real -o /dev/full --supersample 1
c fail dir panosim still --preset paper-real -o "$IN/dir" --supersample 1
AS_NOBODY=1 c fail ro panosim still --preset paper-real -o "$IN/ro/s.png" --supersample 1
c ok - panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --supersample 1
c fail seq panosim sequence --map "$S/map.yaml" --calib "$S/calib.yaml" --trajectory "$S/gt.csv" -o "$S" --force
c fail "$IN/" panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o "$IN" --force
c fail map.yaml panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o "$MAP" --force
c any - panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o "$IN/dir" --supersample 1
c fail video.mp4 panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o "$V" --force
for f in traj_nan.csv traj_huge.csv traj_header.csv empty.csv random.csv nowhere.csv; do
  c fail "$f" panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$D/$f" -o sq
done
c any - panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$D/traj_one.csv" -o sq --supersample 1
for v in 0 -10 nan 1e300 1e-300; do c fail --fps panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --fps "$v"; done
c fail --no-video panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --no-video
for v in -1 2 nan; do c fail --exposure panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --exposure "$v"; done
c fail --blur-samples panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --blur-samples 100000 --exposure 0.5
c fail --people panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --people 100000
c fail --covered-frames panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --covered-frames 1000
c fail --dropped-frames panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --dropped-frames 1000
c fail --auto-exposure panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --auto-exposure 5
c fail --map-sigma panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --map-sigma nan
c fail --map-gross panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --map-gross 1000
c fail --map-gross-offset panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o sq --map-gross 1 --map-gross-offset -1
c fail /dev/null panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o /dev/null --force
AS_NOBODY=1 c fail ro panosim sequence --map "$MAP" --calib "$CAL" --trajectory "$IN/traj.csv" -o "$IN/ro/sq" --supersample 1
c ok - panosim targets --calib "$CAL" --board 6,4,2 --auto 3 -o tt --supersample 1
c fail --board panosim targets --calib "$CAL" --board 0,0,2 --auto 3 -o tt
c fail --board panosim targets --calib "$CAL" --board 6,4,-2 --auto 3 -o tt
c fail --board panosim targets --calib "$CAL" --board 100000,100000,2 --auto 3 -o tt
c fail --board panosim targets --calib "$CAL" --board 6,4,nan --auto 3 -o tt
c fail --auto panosim targets --calib "$CAL" --board 6,4,2 --auto -3 -o tt
c fail --auto panosim targets --calib "$CAL" --board 6,4,2 --auto 100000000 -o tt
c fail --min-visible panosim targets --calib "$CAL" --board 6,4,2 --auto 3 --min-visible 5 -o tt
c fail --charuco panosim targets --calib "$CAL" --board 6,4,2 --auto 3 --charuco 5 -o tt
c fail --dictionary panosim targets --calib "$CAL" --board 6,4,2 --auto 3 --charuco 1 --dictionary DICT_BOGUS -o tt
c fail - panosim targets --calib "$CAL" --board 6,4,2 -o tt
c fail random.csv panosim targets --calib "$CAL" --board 6,4,2 --poses "$D/random.csv" -o tt
c fail calib.yaml panosim targets --calib "$CAL" --board 6,4,2 --auto 3 -o "$CAL" --force
c fail tg panosim targets --calib "$IN/tg/truth.yaml" --board 6,4,2 --auto 3 -o "$IN/tg" --force

echo "== signals"
# An interrupted run: exit 130/143, the rows so far kept as documented.
n=$((n + 1))
id=$(printf '%03d' "$n")
mkdir -p "$RUN/$id"
(cd "$RUN/$id" && exec "$BIN/panoloc" "$D/../seq/frames" "${LOC[@]}" -o a.csv --threads 1 >"$LOG/$id.out" 2>"$LOG/$id.err") &
pid=$!
sleep 0.3
kill -INT "$pid" 2>/dev/null
wait "$pid"
rc=$?
if [ $rc -eq 0 ] || [ $rc -eq 130 ]; then verdict=GOOD; n_good=$((n_good + 1)); else verdict=BAD; n_bad=$((n_bad + 1)); bad_list+=("$id SIGINT: exit $rc"); fi
printf '%-4s %s %-4s rc=%-3s %s\n' "$verdict" "$id" any "$rc" "panoloc frames ... -o a.csv (SIGINT after 0.3 s)"

echo
echo "cases: $n  good: $n_good  weak: $n_weak  bad: $n_bad"
for l in "${bad_list[@]}"; do echo "BAD  $l"; done
[ "$n_bad" -eq 0 ]

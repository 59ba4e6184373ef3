#!/usr/bin/env bash
# Builds the Debian package with `cpack -G DEB` (which first builds the whole
# tree, as `make install` does), extracts it and checks its files, its
# control fields and its panoloc.
# Usage: deb.sh BUILD_DIR WORK_DIR VERSION CPACK WITH_MAN_PAGES(0|1)
set -euo pipefail
build=$1 work=$2 version=$3 cpack=$4 with_man=$5
for tool in dpkg-deb dpkg-shlibdeps; do
  command -v $tool > /dev/null || { echo "deb: no $tool (dpkg-dev); skipped"; exit 77; }
done
rm -rf "$work" && mkdir -p "$work"
(cd "$build" && "$cpack" -G DEB -B "$work") > "$work.cpack.log" 2>&1 || { cat "$work.cpack.log"; exit 1; }
deb=$work/panotrack_${version}_$(dpkg --print-architecture).deb
[ -f "$deb" ] || { echo "deb: no $deb"; ls "$work"; exit 1; }
echo "$(basename "$deb"): $(du -k "$deb" | cut -f1) KiB"
dpkg-deb -f "$deb" Package Version Section Maintainer Depends
[ "$(dpkg-deb -f "$deb" Section)" = science ] || { echo "deb: section is not science"; exit 1; }
dpkg-deb -f "$deb" Depends | grep -q libopencv || { echo "deb: Depends names no OpenCV library"; exit 1; }
dpkg-deb -x "$deb" "$work/root"
cd "$work/root"
expected=(usr/bin/panoloc usr/bin/panocalib usr/bin/panomap usr/bin/panosim usr/lib/libpano_core.a
          usr/lib/cmake/panotrack/panotrackConfig.cmake usr/lib/pkgconfig/panotrack.pc
          usr/include/panotrack/config.h usr/include/panotrack/sensor/sensor.h
          usr/share/panotrack/calib/paper-real.yaml usr/share/doc/panotrack/LICENSE
          usr/lib/panotrack/libpanotrack_opencv_io.so)
[ "$with_man" = 1 ] && expected+=(usr/share/man/man1/panoloc.1)
for f in "${expected[@]}"; do
  [ -f "$f" ] || { echo "deb: missing $f"; exit 1; }
done
echo "$(find . -type f | wc -l) files in the package"
# The OpenCV I/O module panoloc loads on demand: its libraries resolve.
python3 -c 'import ctypes, sys; ctypes.CDLL(sys.argv[1])' usr/lib/panotrack/libpanotrack_opencv_io.so ||
  { echo "deb: usr/lib/panotrack/libpanotrack_opencv_io.so does not load"; exit 1; }
got=$(usr/bin/panoloc --version)
echo "usr/bin/panoloc --version: $got"
[ "$got" = "panoloc $version" ] || { echo "deb: expected panoloc $version"; exit 1; }

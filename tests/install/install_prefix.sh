#!/usr/bin/env bash
# Fixture of the install tests: builds what the install step copies, installs
# the build tree into a fresh prefix and checks what is (and is not) there.
# Usage: install_prefix.sh BUILD_DIR PREFIX WITH_MAN_PAGES(0|1)
set -euo pipefail
build=$1 prefix=$2 with_man=$3
cmake --build "$build" --target pano_installable -j"$(nproc 2>/dev/null || echo 2)" > "$prefix.build.log" 2>&1 ||
  { tail -40 "$prefix.build.log"; exit 1; }
rm -rf "$prefix"
cmake --install "$build" --prefix "$prefix" > "$prefix.install.log"
cd "$prefix"
libdir=$(dirname "$(find . -name libpano_core.a)")
expected=(bin/panoloc bin/panocalib bin/panomap bin/panosim
          "$libdir/libpano_core.a" "$libdir/libpano_sensor.a" "$libdir/libpano_pipeline.a"
          "$libdir/cmake/panotrack/panotrackConfig.cmake" "$libdir/cmake/panotrack/panotrackConfigVersion.cmake"
          "$libdir/cmake/panotrack/panotrackTargets.cmake" "$libdir/pkgconfig/panotrack.pc"
          include/panotrack/config.h include/panotrack/sensor/sensor.h include/panotrack/io/calibration.h
          share/panotrack/calib/paper-real.yaml share/panotrack/calib/paper-synthetic.yaml
          share/doc/panotrack/README.md share/doc/panotrack/LICENSE share/doc/panotrack/CHANGELOG.md
          share/doc/panotrack/docs/panoloc.md)
[ "$with_man" = 1 ] && expected+=(share/man/man1/panoloc.1 share/man/man1/panocalib.1 share/man/man1/panomap.1 share/man/man1/panosim.1)
internal=(include/panotrack/calibrate/internal.h include/panotrack/calibrate/refit.h
          include/panotrack/calibrate/omnidir_peer.h include/panotrack/hough/peak_refine.h
          include/panotrack/plot/figure.h include/panotrack/core/parallel.h include/panotrack/render/render.h
          include/panotrack/calibrate/model_selection.h include/panotrack/io/yaml_util.h)
expected+=(include/panotrack/track/localizer.h include/panotrack/pipeline/panoloc.h
           include/panotrack/calibrate/calibrate.h include/panotrack/mapping/refine.h include/panotrack/unwarp/unwarp.h)
status=0
for f in "${expected[@]}"; do
  [ -f "$f" ] || { echo "install: missing $f"; status=1; }
done
for f in "${internal[@]}"; do
  [ ! -e "$f" ] || { echo "install: internal header installed: $f"; status=1; }
done
# The public API is closed: every toolkit header an installed header
# includes is installed too.
while IFS= read -r h; do
  while IFS= read -r inc; do
    [ -f "include/$inc" ] || { echo "install: $h includes $inc, which is not installed"; status=1; }
  done < <(sed -n 's/^#include "\(panotrack\/[^"]*\)".*/\1/p' "$h")
done < <(find include -name '*.h')
echo "installed $(find . -type f | wc -l) files under $prefix ($(find include -name '*.h' | wc -l) headers)"
exit $status

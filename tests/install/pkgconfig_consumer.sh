#!/usr/bin/env bash
# Compiles tests/install/consumer/main.cc against the installed prefix with
# `pkg-config --cflags --libs panotrack` alone and checks its pixel against
# the installed `panocalib project` exactly.
# Usage: pkgconfig_consumer.sh PREFIX WORK_DIR CONSUMER_SOURCE_DIR CXX
set -euo pipefail
prefix=$1 work=$2 source=$3 cxx=$4
command -v pkg-config > /dev/null || { echo "pkgconfig_consumer: no pkg-config; skipped"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
pc=$(find "$prefix" -name panotrack.pc)
export PKG_CONFIG_PATH=$(dirname "$pc")
echo "pkg-config: panotrack $(pkg-config --modversion panotrack)"
calibdir=$(pkg-config --variable=calibdir panotrack)
# shellcheck disable=SC2046  # pkg-config's flags are meant to be split
"$cxx" -std=c++17 -O2 "$source/main.cc" -o "$work/consumer" -DPANOTRACK_CALIB_DIR="\"$calibdir\"" \
  $(pkg-config --cflags --libs panotrack)
got=$("$work/consumer")
want=$("$prefix/bin/panocalib" project --calib "$prefix/share/panotrack/calib/paper-real.yaml" --point 200,50,30)
echo "consumer:          $got"
echo "panocalib project: $want"
[ "$got" = "$want" ] || { echo "pkgconfig_consumer: the pixels differ"; exit 1; }

#!/usr/bin/env bash
# Builds tests/install/consumer against the installed prefix with
# find_package(panotrack) and checks its pixel against the installed
# `panocalib project` exactly. With "headers" as the fifth argument, compiles
# every installed header on its own instead.
# Usage: cmake_consumer.sh PREFIX WORK_DIR CONSUMER_SOURCE_DIR CXX [headers]
set -euo pipefail
prefix=$1 work=$2 source=$3 cxx=$4 mode=${5:-run}
rm -rf "$work"
check_headers=OFF; target=consumer
[ "$mode" = headers ] && { check_headers=ON; target=header_check; }
cmake -S "$source" -B "$work" -DCMAKE_CXX_COMPILER="$cxx" \
  -DCMAKE_PREFIX_PATH="$prefix" -DCHECK_HEADERS=$check_headers > "$work.configure.log" 2>&1 ||
  { cat "$work.configure.log"; exit 1; }
grep -E '^-- (panotrack|checking)' "$work.configure.log"
# The package must come from the prefix, not from a system-wide install.
grep -q "^-- panotrack .* from $prefix/" "$work.configure.log" ||
  { echo "cmake_consumer: panotrack was not found under $prefix"; exit 1; }
cmake --build "$work" --target $target -j"$(nproc 2>/dev/null || echo 2)" > "$work.build.log" 2>&1 ||
  { tail -60 "$work.build.log"; exit 1; }
[ "$mode" = headers ] && { echo "all installed headers compile on their own"; exit 0; }
got=$("$work/consumer")
want=$("$prefix/bin/panocalib" project --calib "$prefix/share/panotrack/calib/paper-real.yaml" --point 200,50,30)
echo "consumer:          $got"
echo "panocalib project: $want"
[ "$got" = "$want" ] || { echo "cmake_consumer: the pixels differ"; exit 1; }

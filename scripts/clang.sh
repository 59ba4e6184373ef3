#!/usr/bin/env bash
# Builds everything with clang/clang++ in build-clang/ (warnings as errors,
# CPU paths only) and runs the test suite.
#   scripts/clang.sh [extra cmake -D options]
# Environment: BUILD_DIR (default <repo>/build-clang), JOBS (default nproc),
# CTEST_ARGS (e.g. "-R ^hough/"), CC / CXX (default clang / clang++).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build-clang}
jobs=${JOBS:-$(nproc)}
bash "$root/scripts/install-deps.sh"
if ! command -v "${CXX:-clang++}" >/dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get install -y -qq --no-install-recommends clang >/dev/null
fi

cmake -S "$root" -B "$build" -DCMAKE_C_COMPILER="${CC:-clang}" -DCMAKE_CXX_COMPILER="${CXX:-clang++}" \
  -DCMAKE_BUILD_TYPE=Release -DPANO_WERROR=ON -DPANO_BUILD_BENCHMARKS=OFF -DPANO_ENABLE_CUDA=OFF "$@"
cmake --build "$build" -j"$jobs"
cd "$build"
# shellcheck disable=SC2086
ctest --output-on-failure -j"$jobs" ${CTEST_ARGS:-}

#!/usr/bin/env bash
# Installs the dependencies (Debian packages, as root), builds with warnings
# as errors and runs the test suite with ctest. Usage: scripts/test.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
# The Python module and its tests use Debian's interpreter (where numpy and
# pytest come from), not another python3 earlier on the PATH.
python=()
[ -x /usr/bin/python3 ] && python=(-DPython_EXECUTABLE=/usr/bin/python3)
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DPANO_WERROR=ON "${python[@]}"
cmake --build "$build" -j"$jobs"
cd "$build"
ctest --output-on-failure -j"$jobs" --label-exclude benchmark

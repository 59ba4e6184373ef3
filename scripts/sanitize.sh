#!/usr/bin/env bash
# Builds everything with AddressSanitizer and UndefinedBehaviorSanitizer in
# build-asan/ (CPU paths only) and runs the test suite; any sanitizer report
# fails its test.
#   scripts/sanitize.sh [extra cmake -D options]
# Environment: BUILD_DIR (default <repo>/build-asan), JOBS (default nproc),
# CTEST_ARGS (e.g. "-R ^hough/"), TARGETS (e.g. "test_hough test_track"; default all).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build-asan}
jobs=${JOBS:-$(nproc)}
bash "$root/scripts/install-deps.sh"

cmake -S "$root" -B "$build" -DPANO_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DPANO_BUILD_BENCHMARKS=OFF -DPANO_ENABLE_CUDA=OFF "$@"
cmake --build "$build" -j"$jobs" ${TARGETS:+--target $TARGETS}

# Leaks: the check stays on for the project's code. libgomp keeps its thread
# pool and per-thread state until exit by design, and OpenCV and FFmpeg keep
# process-wide caches (codec registries, allocator pools, TLS) that are never
# freed: those allocations are suppressed by the library that made them, not
# switched off wholesale, so a leak reached from our own frames still fails.
cat > "$build/lsan.supp" <<'SUPP'
leak:libgomp.so
leak:libopencv_
leak:libavcodec.so
leak:libavformat.so
leak:libavutil.so
leak:libx264.so
leak:libfontconfig.so
SUPP

# Errors are fatal (exit code 1 fails the test): ASan stops at the first
# report by default, UBSan does with -fno-sanitize-recover plus halt_on_error.
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:detect_stack_use_after_return=1:strict_init_order=1:check_initialization_order=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$build/lsan.supp:print_suppressions=0"

cd "$build"
# shellcheck disable=SC2086
ctest --output-on-failure -j"$jobs" ${CTEST_ARGS:-}

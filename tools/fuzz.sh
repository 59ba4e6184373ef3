#!/usr/bin/env bash
# Fuzzes every reader of the toolkit's files with libFuzzer under
# AddressSanitizer and UndefinedBehaviorSanitizer: calibration, map, targets,
# pose CSV, odometry, case.yaml and lookup table (.lut) files. (No TUM reader
# exists: the toolkit only writes TUM files.)
#   tools/fuzz.sh [SECONDS_PER_READER] [READER...]     (default 60 s, every reader)
# Each reader starts from its seed corpus, tests/fuzz/corpus/<reader>/ (kept
# in the repository), copied to BUILD_DIR/fuzz-corpus/<reader>/, where the
# inputs it finds accumulate between runs. Prints the executions, the corpus
# and the findings (crashes, hangs, sanitizer reports, exceptions other than
# pano::Error) of each reader; findings are kept in BUILD_DIR/fuzz-findings/.
# Exits 1 when any reader has a finding.
# Environment: BUILD_DIR (default <repo>/build-fuzz), JOBS (default nproc),
# CC / CXX (default clang / clang++), TIMEOUT_S (one input at most, default 10).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build-fuzz}
jobs=${JOBS:-$(nproc)}
seconds=${1:-60}
shift || true
readers=("$@")
[ ${#readers[@]} -eq 0 ] && readers=(calibration map targets pose_csv odometry case lut)

if ! command -v "${CXX:-clang++}" >/dev/null; then
  echo "fuzz.sh: ${CXX:-clang++} not found (apt-get install clang)" >&2
  exit 1
fi
cmake -S "$root" -B "$build" -DCMAKE_C_COMPILER="${CC:-clang}" -DCMAKE_CXX_COMPILER="${CXX:-clang++}" \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPANO_SANITIZE=ON -DPANO_FUZZ=ON -DPANO_BUILD_TESTS=OFF \
  -DPANO_BUILD_BENCHMARKS=OFF -DPANO_BUILD_PYTHON=OFF -DPANO_ENABLE_CUDA=OFF >/dev/null
targets=()
for r in "${readers[@]}"; do targets+=("fuzz_$r"); done
cmake --build "$build" -j"$jobs" --target "${targets[@]}"

export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
printf '%-12s %12s %10s %8s %s\n' reader executions exec/s corpus findings
status=0
for r in "${readers[@]}"; do
  corpus=$build/fuzz-corpus/$r
  findings=$build/fuzz-findings/$r
  log=$build/fuzz-findings/$r.log
  mkdir -p "$corpus" "$findings"
  cp -n "$root/tests/fuzz/corpus/$r/"* "$corpus/" 2>/dev/null || true
  max_len=16384  # text files; a lookup table's seed is 66 kB
  [ "$r" = lut ] && max_len=131072
  "$build/tests/fuzz/fuzz_$r" "$corpus" -max_total_time="$seconds" -timeout="${TIMEOUT_S:-10}" \
    -rss_limit_mb=2048 -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$findings/" \
    >"$log" 2>&1 || true
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  n_found=$(find "$findings" -type f \( -name 'crash-*' -o -name 'timeout-*' -o -name 'leak-*' -o -name 'oom-*' \) | wc -l)
  printf '%-12s %12s %10s %8s %s\n' "$r" "${execs:-?}" "${rate:-?}" "$(ls "$corpus" | wc -l)" "$n_found"
  if [ "$n_found" -gt 0 ] || [ -z "$execs" ]; then
    status=1
    echo "  see $log and $findings/" >&2
  fi
done
exit $status

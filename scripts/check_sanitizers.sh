#!/usr/bin/env bash
# Builds ActiveQS with a sanitizer and runs the test suite under it (docs/testing.md,
# "Sanitizers"). Not part of CI: an instrumented build of everything takes about an hour
# at -j2 (AddressSanitizer's is the slowest), its tests about 40 minutes.
# Usage: scripts/check_sanitizers.sh address|thread [ctest arguments, e.g. -R Lbfgs]
#   address: -DAQS_SANITIZE=address,undefined into build-asan; LeakSanitizer's reports of
#            leaks inside Open MPI, CHOLMOD and the other prebuilt libraries are suppressed
#            (tests/sanitizers/lsan_suppressions.txt); a leak of ActiveQS's own is not.
#   thread:  -DAQS_SANITIZE=thread into build-tsan; OpenMP capped at one thread (Debian's
#            CHOLMOD opens OpenMP regions with their own thread counts, and libgomp is not
#            instrumented: its barriers would read as races).
# Any report fails the test that made it. Exit status: ctest's.
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-}
shift || true
jobs=$(nproc 2>/dev/null || echo 2)
case "${kind}" in
  address)
    dir=build-asan
    sanitizers=address,undefined
    export ASAN_OPTIONS=detect_leaks=1:check_initialization_order=1
    export LSAN_OPTIONS="suppressions=${PWD}/tests/sanitizers/lsan_suppressions.txt:print_suppressions=0:fast_unwind_on_malloc=0"
    export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
    ;;
  thread)
    dir=build-tsan
    sanitizers=thread
    export OMP_NUM_THREADS=1 OMP_THREAD_LIMIT=1
    export TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1
    ;;
  *)
    echo "usage: $0 address|thread [ctest arguments]" >&2
    exit 1
    ;;
esac
cmake -S . -B "${dir}" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DAQS_SANITIZE="${sanitizers}"
cmake --build "${dir}" -j"${jobs}"
ctest --test-dir "${dir}" --output-on-failure -j"${jobs}" "$@"

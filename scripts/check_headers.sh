#!/usr/bin/env bash
# Compiles every header of lib/ and tests/testing/ on its own (the only include of a unit,
# parsed, no code generated): each header must include what it uses. The build
# precompiles the common headers (AQS_PRECOMPILED_HEADERS), which hides a missing
# standard, Eigen, glog or GoogleTest include from it; run this after adding includes or
# headers (for the .cc files: a build with -DAQS_PRECOMPILED_HEADERS=OFF). Prints each
# header that fails with the compiler's first errors; exit 1 if any does.
# Usage: scripts/check_headers.sh [header ...]   (paths as included, e.g. util/file_list.h;
#        default: every lib/**/*.h and tests/testing/*.h)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
cxx=${CXX:-c++}
if [ $# -gt 0 ]; then
  headers=("$@")
else
  mapfile -t headers < <( (cd lib && find . -name '*.h'; cd ../tests && find ./testing -name '*.h') |
                          sed 's|^\./||' | sort)
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
check() {  # a header as included (under lib/ or tests/)
  local unit="$work/$(echo "$1" | tr '/.' '__').cc"
  printf '#include "%s"\n#include "%s"\n' "$1" "$1" > "$unit"
  if ! "$cxx" -std=c++17 -fsyntax-only -Ilib -Itests -isystem /usr/include/eigen3 \
       -isystem /usr/include/suitesparse -DGLOG_CUSTOM_PREFIX_SUPPORT "$unit" \
       > "$unit.log" 2>&1; then
    echo "FAILED: $1"
    grep -m 5 'error' "$unit.log" | sed 's/^/  /'
    return 1
  fi
}
export -f check
export work cxx
if printf '%s\n' "${headers[@]}" | xargs -P "$jobs" -I{} bash -c 'check "$@"' _ {}; then
  echo "${#headers[@]} headers compile on their own"
else
  echo "some headers do not compile on their own (above)"
  exit 1
fi

#!/usr/bin/env bash
# Installs the built ActiveQS into a temporary prefix, then configures, builds and runs
# tests/consumer/project against it with find_package(ActiveQS).
# Usage: consumer_test.sh <activeqs build dir> <consumer source dir> <work dir> [sanitizers]
# (sanitizers: the build's AQS_SANITIZE; the consumer links their runtimes).
set -euo pipefail
build_dir=$1
source_dir=$2
work=$3
sanitize=${4:-}
link_flags=()
if [ -n "$sanitize" ]; then
  link_flags=("-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=$sanitize")
fi
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build_dir" --prefix "$work/prefix" > "$work/install.log"
# The curated header set: entry points installed, internal helpers not.
include="$work/prefix/include/activeqs"
for header in equilibrium/quasistatic_solver.h diff/equilibrium_differentiator.h model/model_io.h \
    jobs/fit_sequence.h io/latent_io.h util/matrix_io.h; do
  [ -f "$include/$header" ] || { echo "missing public header $header"; exit 1; }
done
for header in util/disjoint_sets.h mesh/text_io_util.h util/atomic_file.h; do
  [ -f "$include/$header" ] && { echo "private header $header was installed"; exit 1; }
done
cmake -S "$source_dir" -B "$work/build" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$work/prefix" "${link_flags[@]}" > "$work/configure.log"
cmake --build "$work/build" -j2 > "$work/build.log"
"$work/build/consumer"

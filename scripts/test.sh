#!/usr/bin/env bash
# Installs the dependencies, builds, and runs the whole test suite (CTest).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install_deps.sh
./scripts/build.sh -DAQS_WARNINGS_AS_ERRORS=ON  # CI treats compiler warnings as errors
jobs=$(nproc 2>/dev/null || echo 2)
ctest --test-dir build --output-on-failure -j"${jobs}"

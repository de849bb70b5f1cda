#!/usr/bin/env bash
# Sets up (installs dependencies, builds) and runs meshmark's whole test suite with CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir="${MESHMARK_BUILD_DIR:-build}"
cd "$build_dir"
ctest --output-on-failure --parallel "$(nproc)" --timeout 900

#!/usr/bin/env bash
# Sets up (installs dependencies, builds) and runs meshmark's whole test suite with CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir="${MESHMARK_BUILD_DIR:-build}"
cd "$build_dir"
# MESHMARK_CTEST_EXCLUDE: a regular expression of tests to leave out (CI's sanitizer run leaves
# out the long statistical campaigns, which the plain run has already passed).
if [ -n "${MESHMARK_CTEST_EXCLUDE:-}" ]; then
  ctest --output-on-failure --parallel "$(nproc)" --timeout 900 -E "$MESHMARK_CTEST_EXCLUDE"
else
  ctest --output-on-failure --parallel "$(nproc)" --timeout 900
fi

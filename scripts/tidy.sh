#!/usr/bin/env bash
# Runs clang-tidy (the checks of .clang-tidy, every warning an error) on the C++ sources a change
# touched: those changed since MESHMARK_TIDY_BASE (a commit; by default the 20th commit before
# HEAD, or the first commit of a shorter history), in src/, apps/, python/src/ and fuzz/, and
# still present. Needs a build directory with compile_commands.json (MESHMARK_BUILD_DIR, default
# build). Exit code 0 when clang-tidy reported nothing, 1 otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${MESHMARK_BUILD_DIR:-build}"
if [ ! -f "$build_dir/compile_commands.json" ]; then
  echo "tidy: $build_dir/compile_commands.json not found: build first (scripts/setup.sh)" >&2
  exit 2
fi
base="${MESHMARK_TIDY_BASE:-}"
if [ -z "$base" ]; then
  base="$(git rev-parse --verify -q HEAD~20 || git rev-list --max-parents=0 HEAD | tail -n 1)"
fi
mapfile -t files < <(git diff --name-only --diff-filter=d "$base" HEAD -- \
  'src/*.cpp' 'apps/*.cpp' 'python/src/*.cpp' 'fuzz/*.cpp' |
  while read -r f; do
    # Only the files this build compiles (fuzz targets need a clang build of their own).
    if grep -q "\"file\": \".*/$f\"" "$build_dir/compile_commands.json"; then echo "$f"; fi
  done)
echo "tidy: ${#files[@]} changed source(s) since $(git rev-parse --short "$base")"
[ "${#files[@]}" -eq 0 ] && exit 0
printf '%s\n' "${files[@]}" |
  xargs -P "$(nproc)" -n 1 clang-tidy -p "$build_dir" --quiet 2>/dev/null |
  tee "$build_dir/tidy.log" | grep -E "(warning|error):" || true
if grep -qE "(warning|error):" "$build_dir/tidy.log"; then
  echo "tidy: clang-tidy reported the problems above" >&2
  exit 1
fi
echo "tidy: no problem"

#!/bin/bash
# The README's shell quick start (examples/shop.sh: a fresh key, 100 copies by id:auto, copy 42
# leaked through similarity:2,simplify:0.5, traced) run RUNS times on MESH, each in a fresh
# folder with a fresh key. Prints each run's outcome (buyer-42 named alone, nobody, or someone
# else: the worst bug) with the trace's message and wall time, then the counts.
# Usage: bench/quickstart_runs.sh MESH [RUNS] [BUILD_DIR]   (default: 8 runs, build)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
mesh="$(realpath "$1")"
runs="${2:-8}"
build="${3:-$here/build}"
export MESHMARK="$build/meshmark"
named=0 nobody=0 other=0
for run in $(seq "$runs"); do
  work="$(mktemp -d)"
  start=$(date +%s.%N)
  out="$(cd "$work" && bash "$here/examples/shop.sh" "$mesh" 2>&1)" || true
  seconds=$(awk "BEGIN {print $(date +%s.%N) - $start}")
  message="$(grep -m1 -E "named|no buyer" <<<"$out" || echo "$out" | tail -n 1)"
  if grep -q "one buyer named: 'buyer-42'" <<<"$out"; then
    named=$((named + 1)) outcome=named
  elif grep -qE "named: '" <<<"$out"; then
    other=$((other + 1)) outcome=OTHER
  else
    nobody=$((nobody + 1)) outcome=nobody
  fi
  printf '%s run %d: %s in %.1f s: %s\n' "$(basename "$mesh")" "$run" "$outcome" "$seconds" \
    "$message"
  rm -rf "$work"
done
echo "$(basename "$mesh"): buyer-42 named alone in $named of $runs, nobody in $nobody," \
  "someone else in $other"

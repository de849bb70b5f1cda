#!/bin/bash
# Peak memory of `meshmark embed` (maximum resident set size, GNU time) on about a million
# vertices: libcgal-demo's refined_elephant (44k vertices) sqrt3-subdivided three times (1.2M),
# written as binary PLY. Prints the peak, and bytes per vertex for each variant given; then the
# same, and the wall time, for a copy issued to a registry with the defaults (ID 7, a fresh key:
# both marks) and for `meshmark trace` of that copy with the original and the registry.
# Usage: bench/peak_memory.sh [BUILD_DIR] [VARIANT...]   (default: build DRS)
# SQRT3_STEPS=5 subdivides five times instead (10.8 million vertices: about 10 minutes, 14 GB,
# and 3 GB of disk under $TMPDIR).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
shift || true
variants=("$@")
[ ${#variants[@]} -gt 0 ] || variants=(DRS)
mesh="$build/cgal-data/data/meshes/refined_elephant.off"
[ -f "$mesh" ] || { echo "$mesh is missing (scripts/setup.sh installs libcgal-demo)" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "needs GNU time: apt-get install time" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
steps="${SQRT3_STEPS:-3}"
[[ "$steps" =~ ^[1-6]$ ]] || { echo "SQRT3_STEPS must be 1 to 6, not '$steps'" >&2; exit 2; }
"$build/meshmark" attack sqrt3 "$mesh" "$work/big.ply" --strength "$steps" >/dev/null
nv=$(head -c 400 "$work/big.ply" | grep -a "^element vertex" | awk '{print $3}')
for v in "${variants[@]}"; do
  /usr/bin/time -f "%M" -o "$work/rss" "$build/meshmark" embed "$work/big.ply" "$work/out.ply" \
    --variant "$v" --payload 0123456789abcdef >/dev/null
  kb=$(cat "$work/rss")
  echo "$v: $nv vertices, peak RSS $((kb / 1024)) MiB, $((kb * 1024 / nv)) bytes per vertex"
done
"$build/meshmark" keygen "$work/k.key" >/dev/null
/usr/bin/time -f "%M %e" -o "$work/rss" "$build/meshmark" embed "$work/big.ply" "$work/copy.ply" \
  --id 7 --buyer b7 --registry "$work/r.db" --key-file "$work/k.key" >/dev/null
read -r kb wall <"$work/rss"
echo "embed --registry (both marks): peak RSS $((kb / 1024)) MiB, $((kb * 1024 / nv)) bytes per" \
  "vertex, $wall s"
/usr/bin/time -f "%M %e" -o "$work/rss" "$build/meshmark" trace "$work/copy.ply" \
  --original "$work/big.ply" --registry "$work/r.db" --key-file "$work/k.key" >"$work/trace.txt"
read -r kb wall <"$work/rss"
echo "trace: peak RSS $((kb / 1024)) MiB, $((kb * 1024 / nv)) bytes per vertex, $wall s:" \
  "$(head -1 "$work/trace.txt")"

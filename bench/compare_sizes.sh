#!/bin/bash
# Time and peak memory of `meshmark compare` (vertex RMS, MSDM, MRMS, Hausdorff, MSDM2) of a
# marked copy against its original, at three densities of one shape: libcgal-demo's
# refined_elephant (44k vertices) and its sqrt3 subdivisions once (133k) and twice (400k).
# MSDM and MSDM2 walk windows of a fixed share of the bounding box around every vertex, so
# their samples per window grow with the density too: the time grows with about the square
# of the vertex count. One run per size (minutes at 400k).
# Usage: bench/compare_sizes.sh [BUILD_DIR]
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
mesh="$build/cgal-data/data/meshes/refined_elephant.off"
[ -f "$mesh" ] || { echo "$mesh is missing (scripts/setup.sh installs libcgal-demo)" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "needs GNU time: apt-get install time" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
src="$mesh"
"$build/meshmark" attack sqrt3 "$src" "$work/m1.ply" --strength 1 >/dev/null
"$build/meshmark" attack sqrt3 "$work/m1.ply" "$work/m2.ply" --strength 1 >/dev/null
for m in "$src" "$work/m1.ply" "$work/m2.ply"; do
  "$build/meshmark" embed "$m" "$work/copy.ply" --payload 0123456789abcdef >/dev/null
  /usr/bin/time -f "%M %e" -o "$work/rss" "$build/meshmark" compare "$m" "$work/copy.ply" \
    --json >"$work/c.json"
  read -r kb wall <"$work/rss"
  nv=$(head -c 400 "$work/copy.ply" | grep -a "^element vertex" | awk '{print $3}')
  echo "$(basename "$m"): $nv vertices, compare $wall s, peak RSS $((kb / 1024)) MiB," \
    "MSDM $(grep -o '"msdm": *[0-9.e-]*' "$work/c.json" | grep -o '[0-9.e-]*$')"
done

#!/bin/bash
# `meshmark trace` end to end against a large SQLite registry: the registry read included.
# libcgal-demo's refined_elephant (44,460 vertices) issued with both marks within the paper's
# limits to the buyer of ID 5000, then ROWS more copies of the same original and key added with
# one INSERT ... SELECT (IDs 100 to ROWS + 99 but 5000, no MACs). Each leak (the copy itself, and
# the copy simplified to 30 %) is traced RUNS times; prints each run's wall time and peak
# resident memory (GNU time), then the medians, and checks that the buyer of ID 5000 is named.
# With BASELINE (another meshmark binary, an older build), each run traces with it too, in the
# same loop, and the medians' ratio is printed.
# Usage: bench/trace_registry.sh [BUILD_DIR] [ROWS] [RUNS] [BASELINE]   (default: build 1000000 5)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
rows="${2:-1000000}"
runs="${3:-5}"
baseline="${4:-}"
mesh="$build/cgal-data/data/meshes/refined_elephant.off"
[ -f "$mesh" ] || { echo "$mesh is missing (scripts/setup.sh installs libcgal-demo)" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "needs GNU time: apt-get install time" >&2; exit 2; }
command -v sqlite3 >/dev/null || { echo "needs the sqlite3 shell: apt-get install sqlite3" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
m="$build/meshmark"
"$m" keygen "$work/shop.key" >/dev/null
"$m" embed "$mesh" "$work/copy.ply" --id 5000 --buyer buyer-5000 --registry "$work/big.db" \
  --key-file "$work/shop.key" --fingerprint --max-rms 0.04 --max-msdm 0.25 >/dev/null
"$m" attack simplify "$work/copy.ply" "$work/simplified.ply" --strength 0.3 >/dev/null
sqlite3 "$work/big.db" <<SQL
WITH RECURSIVE n(i) AS (SELECT 100 UNION ALL SELECT i + 1 FROM n WHERE i < $rows + 99)
INSERT INTO copies (original_hash, original_path, buyer, id, id_bits, bits, variant, strength,
  strength_spread, bin_offset, key_fingerprint, mark_format, issued_at, output_path, output_hash,
  method, original_geometry, mac, key_derivation, state, spaced_index)
SELECT c.original_hash, c.original_path, 'buyer-' || n.i, n.i, c.id_bits, c.bits, c.variant,
  c.strength, c.strength_spread, c.bin_offset, c.key_fingerprint, c.mark_format, c.issued_at,
  c.output_path || '.' || n.i, lower(hex(randomblob(32))), c.method, c.original_geometry, '',
  c.key_derivation, c.state, 0
FROM copies c, n WHERE n.i != 5000;
SQL
echo "registry: $(sqlite3 "$work/big.db" 'SELECT count(*) FROM copies') rows," \
  "$(($(stat -c %s "$work/big.db") / 1048576)) MiB"
median() { sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }
binaries=("$m")
[ -n "$baseline" ] && binaries=("$baseline" "$m")
for leak in copy simplified; do
  for b in "${!binaries[@]}"; do : >"$work/times.$b"; done
  for _ in $(seq "$runs"); do
    for b in "${!binaries[@]}"; do
      /usr/bin/time -f "%e %M" -o "$work/rss" "${binaries[$b]}" trace "$work/$leak.ply" \
        --original "$mesh" --registry "$work/big.db" --key-file "$work/shop.key" --json \
        >"$work/out.json" || true
      grep -q '"buyer": "buyer-5000"' "$work/out.json" ||
        { echo "$leak: the buyer of ID 5000 was not named" >&2; cat "$work/out.json" >&2; exit 1; }
      read -r wall kb <"$work/rss"
      echo "$leak (${binaries[$b]}): $wall s, $((kb / 1024)) MiB"
      echo "$wall $kb" >>"$work/times.$b"
    done
  done
  for b in "${!binaries[@]}"; do
    echo "$leak (${binaries[$b]}): median $(cut -d' ' -f1 "$work/times.$b" | median) s," \
      "$(($(cut -d' ' -f2 "$work/times.$b" | median) / 1024)) MiB (median peak)"
  done
  if [ -n "$baseline" ]; then
    echo "$leak: ratio $(awk -v a="$(cut -d' ' -f1 "$work/times.1" | median)" \
      -v b="$(cut -d' ' -f1 "$work/times.0" | median)" 'BEGIN {printf "%.2f", a / b}')" \
      "(this build's median over the baseline's)"
  fi
done

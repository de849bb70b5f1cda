#!/usr/bin/env bash
# The shop's job: a key, 100 copies of ORIGINAL for 100 buyers, a leak traced with its report.
# Usage: examples/shop.sh ORIGINAL   (in an empty folder; meshmark on PATH, or MESHMARK=...)
set -euo pipefail
original="$1" mm="${MESHMARK:-meshmark}"
"$mm" keygen shop.key  # 32 random bytes, mode 0600: keep it secret
for n in $(seq 1 100); do echo "$original copy-$n.ply id:auto buyer-$n"; done > manifest.txt
"$mm" embed --batch manifest.txt --key-file shop.key --registry shop.db | tail -n 1
"$mm" attack similarity:2,simplify:0.5 copy-42.ply leak.ply --seed 7  # the leak
"$mm" trace leak.ply --original "$original" --registry shop.db --key-file shop.key \
  --report report.html
echo "evidence report: report.html"

#!/usr/bin/env bash
# The shop's job, end to end, on a real mesh (bunny00 from Debian's libcgal-demo data): make a
# secret key, issue 20 copies to 20 buyers into an SQLite registry, leak one copy through what a
# leak goes through (gltfpack's conversion to GLB and simplification to 50 %; meshmark's own
# attack chain where gltfpack is absent), trace it back to its buyer with an evidence report,
# and read an unprocessed copy blind. Sets up (scripts/setup.sh) first. Prints where the report
# is; DEMO_OUT=DIR keeps everything in DIR (default: a fresh temporary directory, kept).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
mm="$PWD/build/meshmark"
export MESHMARK_DATA_DIR="$PWD/data" MESHMARK_CGAL_DATA="$PWD/build/cgal-data/data/meshes"
original="$MESHMARK_CGAL_DATA/bunny00.off"
[ -f "$original" ] || { echo "demo: $original is missing (scripts/setup.sh installs libcgal-demo)" >&2; exit 1; }
work="${DEMO_OUT:-$(mktemp -d /tmp/meshmark-demo.XXXXXX)}"
mkdir -p "$work"
cd "$work"
rm -f shop.key registry.db manifest.txt copy-*.obj leak.* report.html

echo "== 1. a secret key for the shop (32 random bytes, readable by its owner only)"
"$mm" keygen shop.key
ls -l shop.key

echo "== 2. 20 copies of $(basename "$original") issued to 20 buyers, recorded in registry.db"
for i in $(seq 1 20); do
  echo "$original copy-$i.obj id:$((1000 + i)) buyer-$i"
done > manifest.txt
time "$mm" embed --batch manifest.txt --key-file shop.key --registry registry.db | tail -n 3
"$mm" registry list registry.db | head -n 4

leaker=13
echo "== 3. buyer-$leaker's copy leaks: converted to GLB and simplified to 50 %"
if command -v gltfpack >/dev/null; then
  gltfpack -i "copy-$leaker.obj" -o leak.glb -si 0.5 >/dev/null
  leak=leak.glb
  echo "gltfpack -i copy-$leaker.obj -o leak.glb -si 0.5"
else
  "$mm" attack similarity,simplify:0.5 "copy-$leaker.obj" leak.ply --strength 2 --seed 7 >/dev/null
  leak=leak.ply
  echo "(gltfpack is not installed: meshmark attack similarity,simplify:0.5 instead)"
fi

echo "== 4. trace the leak with the original and the registry"
"$mm" trace "$leak" --original "$original" --registry registry.db --key-file shop.key \
  --report report.html | head -n 12

echo "== 5. the blind read of an unprocessed copy (no original, no registry)"
"$mm" extract copy-7.obj --coded --key-file shop.key | head -n 2

echo
echo "evidence report: $work/report.html"

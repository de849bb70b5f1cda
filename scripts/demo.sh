#!/usr/bin/env bash
# Sets up meshmark and runs its main job on a real mesh: embed a random 64-bit payload into
# fandisk (from Debian's libcgal-demo data), rotate, scale, translate and reorder the result,
# then extract the payload blind and report the bit error rate and the distortion; then trace a
# keyed buyer ID through noise, and run the quick benchmark campaign.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
mm=build/meshmark
mesh=build/cgal-data/data/meshes/fandisk.off
[ -f "$mesh" ] || { echo "demo: $mesh is missing (is libcgal-demo installed?)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

payload=$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')
seed=$((0x$(od -An -N4 -tx1 /dev/urandom | tr -d ' \n')))
echo "== embedding payload $payload into $mesh"
$mm embed "$mesh" "$work/marked.off" --payload "$payload"
echo
echo "== attacking: random rotation, uniform scale and translation, then vertex and face reordering (seed $seed)"
$mm attack similarity "$work/marked.off" "$work/moved.off" --strength 3 --seed "$seed"
$mm attack reorder "$work/moved.off" "$work/attacked.off" --seed "$seed"
echo
echo "== extracting blind from the attacked mesh"
$mm extract "$work/attacked.off" --expect "$payload" | grep -E "^(payload|expected|bit error rate|smallest margin)"
echo
echo "== a buyer ID under a secret key: embed, then trace it (decoding and detection)"
head -c 32 /dev/urandom > "$work/studio.key"
id=$(( $(od -An -N4 -tu4 /dev/urandom | tr -d ' ') ))
$mm embed "$mesh" "$work/buyer.off" --id "$id" --key-file "$work/studio.key" | sed -n 1,2p
$mm attack noise "$work/buyer.off" "$work/leaked.off" --strength 0.0002 --seed "$seed" >/dev/null
$mm extract "$work/leaked.off" --coded --key-file "$work/studio.key" | sed -n 1p
$mm detect "$work/leaked.off" --expect "$id" --key-file "$work/studio.key"
echo
echo "== the quick benchmark campaign (3 models, DRS/SRS/VRS, calibrated, 7 attacks)"
$mm bench bench/campaigns/quick.json --out "$work/quick" --fresh | sed -n 1,4p
echo "(report: $work/quick/report.md; kept in bench-results/quick when run without --out)"

#!/bin/bash
# Small originals (libcgal-demo's hand, head, elk, blobby, knot and mushroom: 1,197 to 2,337
# vertices): 20 copies of each issued with the defaults (IDs 1 to 20, both marks where they fit),
# the copy of ID 10 leaked through `meshmark attack` (simplify 0.5 and 0.3, noise 0.001,
# smooth 10) and traced with the original and the registry. One line per trial: right (ID 10
# alone named), none, or WRONG; the best candidate's corrected p and fingerprint z.
# Usage: bench/small_originals.sh [BUILD_DIR]   (default: build)
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$here/build}" && pwd)"
m="$build/meshmark"
d="$build/cgal-data/data/meshes"
[ -f "$d/hand.off" ] || { echo "$d/hand.off is missing (scripts/setup.sh installs libcgal-demo)" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cd "$work"
"$m" keygen k.key >/dev/null
for name in hand head elk blobby knot mushroom; do
  for id in $(seq 1 20); do
    "$m" embed "$d/$name.off" "$name-$id.ply" --id "$id" --buyer "b$id" --registry "$name.db" \
      --key-file k.key >embed.log 2>&1 ||
      { echo "$name: not issued (ID $id): $(grep -v '^ *$' embed.log | tail -1)"; continue 2; }
  done
  for attack in "simplify 0.5" "simplify 0.3" "noise 0.001" "smooth 10"; do
    set -- $attack
    "$m" attack "$1" "$name-10.ply" leak.ply --strength "$2" >/dev/null 2>&1 ||
      { echo "$name $attack: the attack failed"; continue; }
    "$m" trace leak.ply --original "$d/$name.off" --registry "$name.db" --key-file k.key \
      --json >t.json 2>/dev/null
    python3 - "$name" "$attack" <<'PY'
import json, sys
d = json.load(open("t.json"))
named = [n["id"] for n in d.get("named", [])]
best = (d.get("best") or [{}])[0]
verdict = "right" if named == [10] else ("none" if not named else "WRONG")
print(f"{sys.argv[1]:9s} {sys.argv[2]:13s} {verdict:5s} named={named} best ID {best.get('id')} "
      f"p={best.get('corrected_p', 1):.3g} fingerprint z={best.get('fingerprint', {}).get('z')}")
PY
  done
done

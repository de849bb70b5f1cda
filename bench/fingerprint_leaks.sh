#!/usr/bin/env bash
# The fingerprint against the leaks that defeat the histogram mark (docs/forensics.md, "The
# fingerprint"): 20 copies of MESH with consecutive IDs 1001..1020 issued twice under one key,
# with and without --fingerprint, then the same leaks traced against each registry.
# Usage: bench/fingerprint_leaks.sh MESH [OUTDIR]   (meshmark on PATH, or MESHMARK=...;
# python3 (PYTHON=...) with numpy and the meshmark module on PYTHONPATH for the averages)
set -euo pipefail
mesh="$(realpath "$1")" out="${2:-$(mktemp -d)}" mm="${MESHMARK:-meshmark}"
mkdir -p "$out" && cd "$out"
[ -f shop.key ] || "$mm" keygen shop.key >/dev/null
for mode in plain fingerprint; do
  mkdir -p "$mode"
  for n in $(seq 1001 1020); do echo "$mesh $mode/c$n.ply id:$n b$n"; done > "$mode.txt"
  flag=(); [ "$mode" = fingerprint ] && flag=(--fingerprint)
  "$mm" embed --batch "$mode.txt" --key-file shop.key --registry "$mode.db" "${flag[@]}" >/dev/null
done
# The leaks, made from the fingerprinted copies (the same IDs in both registries).
"${PYTHON:-python3}" - <<'PY'
import meshmark
def average(ids, name):
    ms = [meshmark.read_mesh(f"fingerprint/c{i}.ply") for i in ids]
    meshmark.write_mesh(name, (sum(m.V for m in ms) / len(ms), ms[0].F))
average([1003, 1004, 1005], "avg3.ply")
average([1003, 1004, 1005, 1006, 1008], "avg5.ply")
PY
cp fingerprint/c1007.ply copy.ply
"$mm" attack simplify:0.3 fingerprint/c1007.ply s30.ply >/dev/null
"$mm" attack remesh:1 fingerprint/c1007.ply rm.ply >/dev/null
"$mm" attack smooth fingerprint/c1007.ply lap10.ply --strength 10 >/dev/null
"$mm" attack simplify:0.3,smooth:5 fingerprint/c1007.ply s30l5.ply >/dev/null
"$mm" attack smooth:10,simplify:0.3 fingerprint/c1007.ply l10s30.ply >/dev/null
"$mm" attack remesh:1,smooth:10 fingerprint/c1007.ply rml10.ply >/dev/null
for leak in copy avg3 avg5 s30 rm lap10 s30l5 l10s30 rml10; do
  for mode in plain fingerprint; do
    "$mm" trace "$leak.ply" --original "$mesh" --registry "$mode.db" --key-file shop.key \
      --json > "$leak.$mode.json" || true
  done
  "${PYTHON:-python3}" - "$leak" <<'PY'
import json, sys
leak = sys.argv[1]
row = [leak]
for mode in ("plain", "fingerprint"):
    j = json.load(open(f"{leak}.{mode}.json"))
    named = [n["id"] for n in j.get("named", [])]
    best = (j.get("best") or [{}])[0]
    fz = best.get("fingerprint", {}).get("z")
    row.append(f"{mode}: named {named or 'nobody'}, best {best.get('id')} corrected p "
               f"{best.get('corrected_p', 1):.2g}" + (f", z {fz:.2f}" if fz is not None else ""))
print(" | ".join(row))
PY
done

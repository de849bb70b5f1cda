#!/usr/bin/env bash
# `embed --fidelity paper` against a plain `embed`, for two builds, in one interleaved loop:
#   bash bench/fidelity_ratio.sh BASE_BINARY NEW_BINARY [RUNS] [MESH...]
# Each run embeds payload 0123456789abcdef with DRS: plain with NEW, then --fidelity paper with
# BASE and with NEW, each with an empty calibration cache. Prints, per mesh, the median wall
# seconds of the three and the ratios; checks that both builds wrote the same bytes.
set -euo pipefail
base=$1 new=$2 runs=${3:-5}
shift $(($# < 3 ? $# : 3))
meshes=("$@")
if [ ${#meshes[@]} -eq 0 ]; then
  data=${MESHMARK_CGAL_DATA:?set MESHMARK_CGAL_DATA or name the meshes}
  meshes=("$data/refined_elephant.off" "$data/man.off" "$data/bunny00.off" \
          "$data/armadillo.off" "$data/camel.off")
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
seconds() { # BINARY MESH OUT [ARGS...]: wall seconds of one embed, its cache empty
  local bin=$1 mesh=$2 out=$3
  shift 3
  rm -rf "$work/cache"
  local t0 t1
  t0=$(date +%s.%N)
  XDG_CACHE_HOME="$work/cache" "$bin" embed "$mesh" "$out" --payload 0123456789abcdef \
    --variant DRS "$@" >/dev/null
  t1=$(date +%s.%N)
  echo "$t1 - $t0" | bc -l
}
median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
printf '| mesh | plain embed | --fidelity paper, base | new | new / plain | same bytes |\n'
printf '| --- | ---: | ---: | ---: | ---: | --- |\n'
for mesh in "${meshes[@]}"; do
  : >"$work/plain" && : >"$work/base" && : >"$work/new"
  for ((r = 0; r < runs; ++r)); do
    seconds "$new" "$mesh" "$work/p.ply" >>"$work/plain"
    seconds "$base" "$mesh" "$work/b.ply" --fidelity paper >>"$work/base"
    seconds "$new" "$mesh" "$work/n.ply" --fidelity paper >>"$work/new"
  done
  p=$(median <"$work/plain") b=$(median <"$work/base") n=$(median <"$work/new")
  same=no
  cmp -s "$work/b.ply" "$work/n.ply" && same=yes
  printf '| %s | %.3f s | %.3f s | %.3f s | %.1f | %s |\n' "$(basename "$mesh")" "$p" "$b" "$n" \
    "$(echo "$n / $p" | bc -l)" "$same"
done

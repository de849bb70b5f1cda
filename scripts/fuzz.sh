#!/usr/bin/env bash
# Builds the fuzzers (the mesh readers; hexadecimal payloads and the ID decoder; key files, batch
# manifests, registries and glTF with external buffers; campaign files: CMake targets fuzz_read,
# fuzz_decode, fuzz_inputs and fuzz_campaign, libFuzzer with AddressSanitizer and UndefinedBehaviorSanitizer,
# clang from Debian) and runs each for a bounded time, seeded with real meshes.
# Usage: scripts/fuzz.sh [SECONDS_PER_FORMAT] (default 20). Crashes land in fuzz/crashes/;
# keep each as a regression in fuzz/regressions/ (tests read every file there).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-20}"
command -v clang++ >/dev/null || { echo "fuzz: clang++ is missing (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }
out=build-fuzz
mkdir -p "$out" fuzz/crashes
# Debian's lib3mf 1.8 leaks libzip objects on every 3MF read (third-party; see the file).
export LSAN_OPTIONS="suppressions=$PWD/.ci/lsan-suppressions.txt${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
# The fuzzers are CMake targets (MESHMARK_BUILD_FUZZERS) linking the library's own I/O and
# payload objects, instrumented; nothing else is built.
CXX=clang++ cmake -S . -B "$out" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" \
  -DMESHMARK_BUILD_FUZZERS=ON -DMESHMARK_BUILD_TESTS=OFF -DMESHMARK_BUILD_BENCH=OFF \
  -DMESHMARK_BUILD_PYTHON=OFF >"$out/configure.log" || { cat "$out/configure.log" >&2; exit 1; }
cmake --build "$out" --target fuzz_read fuzz_decode fuzz_inputs fuzz_campaign --parallel "$(nproc)"
# Seeds: real meshes, each prefixed with the byte that selects its format.
seeds="$out/seeds"
rm -rf "$seeds" && mkdir -p "$seeds"
add_seed() { # FILE FORMAT_BYTE
  [ -f "$1" ] || { echo "fuzz: seed $1 is missing (data/meshes, or scripts/setup.sh's Debian data)" >&2; exit 1; }
  [ "$(stat -c %s "$1")" -le 400000 ] || return 0
  { printf "\\x$(printf %02x "$2")"; cat "$1"; } > "$seeds/$(basename "$1").$2"
}
for f in data/meshes/spot.obj data/meshes/spider.obj /usr/share/assimp/models/OBJ/WusonOBJ.obj; do add_seed "$f" 1; done
add_seed data/meshes/featuretype.STL 3
for f in build/cgal-data/data/meshes/cube.off build/cgal-data/data/meshes/tetrahedron.off build/cgal-data/data/meshes/elephant.off; do add_seed "$f" 0; done
for f in build/cgal-data/data/meshes/colored_tetra.ply build/cgal-data/data/meshes/sphere.ply \
         /usr/share/assimp/models/PLY/cube_binary.ply; do add_seed "$f" 2; done
add_seed build/cgal-data/data/meshes/sphere.stl 3
# glTF and GLB seeds: gltfpack's outputs (quantized, float, meshopt) and Debian's sample files.
if command -v gltfpack >/dev/null; then
  for flags in "" "-noq" "-cc"; do
    gltfpack -i data/meshes/spot.obj -o "$out/seed$flags.glb" $flags >/dev/null 2>&1 && add_seed "$out/seed$flags.glb" 5
  done
fi
for f in /usr/share/assimp/models/glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf \
         /usr/share/assimp/models/glTF2/glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf; do add_seed "$f" 4; done
add_seed /usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb 5
for f in fuzz/regressions/*; do [ -f "$f" ] && cp "$f" "$seeds/"; done
# Runs one fuzzer (NAME, then its command) into NAME.log; prints its final statistics, or, when
# it crashed, the sanitizer's report and where the input was kept, then fails.
run_fuzzer() {
  local name="$1"; shift
  if "$@" >"$out/$name.log" 2>&1; then
    echo "fuzz: $name"; grep -E "^(Done|stat::)" "$out/$name.log"
  else
    echo "fuzz: $name crashed; its report (whole log: $out/$name.log):" >&2
    grep -v "Uses:" "$out/$name.log" | grep -E -A12 "ERROR|runtime error|deadly signal|Test unit|==[0-9]+==" | head -80 >&2
    exit 1
  fi
}
corpus="$out/corpus"
mkdir -p "$corpus"
run_fuzzer fuzz_read "$out/fuzz_read" -max_total_time="$seconds" -max_len=400000 -timeout=10 -rss_limit_mb=4096 \
  -artifact_prefix=fuzz/crashes/ -print_final_stats=1 "$corpus" "$seeds"
mkdir -p "$out/corpus-decode"
run_fuzzer fuzz_decode "$out/fuzz_decode" -max_total_time="$seconds" -max_len=1024 -timeout=10 -rss_limit_mb=2048 \
  -artifact_prefix=fuzz/crashes/ -print_final_stats=1 "$out/corpus-decode"
# What users feed besides meshes, each seed prefixed with the byte that selects its kind: a key
# file, manifests (text and CSV), a real registry, and a .gltf with its external buffer.
inputs="$out/seeds-inputs"
rm -rf "$inputs" && mkdir -p "$inputs"
{ printf '\x00'; cat tests/format/example.key; } > "$inputs/key"
printf '\x01data/meshes/spot.obj out/a.ply 7 ann\n# a comment\nspot.obj b.ply auto "Bo B"\n' > "$inputs/manifest.txt"
printf '\x02input,output,id,buyer\nspot.obj,a.ply,7,"Ann, ""A"""\nspot.obj,b.ply,auto,Bo\n' > "$inputs/manifest.csv"
if [ -x build/meshmark ]; then
  rm -f "$out/seed.db" && build/meshmark embed data/meshes/spot.obj "$out/seed-copy.ply" --id 7 \
    --key fuzz --registry "$out/seed.db" --buyer ann >/dev/null 2>&1 || true
  [ -f "$out/seed.db" ] && { printf '\x03'; cat "$out/seed.db"; } > "$inputs/registry"
fi
if command -v gltfpack >/dev/null && gltfpack -i data/meshes/spot.obj -o "$out/buffer.gltf" -noq >/dev/null 2>&1; then
  { printf '\x04'; cat "$out/buffer.gltf"; printf '\x00'; cat "$out/buffer.bin"; } > "$inputs/gltf"
fi
mkdir -p "$out/corpus-inputs"
run_fuzzer fuzz_inputs "$out/fuzz_inputs" -max_total_time="$seconds" -max_len=200000 -timeout=10 -rss_limit_mb=2048 \
  -artifact_prefix=fuzz/crashes/ -print_final_stats=1 "$out/corpus-inputs" "$inputs"
# Campaign files: the project's own, their models found under data/ and in libcgal-demo's meshes
# (unpacked into the fuzz build's tree by CMake).
campaigns="$out/seeds-campaign"
rm -rf "$campaigns" && mkdir -p "$campaigns" "$out/corpus-campaign"
cp bench/campaigns/*.json "$campaigns/"
MESHMARK_DATA_DIR="$PWD/data" MESHMARK_CGAL_DATA="$PWD/$out/cgal-data/data/meshes" \
  run_fuzzer fuzz_campaign "$out/fuzz_campaign" -max_total_time="$seconds" -max_len=20000 -timeout=10 -rss_limit_mb=2048 \
  -artifact_prefix=fuzz/crashes/ -print_final_stats=1 "$out/corpus-campaign" "$campaigns"
echo "fuzz: no crash in ${seconds} s per target"

#!/usr/bin/env bash
# Installs meshmark's build and test dependencies from Debian 12 packages (as root), then
# configures and builds the project in build/. Safe to run again: it installs only what is
# missing and rebuilds only what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  g++ cmake ninja-build pkg-config ccache          # toolchain
  libeigen3-dev libfmt-dev libcli11-dev nlohmann-json3-dev   # library and CLI
  libgtest-dev libgmock-dev libbenchmark-dev       # tests and benchmarks
  coinor-libipopt-dev                              # independent QP solver for the optimality tests
  libsodium-dev                                    # BLAKE2b and ChaCha20 for secret keys
  libcpp-httplib-dev                               # meshmark serve (HTTP/JSON)
  libsqlite3-dev libpq-dev                         # the registry of issued copies
  postgresql                                       # a real server for the registry's tests
  libopenmpi-dev openmpi-bin                       # distributed benchmark campaigns (mpirun)
  librsvg2-bin                                     # campaign figures: SVG to PNG
  chromium libpng-dev poppler-utils                # the trace report's rendering and PDF tests
  libtinygltf-dev libmeshoptimizer-dev libdraco-dev lib3mf-dev libzip-dev   # glTF, meshopt, Draco, 3MF
  gltfpack draco assimp-testmodels                 # third-party tools and glTF sample files for the format tests
  libcgal-dev libcgal-demo                         # CGAL, and its real meshes (data.tar.gz)
  clang libclang-rt-14-dev                         # libFuzzer and sanitizers (scripts/fuzz.sh)
  clang-tidy                                       # the checks of .clang-tidy (scripts/tidy.sh)
  python3 python3-cryptography python3-argon2     # helper scripts; ChaCha20, Argon2id: format vectors
  doxygen groff-base                               # the documentation site (meshmark_doc); the man page test
  python3-dev pybind11-dev python3-numpy python3-pytest python3-pip   # the Python module, its tests, pip install .
)
# Node.js and npm for the glTF validator: Debian's, unless a node with its own npm (such as
# NodeSource's, whose nodejs conflicts with Debian's npm package) is already installed.
command -v npm >/dev/null || packages+=(nodejs npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then echo "setup: run as root to install packages" >&2; exit 1; fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

build_type="${MESHMARK_BUILD_TYPE:-Release}"
build_dir="${MESHMARK_BUILD_DIR:-build}"
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE="$build_type" ${MESHMARK_CMAKE_ARGS:-} >/dev/null
cmake --build "$build_dir" --parallel "$(nproc)"
# The Khronos glTF validator (npm registry, version pinned by package-lock.json) for the glTF
# tests; they fail under CI=true without it and skip elsewhere.
if [ ! -d tests/gltf-validator/node_modules/gltf-validator ]; then
  (cd tests/gltf-validator && npm ci --no-audit --no-fund --loglevel=error) ||
    echo "setup: could not install gltf-validator from the npm registry" >&2
fi

#!/usr/bin/env bash
# The shared-library build, checked by hand (CI builds only the library and the CLI as a shared
# library, in the test Package.SharedLibraryBuildsInstallsAndServesTheExternalProject): configures
# meshmark with -DBUILD_SHARED_LIBS=ON in build-shared (MESHMARK_SHARED_BUILD_DIR), builds
# everything, runs the whole test suite against the shared libmeshmark_*.so, installs into a fresh prefix and
# runs the installed CLI there (--version, then embed and extract on fandisk), printing ldd's
# view of it and the sizes. Exits non-zero at the first failure.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${MESHMARK_SHARED_BUILD_DIR:-build-shared}"
jobs="$(nproc)"

echo "== configure and build in $build_dir (-DBUILD_SHARED_LIBS=ON)"
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DBUILD_SHARED_LIBS=ON \
  -DMESHMARK_BUILD_BENCH=OFF -DMESHMARK_BUILD_PYTHON=OFF >/dev/null
time cmake --build "$build_dir" --parallel "$jobs"

echo "== the whole test suite against the shared library"
(cd "$build_dir" && time ctest --output-on-failure --parallel "$jobs" --timeout 900)

prefix="$(mktemp -d)"
work="$(mktemp -d)"
trap 'rm -rf "$prefix" "$work"' EXIT
echo "== install into $prefix"
cmake --install "$build_dir" --prefix "$prefix" >/dev/null
cli="$prefix/bin/meshmark"
# Every library the CLI loads from the prefix: the core and each component, the real files.
ldd "$cli" | grep -E 'libmeshmark|not found' || true
for lib in $(find "$prefix" -name 'libmeshmark_*.so.*.*.*'); do
  loaded="$(ldd "$cli" | awk -v name="$(basename "$lib" | sed 's/\.so\..*//')" \
    '$1 ~ "^" name "\\.so" { print $3 }')"
  if [ -z "$loaded" ] || [ "$(realpath "$loaded")" != "$lib" ]; then
    echo "check-shared: the installed CLI does not load $(basename "$lib") from $prefix" >&2
    exit 1
  fi
done
"$cli" --version
mesh="$build_dir/cgal-data/data/meshes/fandisk.off"
payload=c0ffee0123456789
"$cli" embed "$mesh" "$work/marked.off" --payload "$payload" | sed -n 1,3p
"$cli" extract "$work/marked.off" --expect "$payload" > "$work/extract.txt"
grep -E "^(payload|expected|bit error rate)" "$work/extract.txt"
if ! grep -qx "bit error rate 0.000000" "$work/extract.txt"; then
  echo "check-shared: the installed CLI did not read $payload back without error" >&2
  exit 1
fi
echo "== sizes (bytes)"
stat -c '%s %n' "$lib" "$cli"

#!/usr/bin/env bash
# pip install . as a user runs it, offline: the in-tree backend builds the module (reusing the
# build tree given) and the wheel is installed into a fresh folder; the module imported from
# there has the version of CMakeLists.txt, its stubs beside it, and reads a real mesh.
# Usage: pip_install.sh PYTHON CHECKOUT BUILD_DIR
set -euo pipefail
python="$1" checkout="$2" build="$3"
target="$(mktemp -d)"
trap 'rm -rf "$target"' EXIT
MESHMARK_PIP_BUILD_DIR="$build" "$python" -m pip install --no-index --no-deps --no-cache-dir \
  --target "$target" "$checkout" >&2
want="$(sed -n 's/^project(meshmark VERSION \([0-9.]*\).*/\1/p' "$checkout/CMakeLists.txt")"
cd "$target"
[ -f meshmark.pyi ] || { echo "pip_install: no meshmark.pyi installed" >&2; exit 1; }
cmp -s meshmark.pyi meshmark-stubs/__init__.pyi ||
  { echo "pip_install: no stub-only package meshmark-stubs holding the stubs" >&2; exit 1; }
PYTHONPATH="$target" "$python" - "$want" "$checkout/data/meshes/spot.obj" <<'PY'
import sys
import meshmark
assert meshmark.__file__.startswith(sys.path[0]) or "/tmp" in meshmark.__file__, meshmark.__file__
assert meshmark.__version__ == sys.argv[1], (meshmark.__version__, sys.argv[1])
V, F = meshmark.read_mesh(sys.argv[2])
assert V.shape == (2930, 3) and F.shape == (5856, 3), (V.shape, F.shape)
print("pip_install: meshmark", meshmark.__version__, "from", meshmark.__file__)
PY

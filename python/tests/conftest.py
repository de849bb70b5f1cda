"""Shared fixtures of the meshmark Python module's tests.

CTest sets MESHMARK_CLI (the built meshmark binary) and MESHMARK_CGAL_DATA (CGAL's meshes,
unpacked into the build tree); run by hand, the defaults below point into build/. The project's
own meshes are in data/meshes. A missing mesh fails the test: data is never a reason to skip.
"""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = pathlib.Path(os.environ.get("MESHMARK_CLI", ROOT / "build" / "meshmark"))
CGAL_DATA = pathlib.Path(
    os.environ.get("MESHMARK_CGAL_DATA", ROOT / "build" / "cgal-data" / "data" / "meshes"))
DATA_MESHES = ROOT / "data" / "meshes"


def mesh_path(directory, name):
    """The path of a real mesh; fails naming it when the directory lacks it."""
    path = directory / name
    if not path.is_file():
        pytest.fail(f"{path} is missing (data/meshes, or libcgal-demo's data: scripts/setup.sh)")
    return path


@pytest.fixture
def fandisk():
    return mesh_path(CGAL_DATA, "fandisk.off")


@pytest.fixture
def elephant():
    return mesh_path(CGAL_DATA, "elephant.off")


@pytest.fixture
def refined_elephant():
    return mesh_path(CGAL_DATA, "refined_elephant.off")  # 44,460 vertices


@pytest.fixture
def spot():
    return mesh_path(DATA_MESHES, "spot.obj")


def run_cli(*args, expect=0):
    """Runs the meshmark CLI; returns its standard output, parsed when it is JSON."""
    if not CLI.is_file():
        pytest.fail(f"the meshmark CLI is not at {CLI} (set MESHMARK_CLI)")
    done = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True)
    assert done.returncode == expect, f"meshmark {' '.join(map(str, args))}: {done.stderr}"
    return json.loads(done.stdout) if "--json" in args else done.stdout


def read_off_numpy(path):
    """An OFF file read with numpy alone, independently of meshmark: vertices as float64,
    polygons fan-triangulated (v0, vi, vi+1) into int64 triangles; '#' comments skipped."""
    rows = []
    for line in pathlib.Path(path).read_text().splitlines():
        tokens = line.split("#", 1)[0].split()
        if tokens:
            rows.append(tokens)
    assert rows[0] == ["OFF"], "only plain OFF files"
    nv, nf = int(rows[1][0]), int(rows[1][1])
    V = np.array([[float(t) for t in row[:3]] for row in rows[2:2 + nv]], dtype=np.float64)
    triangles = []
    for row in rows[2 + nv:2 + nv + nf]:
        corners = [int(t) for t in row[1:1 + int(row[0])]]
        triangles += [(corners[0], corners[i], corners[i + 1]) for i in range(1, len(corners) - 1)]
    return V, np.array(triangles, dtype=np.int64).reshape(-1, 3)


def read_obj_numpy(path):
    """An OBJ file's positions and faces (v, and the vertex of each f corner, 1-based or
    negative), fan-triangulated, with plain Python and numpy."""
    V, triangles = [], []
    for line in pathlib.Path(path).read_text().splitlines():
        tokens = line.split()
        if tokens and tokens[0] == "v":
            V.append([float(t) for t in tokens[1:4]])
        elif tokens and tokens[0] == "f":
            corners = [int(t.split("/")[0]) for t in tokens[1:]]
            corners = [c - 1 if c > 0 else len(V) + c for c in corners]
            triangles += [(corners[0], corners[i], corners[i + 1])
                          for i in range(1, len(corners) - 1)]
    return np.array(V, dtype=np.float64), np.array(triangles, dtype=np.int64)

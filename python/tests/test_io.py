"""The module's reader and writer against numpy's own reading of the same files, and its
checks of arrays at entry."""

import numpy as np
import pytest

import meshmark
from conftest import CGAL_DATA, DATA_MESHES, mesh_path, read_obj_numpy, read_off_numpy


# Triangles (fandisk, cow), quads (cross_quad), comments and mixed polygons (cube_poly).
@pytest.mark.parametrize("name", ["fandisk.off", "cow.off", "cross_quad.off", "cube_poly.off"])
def test_off_reads_as_numpy_reads_it(name):
    path = mesh_path(CGAL_DATA, name)
    V, F = meshmark.read_mesh(path)
    V_np, F_np = read_off_numpy(path)
    # Both parse the same decimal text into the nearest double: exactly equal.
    assert V.dtype == np.float64 and V.flags.c_contiguous and V.shape == V_np.shape
    np.testing.assert_array_equal(V, V_np)
    assert F.dtype == np.int32 and F.shape == F_np.shape
    np.testing.assert_array_equal(F, F_np)


@pytest.mark.parametrize("name", ["spot.obj", "spider.obj"])
def test_obj_reads_as_numpy_reads_it(name):
    path = mesh_path(DATA_MESHES, name)
    mesh = meshmark.read_mesh(path)
    V_np, F_np = read_obj_numpy(path)
    np.testing.assert_array_equal(mesh.V, V_np)
    np.testing.assert_array_equal(mesh.F, F_np)
    assert mesh.format == meshmark.FileFormat.Obj and mesh.has_image


def test_write_then_read_gives_the_same_arrays(fandisk, tmp_path):
    V, F = meshmark.read_mesh(fandisk)
    V = V + np.float64(1) / 3  # values that need all 17 digits
    for ext in ["off", "obj", "ply"]:
        out = tmp_path / f"moved.{ext}"
        meshmark.write_mesh(out, meshmark.Mesh(V, F))
        V2, F2 = meshmark.read_mesh(out)
        np.testing.assert_array_equal(V2, V)
        np.testing.assert_array_equal(F2, F)
        # And numpy reads the OFF the module wrote the same way.
        if ext == "off":
            np.testing.assert_array_equal(read_off_numpy(out)[0], V)


def test_a_file_written_back_keeps_everything_but_the_positions(spot, tmp_path):
    mesh = meshmark.read_mesh(spot)
    mesh.V = mesh.V * 2
    meshmark.write_mesh(tmp_path / "spot2.obj", mesh)
    before = [l for l in spot.read_text().splitlines() if not l.startswith("v ")]
    after = [l for l in (tmp_path / "spot2.obj").read_text().splitlines() if not l.startswith("v ")]
    assert before == after  # texture coordinates and faces untouched
    np.testing.assert_array_equal(meshmark.read_mesh(tmp_path / "spot2.obj").V,
                                  2 * read_obj_numpy(spot)[0])


def test_files_that_cannot_be_read_raise_typed_errors(tmp_path):
    with pytest.raises(meshmark.IOError) as missing:
        meshmark.read_mesh(tmp_path / "none.off")
    assert isinstance(missing.value, OSError) and isinstance(missing.value, meshmark.Error)
    bad = tmp_path / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    with pytest.raises(meshmark.InvalidInputError) as malformed:
        meshmark.read_mesh(bad)
    assert isinstance(malformed.value, ValueError)
    assert malformed.value.file == str(bad) and malformed.value.line == 6
    assert "7" in malformed.value.detail


def test_arrays_are_checked_at_entry(fandisk):
    V, F = meshmark.read_mesh(fandisk)
    bad = F.copy()
    bad[17, 2] = len(V)  # one past the last vertex
    for call in [lambda f: meshmark.Mesh(V, f), lambda f: meshmark.embed(V, f, "ff"),
                 lambda f: meshmark.extract(V, f), lambda f: meshmark.compare((V, F), (V, f))]:
        with pytest.raises(meshmark.InvalidInputError, match=r"face 17, corner 2: vertex index"):
            call(bad)
    bad[17, 2] = -1
    with pytest.raises(meshmark.InvalidInputError, match="-1 is out of range"):
        meshmark.extract(V, bad)
    with pytest.raises(meshmark.InvalidInputError, match=r"shape \(12946, 2\)"):
        meshmark.extract(V, F[:, :2])
    with pytest.raises(TypeError, match="integers"):
        meshmark.extract(V, F.astype(np.float64))
    nan = V.copy()
    nan[5, 1] = np.nan
    with pytest.raises(meshmark.InvalidInputError, match="vertex 5: coordinate 1 is nan"):
        meshmark.embed(nan, F, "ff")
    # int64 and unsigned indices, and float32 or list positions, are accepted.
    assert meshmark.Mesh(V.astype(np.float32), F.astype(np.uint64)).F.dtype == np.int32
    assert meshmark.Mesh(V.tolist(), F.astype(np.int64).tolist()).V.shape == V.shape


def test_mesh_unpacks_and_reports_its_arrays(fandisk):
    mesh = meshmark.read_mesh(fandisk)
    V, F = mesh
    np.testing.assert_array_equal(V, mesh.V)
    np.testing.assert_array_equal(F, mesh.F)
    with pytest.raises(meshmark.InvalidInputError, match="rows given"):
        mesh.V = V[:-1]

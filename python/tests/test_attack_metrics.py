"""Attacks and distortion metrics through the module, against the meshmark CLI and against
invariants."""

import numpy as np
import pytest

import meshmark
from conftest import run_cli

# compare runs the same float64 code as the CLI; MSDM and the surface distances sum over
# threads, whose partition may reorder the sums: agreement to this relative tolerance.
SUM_ORDER_RTOL = 1e-12
# A mesh's distances to itself as floating point rounds them (percent, MSDM scores).
SELF_DISTANCE_ROUNDING = 1e-12


def test_the_attack_kinds_are_the_clis(fandisk):
    help_text = run_cli("attack", "--help")
    kinds = meshmark.attack_kinds()
    assert len(kinds) >= 10
    for name in kinds:
        assert f"\n  {name} " in help_text


def test_the_attack_registry_is_the_clis_and_its_parameters_are_checked(fandisk):
    help_lines = {line.split()[0]: line for line in run_cli("attack", "--help").splitlines()
                  if line.startswith("  ") and line.split() and not line.split()[0].startswith("-")}
    registry = meshmark.attack_registry()
    assert [k["name"] for k in registry] == list(meshmark.attack_kinds())
    keyword = {"lambda": dict(lambda_=0.1), "mu": dict(mu=-0.2),
               "fixed_boundary": dict(fixed_boundary=True),
               "weighting": dict(weighting="inverse-distance"),
               "convention": dict(convention="benchmark")}
    V, F = meshmark.read_mesh(fandisk)
    for kind in registry:
        line = help_lines[kind["name"]]
        assert ("[seeded]" in line) == kind["seeded"], line
        assert ("[reads " in line) == bool(kind["parameters"]), line
        for name, kwargs in keyword.items():
            if name not in kind["parameters"]:
                with pytest.raises(meshmark.InvalidArgumentError, match=f"no step of the attack reads '{name}'"):
                    meshmark.attack((V, F), kind["name"], 0.5, **kwargs)
    seeded = {k["name"] for k in registry if k["seeded"]}
    assert {"noise", "similarity", "crop", "reorder"} <= seeded
    assert not {"quant", "smooth", "simplify", "loop"} & seeded


@pytest.mark.parametrize("cli_args,args,kwargs", [
    (["noise", "--strength", "0.002", "--seed", "7"], ("noise", 0.002), dict(seed=7)),
    (["smooth", "--strength", "5", "--lambda", "0.1", "--fixed-boundary"], ("smooth", 5),
     dict(lambda_=0.1, fixed_boundary=True)),
    (["quant:10,similarity:1", "--seed", "3"], ("quant:10,similarity:1",), dict(seed=3)),
    (["simplify", "--strength", "0.5"], ("simplify", 0.5), {}),
])
def test_attack_equals_the_cli(fandisk, tmp_path, cli_args, args, kwargs):
    kind, *rest = cli_args
    run_cli("attack", kind, fandisk, tmp_path / "cli.off", *rest)
    attacked = meshmark.attack(meshmark.read_mesh(fandisk), *args, **kwargs)
    meshmark.write_mesh(tmp_path / "py.off", attacked)
    assert (tmp_path / "py.off").read_bytes() == (tmp_path / "cli.off").read_bytes()


def test_attacks_keep_or_change_what_they_should(fandisk):
    mesh = meshmark.read_mesh(fandisk)
    V, F = mesh
    # A similarity keeps every distance ratio: pairwise distances scale by one factor.
    S, F2 = meshmark.attack((V, F), "similarity", 1, seed=5)
    np.testing.assert_array_equal(F2, F)
    d0 = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1)
    d1 = np.linalg.norm(S[F[:, 0]] - S[F[:, 1]], axis=1)
    np.testing.assert_allclose(d1 / d0, np.full_like(d0, d1[0] / d0[0]), rtol=1e-9)
    # Simplification to half the faces.
    _, Fs = meshmark.attack(mesh, "simplify", 0.5)
    assert len(Fs) <= len(F) // 2
    with pytest.raises(meshmark.InvalidArgumentError):
        meshmark.attack(mesh, "melt", 1)
    with pytest.raises(meshmark.InvalidArgumentError, match="lambda"):
        meshmark.attack(mesh, "noise", 0.001, lambda_=0.2)  # noise reads no lambda


def test_compare_equals_the_cli(fandisk, tmp_path):
    marked = tmp_path / "marked.off"
    run_cli("embed", fandisk, marked, "--payload", "ff00ff00ff00ff00", "--strength", "0.1")
    cli = run_cli("compare", fandisk, marked, "--json")
    py = meshmark.compare(meshmark.read_mesh(fandisk), meshmark.read_mesh(marked))
    for key in ["rms_percent", "msdm", "mrms_percent", "hausdorff_percent", "rms_ab",
                "rms_ba", "hausdorff", "msdm2"]:
        assert py[key] == pytest.approx(cli[key], rel=SUM_ORDER_RTOL, abs=0), key
    assert py["same_connectivity"] is True and py["msdm"] > 0


def test_metrics_of_a_mesh_with_itself_are_zero_and_rms_is_numpy_s(fandisk):
    V, F = meshmark.read_mesh(fandisk)
    same = meshmark.compare((V, F), (V, F))
    assert same["rms_percent"] == 0  # differences of equal numbers
    # Closest points and curvature windows are computed, not looked up: rounding only.
    for key in ["hausdorff_percent", "mrms_percent", "msdm", "msdm2"]:
        assert 0 <= same[key] < SELF_DISTANCE_ROUNDING, key
    # Vertex RMS against numpy: every fandisk vertex is referenced.
    B = V + np.array([1e-3, 0, 0])
    diagonal = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    expected = 100 * np.sqrt(np.mean(np.sum((B - V) ** 2, axis=1))) / diagonal
    assert meshmark.vertex_rms_percent(V, B, F) == pytest.approx(expected, rel=1e-12)
    # A translation by t moves every surface point by |t|: no point is farther than |t| from
    # the other surface (closer where the surface runs along t).
    d = meshmark.surface_distance(V, F, B, F, samples=2000)
    assert 0 < d.mrms <= d.hausdorff <= 1e-3 * (1 + 1e-12)


def test_surface_metrics_refuse_a_mesh_without_triangles(fandisk):
    V, F = meshmark.read_mesh(fandisk)
    none = np.zeros((0, 3), dtype=np.int32)
    with pytest.raises(meshmark.InvalidInputError, match="FA: no triangles"):
        meshmark.surface_distance(V, none, V, F)
    with pytest.raises(meshmark.InvalidInputError, match="FB: no triangles"):
        meshmark.msdm2(V, F, V, none)
    with pytest.raises(meshmark.InvalidInputError, match="a: no triangles"):
        meshmark.compare((V, none), (V, F))


def test_collude_is_the_weighted_mean_or_a_splice_as_the_cli_makes_it(fandisk, tmp_path):
    """collude: the average of three noisy copies is their mean at every vertex (computed here),
    given weights are normalized, a splice with a seed is the CLI's file byte for byte and takes
    every vertex whole from one copy; fewer than 2 copies, other faces and bad weights raise."""
    paths = [tmp_path / f"c{s}.off" for s in (1, 2, 3)]
    for seed, path in enumerate(paths, start=1):
        run_cli("attack", "noise", fandisk, path, "--strength", "0.001", "--seed", str(seed))
    meshes = [meshmark.read_mesh(p) for p in paths]
    V = [tuple(m)[0] for m in meshes]
    F = tuple(meshes[0])[1]
    scale = np.abs(V[0]).max()
    avg_V, avg_F = meshmark.collude(meshes)
    np.testing.assert_allclose(avg_V, (V[0] + V[1] + V[2]) / 3, rtol=0, atol=1e-15 * scale)
    np.testing.assert_array_equal(avg_F, F)
    weighted_V, _ = meshmark.collude(meshes, weights=[2, 1, 1])
    np.testing.assert_allclose(weighted_V, 0.5 * V[0] + 0.25 * V[1] + 0.25 * V[2], rtol=0,
                               atol=1e-15 * scale)
    run_cli("collude", *paths, "--out", tmp_path / "cli.off", "--splice", "--seed", "4")
    spliced = meshmark.collude(meshes, splice=True, seed=4)
    meshmark.write_mesh(tmp_path / "py.off", spliced)
    assert (tmp_path / "py.off").read_bytes() == (tmp_path / "cli.off").read_bytes()
    spliced_V, _ = spliced
    from_one = np.zeros(len(V[0]), dtype=int)
    for v in V:
        from_one += np.all(spliced_V == v, axis=1)
    assert np.all(from_one >= 1)
    with pytest.raises(meshmark.InvalidArgumentError, match="at least 2 copies"):
        meshmark.collude(meshes[:1])
    with pytest.raises(meshmark.InvalidArgumentError, match="weight -1 of copy 2"):
        meshmark.collude(meshes, weights=[1, -1, 1])
    with pytest.raises(meshmark.InvalidArgumentError, match="other faces"):
        meshmark.collude([meshes[0], (V[1], F[::-1])])

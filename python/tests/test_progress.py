"""Progress from Python: the long calls report their phases to a callable, give the same results
with one as without, and stop (or, for issue, finish first) when it raises."""

import hashlib
import json

import numpy as np
import pytest

import meshmark
from conftest import run_cli

KEY = "python progress key"


class Stop(Exception):
    """What a callback raises to stop the work."""


def recorder():
    calls = []
    return calls, lambda phase, done, total, what: calls.append((phase, done, total, what))


def check_phases(calls):
    """Each phase starts at 0 and counts up to its total, never back."""
    assert calls, "progress was never called"
    last = {}
    for phase, done, total, what in calls:
        assert isinstance(phase, str) and isinstance(what, str)
        assert 0 <= done <= total, (phase, done, total)
        if phase not in last:
            assert done == 0, f"phase {phase!r} starts at {done}"
        else:
            assert done >= last[phase], f"phase {phase!r} went back"
        last[phase] = done
    return last


def raising_at(n):
    """A callback that raises Stop at its n-th call, and counts the calls it sees."""
    seen = []

    def callback(phase, done, total, what):
        seen.append(phase)
        if len(seen) == n:
            raise Stop(f"stopped at call {n}")
    return seen, callback


def test_attack_reports_its_phases_and_gives_the_same_mesh(fandisk):
    mesh = meshmark.read_mesh(fandisk)
    calls, callback = recorder()
    with_progress = meshmark.attack(mesh, "simplify", 0.5, progress=callback)
    without = meshmark.attack(mesh, "simplify", 0.5)
    np.testing.assert_array_equal(with_progress.V, without.V)
    np.testing.assert_array_equal(with_progress.F, without.F)
    last = check_phases(calls)
    # Collapsing edges counts to its total; a kind without phases of its own reports one.
    assert last["collapsing edges"] == calls[[c[0] for c in calls].index("collapsing edges")][2]
    noise_calls, noise_callback = recorder()
    meshmark.attack(mesh, "noise", 0.001, progress=noise_callback)
    assert [(c[0], c[1], c[2]) for c in noise_calls] == [("noise", 0, 1), ("noise", 1, 1)]


def test_a_raising_callback_stops_the_attack_and_is_raised(fandisk):
    mesh = meshmark.read_mesh(fandisk)
    seen, callback = raising_at(3)
    with pytest.raises(Stop, match="stopped at call 3"):
        meshmark.attack(mesh, "simplify", 0.5, progress=callback)
    assert len(seen) == 3, "called again after it raised"
    # The module works on after it.
    assert meshmark.attack(mesh, "noise", 0.001).V.shape == mesh.V.shape


def test_compare_and_msdm_report_the_windows_walked(fandisk):
    mesh = meshmark.read_mesh(fandisk)
    moved = meshmark.attack(mesh, "noise", 0.002, seed=4)
    calls, callback = recorder()
    report = meshmark.compare(mesh, moved, progress=callback)
    assert report == meshmark.compare(mesh, moved)
    last = check_phases(calls)
    n = mesh.V.shape[0]
    assert last["measuring MSDM"] == n and last["measuring MSDM (the original's windows)"] == n
    assert "measuring MSDM2" in last
    calls, callback = recorder()
    value = meshmark.msdm(mesh.V, moved.V, mesh.F, progress=callback)
    assert value.global_ == report["msdm"]
    assert check_phases(calls)["measuring MSDM"] == n
    with pytest.raises(Stop):
        meshmark.compare(mesh, moved, progress=raising_at(2)[1])


def test_calibrate_names_each_strength_it_measures(fandisk):
    mesh = meshmark.read_mesh(fandisk)
    calls, callback = recorder()
    result = meshmark.calibrate(mesh.V, mesh.F, progress=callback)
    again = meshmark.calibrate(mesh.V, mesh.F)
    assert result.strength == again.strength and result.msdm == again.msdm
    check_phases(calls)
    strengths = {c[0].split(":")[0] for c in calls if c[0].startswith("strength ")}
    # One strength named per embedding whose RMS passed (MSDM measured), at least the one found.
    assert f"strength {result.strength:.5f}" in strengths
    assert 1 <= len(strengths) <= result.evaluations
    with pytest.raises(Stop):
        meshmark.calibrate(mesh.V, mesh.F, progress=raising_at(1)[1])


def test_issue_reports_and_finishes_even_when_the_callback_raises(fandisk, tmp_path):
    copies = [{"input": fandisk, "output": tmp_path / f"copy-{i}.ply", "id": i,
               "buyer": f"buyer {i}"} for i in (40, 41, 42)]
    registry = str(tmp_path / "shop.db")
    calls, callback = recorder()
    out = meshmark.issue(copies[:1], registry=registry, key=KEY, progress=callback)
    assert out[0]["status"] == "written"
    assert [(c[0], c[1], c[2]) for c in calls] == [
        ("preparing", 0, 1), ("preparing", 1, 1), ("issuing", 0, 1), ("issuing", 1, 1)]
    # A progress that cannot be called is refused before any work.
    with pytest.raises(TypeError, match="callable"):
        meshmark.issue(copies[1:], registry=registry, key=KEY, progress=5)
    assert not copies[1]["output"].exists()
    # Raising at the first call: raised once the issue is done; every copy written and recorded.
    seen, callback = raising_at(1)
    with pytest.raises(Stop):
        meshmark.issue(copies[1:], registry=registry, key=KEY, threads=2, progress=callback)
    assert len(seen) == 1, "called again after it raised"
    rows = [json.loads(line) for line in run_cli(
        "registry", "export", tmp_path / "shop.db", "--format", "jsonl").splitlines()]
    assert sorted(r["id"] for r in rows) == [40, 41, 42]
    for r in rows:
        assert r["state"] == "issued", r
        with open(r["output_path"], "rb") as f:  # the registry's content hash: BLAKE2b-256
            written = hashlib.blake2b(f.read(), digest_size=32).hexdigest()
        assert written == r["output_hash"], r["output_path"]


def test_trace_reports_and_a_raising_callback_writes_no_report(fandisk, tmp_path):
    copies = [{"input": fandisk, "output": tmp_path / "copy.ply", "id": 7, "buyer": "b7"}]
    registry = str(tmp_path / "shop.db")
    assert meshmark.issue(copies, registry=registry, key=KEY)[0]["ok"]
    calls, callback = recorder()
    found = meshmark.trace(tmp_path / "copy.ply", fandisk, registry, key=KEY, progress=callback)
    assert found["status"] == "named" and found["named"][0]["buyer"] == "b7"
    assert check_phases(calls) == {"tracing": 2}  # registered, then one group of candidates
    report = tmp_path / "report.html"
    with pytest.raises(Stop):
        meshmark.trace(tmp_path / "copy.ply", fandisk, registry, key=KEY, report=report,
                       progress=raising_at(2)[1])
    assert not report.exists()

"""Strength calibration from Python: the CLI's answers on the same file and settings, the
limits kept (measured again with numpy and the metrics), the cache shared with the CLI."""

import numpy as np
import pytest

import meshmark
from conftest import run_cli

# Both tools run the same deterministic search; their figures may differ only by printing.
SAME = 1e-12
# The numpy vertex RMS against the library's (different summation order).
RMS_REL = 1e-9
# The search stops within its precision (1 %) of the strongest strength within the limits.
PRECISION = 0.01

FIELDS = ("status", "cause", "strength", "bin_offset", "rms_percent", "msdm", "evaluations",
          "measurements", "estimates", "key", "bin_offset_rule", "variant", "method", "bits", "diagnostics")


def assert_same_calibration(a, b):
    for field in FIELDS:
        if isinstance(a[field], float):
            assert a[field] == pytest.approx(b[field], rel=SAME), field
        else:
            assert a[field] == b[field], field


# The defaults (fandisk: the MSDM limit binds), and every setting changed (elephant).
@pytest.mark.parametrize("mesh,args,kwargs", [
    ("fandisk", (), {}),
    ("elephant",
     ("--variant", "VRS", "--bits", "32", "--max-rms", "0.03", "--max-msdm", "0.3",
      "--bin-offset", "0.02", "--bin-offset-rule", "fixed", "--iterations", "8", "--precision",
      "0.02"),
     dict(variant="VRS", bits=32, max_rms_percent=0.03, max_msdm=0.3, bin_offset=0.02,
          limits=meshmark.CalibrateOptions(bin_offset="fixed"), iterations=8, precision=0.02)),
    ("refined_elephant", ("--no-steer",),
     dict(limits=meshmark.CalibrateOptions(steer=False))),
    ("elephant", ("--variant", "SRS", "--method", "cho-mean", "--max-rms", "0.06"),
     dict(variant=meshmark.Variant("SRS"), method=meshmark.Method.ChoMean,
          max_rms_percent=0.06)),
])
def test_calibrate_file_gives_the_cli_calibration(request, mesh, args, kwargs):
    path = request.getfixturevalue(mesh)
    cli = run_cli("calibrate", path, "--no-cache", "--json", *args)
    py = meshmark.calibrate_file(path, **kwargs)
    assert cli["status"] == "calibrated", cli
    assert_same_calibration(py, cli)
    assert py["cached"] is False and py["cache"] == ""


@pytest.mark.parametrize("mesh", ["fandisk", "elephant"])
def test_calibrate_on_arrays_keeps_the_limits_and_matches_the_file(request, mesh):
    path = request.getfixturevalue(mesh)
    V, F = meshmark.read_mesh(path)
    r = meshmark.calibrate(V, F)
    file = meshmark.calibrate_file(path)
    assert r.status == file["status"] == "calibrated" and r.cause == "none"
    assert r.strength == pytest.approx(file["strength"], rel=SAME)
    assert r.msdm == pytest.approx(file["msdm"], rel=SAME)
    # The embedding's distortion, measured again: numpy's vertex RMS (% of the bounding-box
    # diagonal) and the metrics module's MSDM, both within the paper's limits.
    W = r.embedding.V
    diagonal = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    rms = 100 * np.sqrt(np.mean(np.sum((W - V) ** 2, axis=1))) / diagonal
    assert rms == pytest.approx(r.rms_percent, rel=RMS_REL)
    assert rms <= meshmark.PAPER_MAX_RMS_PERCENT
    assert meshmark.msdm(V, W, F).global_ == pytest.approx(r.msdm, rel=SAME)
    assert r.msdm <= meshmark.PAPER_MAX_MSDM
    # Calibrated: a limit is within the precision, or 1 % more strength would break one.
    assert (r.msdm >= (1 - PRECISION) * meshmark.PAPER_MAX_MSDM
            or rms >= (1 - PRECISION) * meshmark.PAPER_MAX_RMS_PERCENT
            or meshmark.calibrate(V, F, min_strength=r.strength * (1 + PRECISION),
                                  ).strength == 0)


def test_steering_estimates_only_on_large_meshes_and_stops_on_a_full_measurement(
        fandisk, refined_elephant):
    # fandisk (6,475 vertices) is below the 16,384 vertices from which the search steers:
    # the same search either way. refined_elephant (44,460) steers unless told not to.
    V, F = meshmark.read_mesh(fandisk)
    on, off = meshmark.calibrate(V, F), meshmark.calibrate(V, F, steer=False)
    assert on.estimates == off.estimates == 0
    assert (on.strength, on.msdm, on.measurements) == (off.strength, off.msdm, off.measurements)
    V, F = meshmark.read_mesh(refined_elephant)
    on, off = meshmark.calibrate(V, F), meshmark.calibrate(V, F, steer=False)
    assert on.estimates > 0 and off.estimates == 0 and on.measurements >= 1
    # What it stopped on was measured in full: the metrics module gives the same MSDM.
    assert meshmark.msdm(V, on.embedding.V, F).global_ == pytest.approx(on.msdm, rel=SAME)
    assert on.msdm <= meshmark.PAPER_MAX_MSDM


def test_a_given_payload_is_embedded_at_the_calibrated_strength(elephant):
    V, F = meshmark.read_mesh(elephant)
    bits = meshmark.random_payload(64, seed=5)
    r = meshmark.calibrate(V, F, bits, options=meshmark.EmbedOptions(variant="SRS"))
    assert r.status == "calibrated", r.message
    read = meshmark.extract(r.embedding.V, F, meshmark.ExtractOptions(center=meshmark.CenterKind.Surface))
    np.testing.assert_array_equal(read.bits, bits)
    assert read.min_margin() >= r.strength - 1e-6  # the solver's margin tolerance


def test_tighter_limits_give_a_weaker_mark_and_none_fits_an_impossible_one(elephant):
    V, F = meshmark.read_mesh(elephant)
    paper = meshmark.calibrate(V, F)
    tight = meshmark.calibrate(V, F, limits=meshmark.CalibrateOptions(max_rms_percent=0.03))
    assert tight.status == "calibrated" and tight.rms_percent <= 0.03
    assert tight.strength < paper.strength
    none = meshmark.calibrate(V, F, max_rms_percent=1e-6)
    assert (none.status, none.cause, none.strength) == ("below minimum", "rms limit", 0)
    assert none.rms_percent > 1e-6  # what the weakest mark cost, beyond the limit
    assert any("way out" in line for line in none.diagnostics)


def test_per_bit_strengths_from_a_callable(elephant):
    V, F = meshmark.read_mesh(elephant)
    asked = []

    def strengths(alpha):
        asked.append(alpha)
        return [alpha] * 32 + [2 * alpha] * 32

    r = meshmark.calibrate(V, F, strengths=strengths, max_strength=0.2)
    assert r.status == "calibrated" and r.strength in asked
    np.testing.assert_allclose(r.strengths, [r.strength] * 32 + [2 * r.strength] * 32,
                               rtol=SAME)
    read = meshmark.extract(r.embedding.V, F)
    margins = read.margins
    assert margins[:32].min() >= r.strength - 1e-6
    assert margins[32:].min() >= 2 * r.strength - 1e-6
    # Twice the strength on half the bits costs more: a weaker alpha than uniform.
    assert r.strength < meshmark.calibrate(V, F).strength
    with pytest.raises(ZeroDivisionError):
        meshmark.calibrate(V, F, strengths=lambda alpha: [1 / 0])


def test_the_cache_is_shared_with_the_cli(fandisk, tmp_path):
    cache = tmp_path / "calibration.jsonl"
    first = meshmark.calibrate_file(fandisk, cache=cache)
    assert first["cached"] is False and first["cache"] == str(cache)
    again = meshmark.calibrate_file(fandisk, cache=cache)
    assert again["cached"] is True
    assert_same_calibration(again, first)
    cli = run_cli("calibrate", fandisk, "--cache", cache, "--json")
    assert cli["cached"] is True
    assert_same_calibration(cli, first)
    assert len(cache.read_text().splitlines()) == 1  # nobody computed it twice


def test_bad_settings_raise_the_module_exceptions(fandisk, tmp_path):
    V, F = meshmark.read_mesh(fandisk)
    with pytest.raises(meshmark.InvalidArgumentError, match="calibration range"):
        meshmark.calibrate(V, F, min_strength=0.3, max_strength=0.2)
    with pytest.raises(TypeError, match="unexpected keyword 'max_rms'"):
        meshmark.calibrate(V, F, max_rms=0.04)
    with pytest.raises(meshmark.InvalidArgumentError,
                       match=r"unknown bin offset rule 'sometimes' \(one of: fixed, at-most-strength\)"):
        meshmark.CalibrateOptions(bin_offset="sometimes")
    with pytest.raises(meshmark.InvalidArgumentError, match="bits 0 is not at least 1"):
        meshmark.calibrate(V, F, bits=0)
    with pytest.raises(meshmark.InvalidArgumentError, match="bits -3 is not at least 1"):
        meshmark.calibrate_file(tmp_path / "missing.off", bits=-3)
    with pytest.raises(TypeError, match="method: expected a Method or its name"):
        meshmark.calibrate_file(tmp_path / "missing.off", method=3)
    with pytest.raises(meshmark.IOError):
        meshmark.calibrate_file(tmp_path / "missing.off")
    bad = tmp_path / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    with pytest.raises(meshmark.InvalidInputError) as e:
        meshmark.calibrate_file(bad)
    assert e.value.file == str(bad)

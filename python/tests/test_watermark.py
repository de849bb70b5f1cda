"""Embedding, extraction and detection through the module: round trips on real meshes, and
the same results as the meshmark CLI on the same files and options."""

import numpy as np
import pytest

import meshmark
from conftest import run_cli

PAYLOAD = "c0ffee00deadbeef"


def test_embed_extract_round_trip_every_bit_right(fandisk):
    V, F = meshmark.read_mesh(fandisk)
    bits = meshmark.random_payload(64, seed=11)
    result = meshmark.embed(V, F, bits, strength=0.05)
    assert result.status == meshmark.EmbedStatus.Embedded, result.message
    read = meshmark.extract(result.V, F)
    np.testing.assert_array_equal(read.bits, bits)
    # Every bin mean reached its target: 1/2 +- alpha, less the solver's margin tolerance.
    assert read.min_margin() >= 0.05 - 1e-6
    assert read.erasures == 0
    # The original reads as something else (its bin means are not at the targets).
    assert meshmark.extract(V, F).min_margin() < 0.05 - 1e-6


@pytest.mark.parametrize("method", ["ChoMean", "ChoVariance"])
def test_cho_methods_round_trip_with_their_own_statistic(fandisk, method):
    V, F = meshmark.read_mesh(fandisk)
    bits = meshmark.random_payload(64, seed=12)
    m = getattr(meshmark.Method, method)
    result = meshmark.embed(V, F, bits, strength=0.05, method=m)
    assert result.status == meshmark.EmbedStatus.Embedded, result.message
    read = meshmark.extract(result.V, F, meshmark.ExtractOptions(method=m))
    np.testing.assert_array_equal(read.bits, bits)
    assert read.min_margin() >= 0.05 - 1e-6
    if method == "ChoVariance":
        # Recomputed here with numpy: per bit bin, the mean of u^2 (u = 2t - 1) is at least
        # (1 + alpha) / 3 for a 1 and at most (1 - alpha) / 3 for a 0, to the stated 1e-6.
        c = result.V.mean(axis=0)  # fandisk: every vertex is used, no two at one position
        rho = np.linalg.norm(result.V - c, axis=1)
        s = (rho.max() - rho.min()) / 66
        x = (rho - rho.min()) / s
        b = np.minimum(np.floor(x).astype(int), 65)
        u2 = (2 * (x - b) - 1) ** 2
        for j in range(64):
            v = u2[b == j + 1].mean()
            if bits[j]:
                assert v >= (1 + 0.05) / 3 - 1e-6 / 3
            else:
                assert v <= (1 - 0.05) / 3 + 1e-6 / 3


@pytest.mark.parametrize("variant", ["VRS", "DRL", "SNS"])
def test_round_trip_through_a_file_for_other_variants(fandisk, tmp_path, variant):
    mesh = meshmark.read_mesh(fandisk)
    result = meshmark.embed(mesh.V, mesh.F, PAYLOAD, variant=variant)
    assert result.status == meshmark.EmbedStatus.Embedded, result.message
    mesh.V = result.V
    meshmark.write_mesh(tmp_path / "marked.off", mesh)
    V, F = meshmark.read_mesh(tmp_path / "marked.off")
    reading = meshmark.read_mark(V, F, variant=variant)
    assert reading.payload_hex == PAYLOAD and reading.extract.erasures == 0


def test_options_object_and_keywords_are_the_same(fandisk):
    V, F = meshmark.read_mesh(fandisk)
    options = meshmark.EmbedOptions(variant="VRQ", strength=0.08, lambda_=0.3)
    assert options.variant == meshmark.Variant("vrq") and options.lambda_ == 0.3
    a = meshmark.embed(V, F, PAYLOAD, options=options)
    b = meshmark.embed(V, F, PAYLOAD, variant="VRQ", strength=0.08, lambda_=0.3)
    np.testing.assert_array_equal(a.V, b.V)
    with pytest.raises(TypeError, match="unexpected keyword 'strenght'"):
        meshmark.embed(V, F, PAYLOAD, strenght=0.1)
    with pytest.raises(meshmark.InvalidArgumentError):
        meshmark.embed(V, F, PAYLOAD, variant="XYZ")


def test_coded_id_under_a_key(fandisk):
    V, F = meshmark.read_mesh(fandisk)
    result = meshmark.embed(V, F, id=4242, key="studio secret")
    assert result.status == meshmark.EmbedStatus.Embedded, result.message
    found = meshmark.read_id(result.V, F, key="studio secret")
    assert found.id.valid and found.id.id == 4242 and found.id.corrected == 0
    detected = meshmark.detect(result.V, F, expect=4242, key="studio secret",
                               variant=meshmark.Variant("DRS"))
    assert detected.detected and detected.matches == 64 and detected.p_value < 1e-6
    assert detected.model == meshmark.NullModel.CodewordExact


def test_a_wrong_key_does_not_detect(fandisk):
    V, F = meshmark.read_mesh(fandisk)
    marked = meshmark.embed(V, F, id=4242, key="studio secret").V
    for wrong in ["another secret", "studio secret "]:
        assert not meshmark.detect(marked, F, expect=4242, key=wrong).detected
        assert not meshmark.read_id(marked, F, key=wrong).id.valid
    # Nor does an innocent ID under the right key.
    assert not meshmark.detect(marked, F, expect=4243, key="studio secret").detected


# The same file, payload and options through the CLI and through the module give the same
# bytes: both run the same float64 computation, so the tolerance is zero.
CASES = [
    (["--payload", PAYLOAD], dict(payload=PAYLOAD)),
    (["--payload", PAYLOAD, "--variant", "VRL", "--strength", "0.07", "--lambda", "0.4"],
     dict(payload=PAYLOAD, variant="VRL", strength=0.07, lambda_=0.4)),
    (["--id", "77", "--key", "k", "--bin-offset", "0.03", "--strength-spread", "0.5"],
     dict(id=77, key="k", bin_offset=0.03, strength_spread=0.5)),
    (["--payload", PAYLOAD, "--method", "cho-variance", "--strength", "0.1"],
     dict(payload=PAYLOAD, method=meshmark.Method.ChoVariance, strength=0.1)),
]


@pytest.mark.parametrize("cli_args,kwargs", CASES)
def test_embed_equals_the_cli(fandisk, tmp_path, cli_args, kwargs):
    cli_out = tmp_path / "cli.off"
    report = run_cli("embed", fandisk, cli_out, *cli_args, "--json")
    mesh = meshmark.read_mesh(fandisk)
    result = meshmark.embed(mesh.V, mesh.F, **kwargs)
    mesh.V = result.V
    meshmark.write_mesh(tmp_path / "py.off", mesh)
    assert (tmp_path / "py.off").read_bytes() == cli_out.read_bytes()
    np.testing.assert_array_equal(meshmark.read_mesh(cli_out).V, result.V)
    assert report["rounds"] == result.rounds
    assert report["min_margin"] == result.min_margin
    assert report["rms_percent"] == result.rms_percent
    assert report["margins"] == result.margins.tolist()


def test_extract_and_detect_equal_the_cli(fandisk, tmp_path):
    marked = tmp_path / "marked.off"
    run_cli("embed", fandisk, marked, "--id", "9", "--key", "k")
    V, F = meshmark.read_mesh(marked)
    cli = run_cli("extract", marked, "--coded", "--key", "k", "--json")
    py = meshmark.read_id(V, F, key="k")
    assert cli["id"] == py.id.id == 9
    assert cli["payload"] == py.reading.payload_hex
    assert [b["margin"] for b in cli["per_bit"]] == py.reading.margins.tolist()
    for expect, found in [(9, 0), (10, 6)]:  # the CLI exits 6 when it does not detect
        cli = run_cli("detect", marked, "--expect", expect, "--key", "k", "--json", expect=found)
        py = meshmark.detect(V, F, expect=expect, key="k")
        assert (cli["detected"], cli["matches"], cli["p_value"]) == \
            (py.detected, py.matches, py.p_value)

"""Benchmark campaigns from Python: the rows of the CLI's bench for the same campaign, from a
file or a dict, resumed after a callback stopped the run, and malformed campaigns refused."""

import csv
import json
import threading

import pytest

import meshmark
from conftest import run_cli

# Both tools run the same seeded trials; only the times may differ.
SAME = 1e-12
TIMES = ("embed_seconds", "attack_seconds", "extract_seconds", "trace_seconds", "seconds")
# Trials: 2 payloads x (no attack + 2 noise strengths x 2 draws).
TRIALS = 2 * (1 + 2 * 2)


def tiny(model):
    """One mesh, one variant, one attack at two strengths: about a second."""
    return {"name": "tiny", "models": [str(model)], "variants": ["DRS"], "payloads": 2,
            "draws": 2, "seed": 3, "calibration": {"max_rms": 0.1, "max_msdm": 0.4},
            "attacks": [{"kind": "noise", "strengths": [0.0003, 0.001]}]}


def without_times(records):
    return [{k: v for k, v in r.items() if k not in TIMES} for r in records]


def read_jsonl(path):
    return [json.loads(line) for line in open(path) if line.strip()]


def assert_same_records(a, b):
    assert len(a) == len(b)
    for x, y in zip(without_times(a), without_times(b)):
        assert x.keys() == y.keys()
        for k in x:
            if isinstance(x[k], float):
                assert x[k] == pytest.approx(y[k], rel=SAME, abs=SAME), (x.get("key"), k)
            else:
                assert x[k] == y[k], k


def test_rows_are_the_cli_bench_rows(fandisk, tmp_path):
    config = tmp_path / "tiny.json"
    config.write_text(json.dumps(tiny(fandisk)))
    run_cli("bench", config, "--out", tmp_path / "cli", "--jobs", "2")
    calls, spins, stop = [], [0], threading.Event()

    def spin():  # Python work that can only advance while the campaign releases the GIL
        while not stop.is_set():
            spins[0] += 1

    spinner = threading.Thread(target=spin)
    spinner.start()
    try:
        r = meshmark.run_campaign(config, tmp_path / "py", jobs=2,
                                  progress=lambda *args: calls.append(args + (spins[0],)))
    finally:
        stop.set()
        spinner.join()
    assert r["status"] == "complete" and r["jobs"] == 2
    assert (r["calibrations_run"], r["trials_run"], r["trials_resumed"]) == (1, TRIALS, 0)
    assert r["diagnostics"] == [] and r["dropped_lines"] == 0
    assert_same_records(r["rows"], read_jsonl(tmp_path / "cli" / "rows.jsonl"))
    assert_same_records(r["calibrations"], read_jsonl(tmp_path / "cli" / "calibration.jsonl"))
    # The files hold what the result holds.
    assert r["rows_jsonl"] == str(tmp_path / "py" / "rows.jsonl")
    assert read_jsonl(r["rows_jsonl"]) == r["rows"]
    with open(r["rows_csv"]) as f:
        table = list(csv.DictReader(f))
    assert [(t["payload"], t["attack"], t["draw"], float(t["ber"])) for t in table] == \
        [(str(row["payload"]), row["attack"], str(row["draw"]), row["ber"]) for row in r["rows"]]
    # Every trial measured a mark within the limits, and no attack means no bit error.
    limits = tiny(fandisk)["calibration"]
    for row in r["rows"]:
        assert row["status"] == "ok", row
        assert row["rms_percent"] <= limits["max_rms"] and row["msdm"] <= limits["max_msdm"]
        if row["attack"] == "none":
            assert row["ber"] == 0 and row["erasures"] == 0
    # Progress: each phase starts at 0 and ends at its total.
    assert calls[0][:4] == ("calibrating", 0, 1, "") and calls[1][:3] == ("calibrating", 1, 1)
    trials = [c for c in calls if c[0] == "trials"]
    assert trials[0][:3] == ("trials", 0, TRIALS) and trials[-1][1:3] == (TRIALS, TRIALS)
    assert [c[1] for c in trials] == sorted(c[1] for c in trials)
    # The Python thread ran while the trials ran (about a million loops here; none if the GIL
    # were held from the first trials report to the last).
    assert trials[-1][4] - trials[0][4] > 1000


def test_a_dict_runs_the_same_campaign_and_a_stopped_run_resumes(fandisk, tmp_path,
                                                                  monkeypatch):
    file = tmp_path / "tiny.json"
    file.write_text(json.dumps(tiny(fandisk)))
    reference = meshmark.run_campaign(file, tmp_path / "file", jobs=1)["rows"]
    # A dict with a model path relative to the current directory.
    monkeypatch.chdir(fandisk.parent)
    config = tiny(fandisk.name)

    def stop_after_one_unit(phase, done, total, what):
        if phase == "trials" and done > 0:
            raise KeyboardInterrupt("stopped by the test")

    with pytest.raises(KeyboardInterrupt, match="stopped by the test"):
        meshmark.run_campaign(config, tmp_path / "dict", jobs=1, progress=stop_after_one_unit)
    # The same campaign with its keys in another order resumes.
    reordered = dict(reversed(list(config.items())))
    assert list(reordered) != list(config)
    resumed = meshmark.run_campaign(reordered, tmp_path / "dict", jobs=1)
    assert resumed["calibrations_resumed"] == 1 and resumed["calibrations_run"] == 0
    assert resumed["trials_resumed"] == TRIALS // 2 and resumed["trials_run"] == TRIALS // 2
    assert_same_records(resumed["rows"], reference)
    stamp = json.loads((tmp_path / "dict" / "campaign.json").read_text())
    assert stamp["models"] == [str(fandisk)]
    # Another campaign in the same directory is refused, unless fresh.
    config["seed"] = 4
    with pytest.raises(meshmark.InvalidArgumentError, match="another campaign"):
        meshmark.run_campaign(config, tmp_path / "dict")
    again = meshmark.run_campaign(config, tmp_path / "dict", fresh=True)
    assert again["trials_resumed"] == 0 and again["trials_run"] == TRIALS


@pytest.mark.parametrize("change,message", [
    (lambda c: c.update(atacks=[]), 'unknown key "atacks"'),
    (lambda c: c["attacks"][0].update(kind="nosie"), r"unknown attack 'nosie' \(the kinds: "),
    (lambda c: c.update(models=["no-such-mesh.off"]), "no-such-mesh.off does not exist"),
    (lambda c: c.update(payloads=0), "payloads must be at least 1"),
    (lambda c: c.update(variants=["DRX"]), 'variant "DRX"'),
])
def test_malformed_campaigns_raise_naming_the_problem(fandisk, tmp_path, change, message):
    config = tiny(fandisk)
    change(config)
    with pytest.raises(meshmark.InvalidInputError, match=message) as e:
        meshmark.run_campaign(config, tmp_path / "dict")
    assert e.value.file == "config"
    assert not (tmp_path / "dict").exists()  # nothing written
    file = tmp_path / "bad.json"
    file.write_text(json.dumps(config))
    with pytest.raises(meshmark.InvalidInputError, match=message) as e:
        meshmark.run_campaign(file, tmp_path / "file")
    assert e.value.file == str(file)


def test_a_file_that_is_not_a_campaign(tmp_path):
    file = tmp_path / "broken.json"
    file.write_text('{"name": "broken", "models": [')
    with pytest.raises(meshmark.InvalidInputError, match="not valid JSON"):
        meshmark.run_campaign(file, tmp_path / "out")
    with pytest.raises(meshmark.IOError):
        meshmark.run_campaign(tmp_path / "missing.json", tmp_path / "out")

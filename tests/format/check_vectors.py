"""Checks the test vectors of docs/format.md (section 9) two ways.

1. reference.py, a second implementation written from the page alone, must compute every
   codeword of the table and both key fingerprints.
2. For the rows marked "embedded", the meshmark command line must write that codeword into
   data/meshes/spot.obj and read the ID back; the bins and the whitening it reports must be the
   reference's layout, and the per-bin means it reads must be those the reference computes from
   the same marked file (within 1e-12 of a bin width).

Usage: python3 check_vectors.py MESHMARK_CLI CHECKOUT_DIR SCRATCH_DIR
Exits 0 when every check passes, 1 naming the first one that fails.
"""

import json
import os
import pathlib
import re
import subprocess
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import reference as ref  # noqa: E402

PASSPHRASE = "correct horse battery staple"
MEAN_TOLERANCE = 1e-12  # bin widths: two float64 computations of one mean


def fail(message):
    print(f"check_vectors: FAILED: {message}", file=sys.stderr)
    sys.exit(1)


def vectors(page):
    """The rows between the page's test-vector markers."""
    text = page.read_text(encoding="utf-8")
    start, end = text.find("<!-- test-vectors -->"), text.find("<!-- /test-vectors -->")
    if start < 0 or end < 0:
        fail(f"{page}: the test-vector markers are missing")
    rows = []
    for line in text[start:end].splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 6 or not cells[1].isdigit():
            continue
        rows.append({"key": cells[0], "nb": int(cells[1]), "id_bits": int(cells[2]),
                     "id": int(cells[3]), "codeword": cells[4],
                     "embedded": cells[5].startswith("yes")})
    if len(rows) < 5:
        fail(f"{page}: only {len(rows)} test vectors found")
    fingerprints = dict(re.findall(r"(key file|passphrase)\s+`([0-9a-f]{32})`", text))
    return rows, fingerprints


def cli(meshmark, *args):
    run = subprocess.run([meshmark, *args], capture_output=True, text=True, check=False)
    if run.returncode != 0:
        fail(f"meshmark {' '.join(args)} exited {run.returncode}: {run.stdout}{run.stderr}")
    return json.loads(run.stdout)


def main():
    meshmark, checkout, scratch = sys.argv[1], pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
    scratch.mkdir(parents=True, exist_ok=True)
    key_file = checkout / "tests" / "format" / "example.key"
    mesh = checkout / "data" / "meshes" / "spot.obj"
    rows, fingerprints = vectors(checkout / "docs" / "format.md")
    keys = {"file": ref.key_from_file(str(key_file)),
            "passphrase": ref.key_from_passphrase(PASSPHRASE.encode()),
            "public": ref.PUBLIC}
    key_args = {"file": ["--key-file", str(key_file)], "passphrase": ["--key", PASSPHRASE],
                "public": []}
    for name, label in (("file", "key file"), ("passphrase", "passphrase")):
        got = ref.fingerprint(keys[name])
        if fingerprints.get(label) != got:
            fail(f"the {label}'s fingerprint: page {fingerprints.get(label)}, reference {got}")
    embedded = 0
    for row in rows:
        what = f"{row['key']} key, nb {row['nb']}, {row['id_bits']} ID bits, ID {row['id']}"
        key = keys[row["key"]]
        code = ref.IdCode(row["nb"], row["id_bits"])
        word = code.encode(row["id"], key)
        if ref.hexword(word) != row["codeword"]:
            fail(f"{what}: page {row['codeword']}, reference {ref.hexword(word)}")
        if not row["embedded"]:
            continue
        out = scratch / f"spot-{row['key']}-{row['nb']}-{row['id']}.obj"
        bits = ["--bits", str(row["nb"]), "--id-bits", str(row["id_bits"])]
        e = cli(meshmark, "embed", str(mesh), str(out), "--id", str(row["id"]), *bits,
                *key_args[row["key"]], "--json")
        if e["payload"] != row["codeword"] or e["id"] != row["id"]:
            fail(f"{what}: meshmark embedded {e['payload']} (ID {e['id']})")
        x = cli(meshmark, "extract", str(out), "--coded", *bits, *key_args[row["key"]], "--json")
        if x["id"] != row["id"] or x["payload"] != row["codeword"]:
            fail(f"{what}: meshmark read ID {x['id']}, payload {x['payload']}")
        bin_of, white = ref.layout(key, row["nb"])
        V, F = ref.read_obj(str(out))
        ref_bits, means, counts, *_ = ref.extract(V, F, row["nb"])
        for j, b in enumerate(x["per_bit"]):
            if b["bin"] != bin_of[j] + 1:
                fail(f"{what}: bit {j} in bin {b['bin']}, reference bin {bin_of[j] + 1}")
            if b["vertices"] != counts[bin_of[j]]:
                fail(f"{what}: bit {j}: {b['vertices']} vertices, reference {counts[bin_of[j]]}")
            if abs(b["mean"] - means[bin_of[j]]) > MEAN_TOLERANCE:
                fail(f"{what}: bit {j}: mean {b['mean']!r}, reference {means[bin_of[j]]!r}")
            if (ref_bits[bin_of[j]] ^ white[j]) != word[j] or b["value"] != word[j]:
                fail(f"{what}: bit {j} reads {b['value']}, the codeword holds {word[j]}")
        embedded += 1
    # The geometry hash of section 7.1: the page's, the reference's and what meshmark records.
    page = (checkout / "docs" / "format.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- geometry-vector -->`([0-9a-f]{64})`<!-- /geometry-vector -->", page)
    if not m:
        fail("docs/format.md: the geometry hash vector is missing")
    V, F = ref.read_obj(str(mesh))
    if ref.geometry_hash(V, F) != m.group(1):
        fail(f"geometry hash of {mesh.name}: page {m.group(1)}, reference {ref.geometry_hash(V, F)}")
    db = scratch / "geometry.db"
    if db.exists():
        db.unlink()
    cli(meshmark, "embed", str(mesh), str(scratch / "geometry.ply"), "--id", "5", "--key-file",
        str(key_file), "--registry", str(db), "--json")
    row = cli(meshmark, "registry", "list", str(db), "--json")[0]
    recorded = row["original_geometry"]
    if recorded != m.group(1):
        fail(f"geometry hash of {mesh.name}: page {m.group(1)}, meshmark recorded {recorded}")
    # The row's MAC (section 7.2), recomputed from the page's encoding.
    if ref.row_mac(keys["file"], row) != row["mac"]:
        fail(f"row MAC: meshmark recorded {row['mac']}, reference {ref.row_mac(keys['file'], row)}")
    print(f"check_vectors: {len(rows)} codewords and 2 fingerprints as the page states; "
          f"{embedded} embedded into {mesh.name} and read back as the reference reads them; "
          f"its geometry hash as the page, the reference and the registry give it, and its "
          f"row MAC as the reference computes it")


if __name__ == "__main__":
    main()

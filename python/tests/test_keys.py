"""Passphrase keys: Argon2id as docs/format.md section 2.1 specifies, recorded with each copy.

The expected fingerprints are computed here from the page alone, with the Argon2 reference
implementation (argon2-cffi) and hashlib's BLAKE2b, never with the library.
"""

import hashlib
import json

from argon2.low_level import Type, hash_secret_raw

import meshmark
from conftest import run_cli

PASSPHRASE = "a passphrase of the python tests"
ARGON2ID = "passphrase/argon2id13/t=3/m=64MiB/salt=c9221906c490540cb058155a6f19d6ed"


def fingerprint(key):
    return hashlib.blake2b(b"meshmark/mark-v2/fingerprint", digest_size=32,
                           key=key).digest()[:16].hex()


def argon2id_key(passphrase):
    salt = hashlib.blake2b(b"meshmark/passphrase/v2/salt\x00", digest_size=32).digest()[:16]
    assert salt.hex() == ARGON2ID.rsplit("=", 1)[1]
    return hash_secret_raw(passphrase.encode(), salt, time_cost=3, memory_cost=64 * 1024,
                           parallelism=1, hash_len=32, type=Type.ID, version=19)


def blake2b_key(passphrase):
    return hashlib.blake2b(b"meshmark/passphrase/v1\x00" + passphrase.encode(),
                           digest_size=32).digest()


def test_keys_say_how_they_were_derived():
    assert meshmark.Key.from_passphrase(PASSPHRASE).derivation == ARGON2ID
    assert meshmark.Key.from_passphrase_v1(PASSPHRASE).derivation == "passphrase/blake2b"
    assert meshmark.Key.from_passphrase(PASSPHRASE) != meshmark.Key.from_passphrase_v1(PASSPHRASE)


def test_an_issued_copy_records_the_argon2id_key_and_its_derivation(fandisk, tmp_path):
    db = tmp_path / "shop.db"
    copies = [{"input": fandisk, "output": tmp_path / "c.ply", "id": 5, "buyer": "b"},
              {"input": fandisk, "output": tmp_path / "d.ply", "id": 6, "buyer": "c"}]
    meshmark.issue(copies[:1], registry=str(db), key=PASSPHRASE)
    meshmark.issue(copies[1:], registry=str(db), key=meshmark.Key.from_passphrase_v1(PASSPHRASE))
    rows = {r["id"]: r for r in run_cli("registry", "list", db, "--json")}
    assert rows[5]["key_derivation"] == ARGON2ID
    assert rows[5]["key_fingerprint"] == fingerprint(argon2id_key(PASSPHRASE))
    assert rows[6]["key_derivation"] == "passphrase/blake2b"
    assert rows[6]["key_fingerprint"] == fingerprint(blake2b_key(PASSPHRASE))


def test_trace_with_a_passphrase_reads_copies_issued_under_its_earlier_key(fandisk, tmp_path):
    db = tmp_path / "shop.db"
    copy = tmp_path / "old.ply"
    out = meshmark.issue([{"input": fandisk, "output": copy, "id": 9, "buyer": "old buyer"}],
                         registry=str(db), key=meshmark.Key.from_passphrase_v1(PASSPHRASE))
    assert out[0]["ok"], out
    found = meshmark.trace(copy, fandisk, str(db), key=PASSPHRASE)
    assert [n["id"] for n in found["named"]] == [9], found["message"]
    assert any("issued before registry schema 4" in w for w in found["warnings"]), found

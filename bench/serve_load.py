#!/usr/bin/env python3
"""Load on `meshmark serve` over loopback (bench/README.md, "Serving copies").

Starts the built CLI's server on 127.0.0.1 with a fresh key and registry, prepares one original,
then issues copies from CLIENTS concurrent clients (Python's http.client, one connection
each) and reports the latency of each copy (request sent to the last byte of the file received;
the file is written and its row committed before the answer) and the copies per second.
Afterwards it checks what the load test of issue #31 asks: no request lost, no ID twice, every
received file's hash equal to its row's output_hash.

    /usr/bin/python3 bench/serve_load.py build/meshmark MESH --copies 1000 --clients 4
"""

import argparse
import hashlib
import http.client
import json
import os
import shutil
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import uuid


def multipart(field, filename, data):
    boundary = uuid.uuid4().hex
    body = (f"--{boundary}\r\nContent-Disposition: form-data; name=\"{field}\"; "
            f"filename=\"{filename}\"\r\nContent-Type: application/octet-stream\r\n\r\n").encode()
    body += data + f"\r\n--{boundary}--\r\n".encode()
    return body, f"multipart/form-data; boundary={boundary}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("cli")
    ap.add_argument("mesh")
    ap.add_argument("--copies", type=int, default=1000)
    ap.add_argument("--clients", type=int, default=4)
    ap.add_argument("--format", default="ply")
    ap.add_argument("--kill-after", type=float, default=0,
                    help="kill -9 the server after this many seconds of load, start it again, "
                         "and check that no row stays reserved")
    args = ap.parse_args()
    work = tempfile.mkdtemp(prefix="meshmark-serve-load-")
    try:
        subprocess.run([args.cli, "keygen", f"{work}/shop.key"], check=True,
                       stdout=subprocess.DEVNULL)
        token = uuid.uuid4().hex
        env = dict(os.environ, MESHMARK_TOKEN=token)
        command = [args.cli, "serve", "--listen", "127.0.0.1:0", "--registry", f"{work}/shop.db",
                   "--key-file", f"{work}/shop.key"]
        server = subprocess.Popen(command, stdout=subprocess.PIPE, env=env, text=True)
        line = server.stdout.readline()
        port = int(line.rsplit(":", 1)[1].split()[0])
        headers = {"Authorization": f"Bearer {token}"}
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=600)
        with open(args.mesh, "rb") as f:
            body, ctype = multipart("mesh", os.path.basename(args.mesh), f.read())
        t0 = time.perf_counter()
        c.request("POST", "/originals", body, dict(headers, **{"Content-Type": ctype}))
        r = c.getresponse()
        original = json.loads(r.read())
        prepare_s = time.perf_counter() - t0
        if r.status not in (200, 201):
            sys.exit(f"POST /originals: {r.status} {original}")
        received, latencies, errors, cut = [], [], [], []
        lock = threading.Lock()

        def client(k, n):
            conn = http.client.HTTPConnection("127.0.0.1", port, timeout=600)
            for i in range(n):
                req = json.dumps({"original": original["original"], "buyer": f"c{k}-{i}",
                                  "format": args.format})
                t = time.perf_counter()
                try:
                    conn.request("POST", "/copies", req,
                                 dict(headers, **{"Content-Type": "application/json"}))
                    resp = conn.getresponse()
                    data = resp.read()
                except (ConnectionError, http.client.HTTPException):
                    with lock:
                        cut.append(k)  # the server was killed: this client stops
                    return
                dt = time.perf_counter() - t
                with lock:
                    if resp.status != 200:
                        errors.append((resp.status, data[:200]))
                        continue
                    latencies.append(dt)
                    received.append((int(resp.getheader("X-Meshmark-Id")),
                                     hashlib.blake2b(data, digest_size=32).hexdigest()))

        per = [args.copies // args.clients + (k < args.copies % args.clients)
               for k in range(args.clients)]
        t0 = time.perf_counter()
        threads = [threading.Thread(target=client, args=(k, n)) for k, n in enumerate(per)]
        for t in threads:
            t.start()
        released = None
        if args.kill_after > 0:
            time.sleep(args.kill_after)
            server.kill()  # SIGKILL, in the middle of the load
            server.wait(timeout=60)
        for t in threads:
            t.join()
        wall = time.perf_counter() - t0
        if args.kill_after > 0:
            db = sqlite3.connect(f"{work}/shop.db")
            left = db.execute("SELECT count(*) FROM copies WHERE state = 'reserved'").fetchone()[0]
            db.close()
            server = subprocess.Popen(command, stdout=subprocess.PIPE, env=env, text=True)
            first = server.stdout.readline()
            released = {"reserved_after_kill": left,
                        "restart_says": first.strip() if "gave back" in first else None}
        server.terminate()
        server.wait(timeout=60)
        rows = {}
        db = sqlite3.connect(f"{work}/shop.db")
        for rid, state, out_hash in db.execute("SELECT id, state, output_hash FROM copies"):
            if rid in rows:
                sys.exit(f"ID {rid} recorded twice")
            rows[rid] = (state, out_hash)
        lost = [i for i, h in received if i not in rows or rows[i] != ("issued", h)]
        reserved = sum(1 for state, _ in rows.values() if state == "reserved")
        ids = [i for i, _ in received]
        print(json.dumps({
            "mesh": os.path.basename(args.mesh), "vertices": original["vertices"],
            "prepare_s": round(prepare_s, 3), "copies": len(received), "clients": args.clients,
            "errors": len(errors), "first_error": str(errors[0]) if errors else None,
            "latency_median_ms": round(1e3 * statistics.median(latencies), 1),
            "latency_p95_ms": round(1e3 * sorted(latencies)[int(0.95 * len(latencies))], 1),
            "copies_per_s": round(len(received) / wall, 1),
            "duplicate_ids": len(ids) - len(set(ids)), "rows": len(rows),
            "mismatched_or_missing_rows": len(lost), "rows_left_reserved": reserved,
            "clients_cut_by_the_kill": len(cut), "kill": released}, indent=1))
        return 1 if errors or lost or reserved or len(ids) != len(set(ids)) else 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())

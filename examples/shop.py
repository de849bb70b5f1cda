"""The shop's job: a key, 100 copies of ORIGINAL for 100 buyers, a leak traced with its report.
Usage: PYTHONPATH=build/python python3 examples/shop.py ORIGINAL   (in an empty folder)"""
import sys
import meshmark

original = sys.argv[1]
key = meshmark.Key.generate("shop.key")  # 32 random bytes, mode 0600: keep it secret
copies = [{"input": original, "output": f"copy-{n}.ply", "id": "auto", "buyer": f"buyer-{n}"}
          for n in range(1, 101)]
issued = meshmark.issue(copies, registry="shop.db", key=key)
print(sum(c["ok"] for c in issued), "copies issued")
leak = meshmark.attack(meshmark.read_mesh("copy-42.ply"), "similarity:2,simplify:0.5", seed=7)
meshmark.write_mesh("leak.ply", leak)
print(meshmark.trace("leak.ply", original, "shop.db", key=key, report="report.html")["message"])
print("evidence report: report.html")

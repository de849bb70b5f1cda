"""The layout shows the architecture (docs/developing.md, "Stages"): every source and public
header sits in the folder of its stage, src/, include/meshmark/ and tests/ use the same stage
names, a stage includes only headers of the stages before it in STAGES, and a public header
includes only public headers. Exits 1 naming
every file out of place and every include that goes the wrong way.

Usage: python3 check_layout.py SOURCE_DIR"""

import os
import re
import sys

# The stages in the order they may depend on each other (docs/developing.md's table).
STAGES = ["core", "io", "plot", "attacks", "solve", "carrier", "metrics", "mark", "protocol",
          "forensics", "campaign"]
INCLUDE = re.compile(r'^\s*#\s*include\s+"(?:meshmark/)?([a-z_]+)/([a-z0-9_]+\.h)"', re.M)


def main(root):
    problems = []
    src = os.path.join(root, "src")
    public = os.path.join(root, "include", "meshmark")
    tests = os.path.join(root, "tests")
    for base, allowed_top, extra_dirs in ((src, set(), {"cgal"}),
                                          (public, {"meshmark.h"}, set()),
                                          (tests, None, {"cli"})):
        for entry in sorted(os.listdir(base)):
            path = os.path.join(base, entry)
            if os.path.isdir(path):
                if entry in STAGES or entry in extra_dirs:
                    continue
                if base == tests:
                    continue  # the suite's own folders (examples, format, ...), not stages
                problems.append(f"{path}: a folder that is no stage ({', '.join(STAGES)})")
            elif allowed_top is not None and entry.endswith((".cpp", ".h")) \
                    and entry not in allowed_top:
                problems.append(f"{path}: outside a stage folder")
            elif base == tests and entry.endswith("_test.cpp") and entry != "data_test.cpp":
                problems.append(f"{path}: a test outside its stage's folder")
    for stage in STAGES:
        if not os.path.isdir(os.path.join(src, stage)):
            problems.append(f"{os.path.join(src, stage)}: the stage has no sources")
    for base, depth in ((src, 1), (public, 2)):
        for folder, _, files in os.walk(base):
            for name in files:
                path = os.path.join(folder, name)
                parts = os.path.relpath(path, root).split(os.sep)
                stage = parts[depth] if len(parts) > depth + 1 else None
                if stage not in STAGES:
                    continue
                text = open(path, encoding="utf-8").read()
                if base == public:  # installed: it may include only installed headers
                    for m in re.finditer(r'^\s*#\s*include\s+"([^"]+)"', text, re.M):
                        if not m.group(1).startswith("meshmark/"):
                            line = text.count("\n", 0, m.start()) + 1
                            problems.append(f"{path}:{line}: a public header includes "
                                            f"{m.group(1)}, which is not installed")
                for m in INCLUDE.finditer(text):
                    other = m.group(1)
                    if other in STAGES and STAGES.index(other) > STAGES.index(stage):
                        line = text.count("\n", 0, m.start()) + 1
                        problems.append(f"{path}:{line}: stage {stage} includes "
                                        f"{other}/{m.group(2)}, of a later stage")
    for p in problems:
        print(p)
    print(f"layout: {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))

"""The README a newcomer reads: at most 200 lines, and each quick start in it is, byte for byte,
the example file the tests run (the block after a line `<!-- example: PATH -->`).
Usage: python3 check_readme.py CHECKOUT_DIR"""
import pathlib
import re
import sys

MAX_LINES = 200

root = pathlib.Path(sys.argv[1])
text = (root / "README.md").read_text(encoding="utf-8")
lines = text.splitlines()
if len(lines) > MAX_LINES:
    sys.exit(f"check_readme: README.md has {len(lines)} lines, more than {MAX_LINES}")
blocks = re.findall(r"<!-- example: (\S+) -->\n```[a-z+]*\n(.*?)```\n", text, re.S)
names = sorted(name for name, _ in blocks)
if names != ["examples/shop.cpp", "examples/shop.py", "examples/shop.sh"]:
    sys.exit(f"check_readme: the README's quick starts are {names}, not the three examples")
for name, block in blocks:
    example = (root / name).read_text(encoding="utf-8")
    if block != example:
        sys.exit(f"check_readme: the README's block for {name} is not the file")
    if len(example.splitlines()) > 15:
        sys.exit(f"check_readme: {name} has more than 15 lines")
print(f"check_readme: {len(lines)} lines; the quick starts are the 3 examples")

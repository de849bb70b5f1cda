#!/usr/bin/env bash
# Runs one of examples/ (a command line taking the original's path) in a fresh folder on a real
# mesh, then checks what a shop needs from it: buyer 42's leaked copy named, no other buyer
# named, and the evidence report written and naming buyer 42.
# Usage: tests/examples/run.sh ORIGINAL COMMAND...
set -euo pipefail
original="$(realpath "$1")"
shift
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cd "$work"
rc=0
out="$("$@" "$original" 2>&1)" || rc=$?
[ "$rc" = 0 ] || { echo "$out"; echo "examples: '$*' exited $rc" >&2; exit 1; }
echo "$out"
grep -q "one buyer named: 'buyer-42' (ID [0-9]*)" <<<"$out" ||
  { echo "examples: buyer-42 is not the one buyer named" >&2; exit 1; }
[ -s report.html ] || { echo "examples: no evidence report" >&2; exit 1; }
grep -q "buyer-42" report.html || { echo "examples: the report does not name buyer-42" >&2; exit 1; }
[ "$(stat -c %a shop.key)" = 600 ] || { echo "examples: the key file is not private" >&2; exit 1; }
echo "examples: buyer-42 named, report.html written ($(stat -c %s report.html) bytes)"

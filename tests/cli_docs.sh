#!/usr/bin/env bash
# The man page and the bash completion (meshmark generate): groff renders the page without a
# warning; every command that --help lists has a section, and every option that a command's
# --help lists is in it; the completion completes commands, options and registry's
# subcommands as --help names them.
# Usage: cli_docs.sh MESHMARK_CLI MAN_PAGE COMPLETION
set -euo pipefail
cli="$1" man="$2" completion="$3"
warnings="$(groff -man -Tutf8 -ww "$man" 2>&1 >/dev/null)"
[ -z "$warnings" ] || { echo "cli_docs: groff warns: $warnings" >&2; exit 1; }
commands="$("$cli" --help | awk '/^Subcommands:/ {on = 1; next} on && !NF {exit} on {print $1}')"
[ "$(wc -w <<<"$commands")" -ge 11 ] || { echo "cli_docs: --help lists too few commands" >&2; exit 1; }
for c in $commands; do
  grep -qx ".SS $c" "$man" || { echo "cli_docs: no section for $c" >&2; exit 1; }
  for o in $("$cli" $c --help | grep -o -- '--[a-z][a-z0-9-]*' | sort -u); do
    grep -qF -- "$(sed 's/-/\\-/g' <<<"$o")" "$man" || { echo "cli_docs: $c: $o is not in the man page" >&2; exit 1; }
  done
done
complete_words() {  # the completions of a command line whose last word is being typed
  bash -c 'source "$1"; shift; COMP_WORDS=("$@"); COMP_CWORD=$(($# - 1)); _meshmark; echo "${COMPREPLY[*]}"' _ "$completion" "$@"
}
[ "$(complete_words meshmark tr)" = "trace" ] || { echo "cli_docs: 'meshmark tr' does not complete to trace" >&2; exit 1; }
got="$(complete_words meshmark trace --re)"
for o in --registry --report --redact; do
  grep -qw -- "$o" <<<"$got" || { echo "cli_docs: 'trace --re' misses $o ($got)" >&2; exit 1; }
done
[ "$(complete_words meshmark registry l)" = "list" ] || { echo "cli_docs: 'registry l' does not complete to list" >&2; exit 1; }
echo "cli_docs: $(wc -w <<<"$commands") commands and their options in the man page; completion answers"

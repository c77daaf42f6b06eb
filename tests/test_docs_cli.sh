#!/usr/bin/env bash
# docs/cli.md against the program: every command `chisel --help` lists has a
# section "## chisel NAME", and every option a command accepts (its entry in
# src/main.c's option table and every long option its --help names) appears
# in that section as `--opt`; the options every command takes appear in the
# conventions. So an option added to the CLI without its documentation fails
# here.
# usage: test_docs_cli.sh CHISEL SOURCE_DIR
set -u
chisel=$1 src=$2
doc=$src/docs/cli.md main=$src/src/main.c
failures=0 checks=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
[ -f "$doc" ] || { echo "FAIL: $doc missing" >&2; exit 1; }

# The text of section "## chisel NAME" (up to the next "## ").
section() { awk -v h="## chisel $1" '$0 == h {on = 1; next} /^## / {on = 0} on' "$doc"; }

# main.c's table: {"command", "opt= opt ..." "..."} entries, string
# literals joined; prints "command option" per option, values' '=' dropped.
table=$(sed -n '/option_lists\[\] = {/,/^};/p' "$main" | tr '\n' ' ' | sed 's/" *"//g' |
  grep -o '{"[a-z]*", *"[^"]*"}' | sed 's/^{"\([a-z]*\)", *"\([^"]*\)"}$/\1 \2/')
[ -n "$table" ] || fail "no option table found in $main"

commands=$("$chisel" --help | awk '/^commands:/ {on = 1; next} /^$/ {on = 0} on {print $1}' | grep -v '^help$')
[ -n "$commands" ] || fail "chisel --help lists no commands"
for cmd in $commands; do
  checks=$((checks + 1))
  text=$(section "$cmd")
  if [ -z "$text" ]; then
    fail "docs/cli.md has no section '## chisel $cmd'"
    continue
  fi
  opts=$(printf '%s\n' "$table" | awk -v c="$cmd" '$1 == c {for (i = 2; i <= NF; i++) print $i}' | tr -d '=')
  [ -n "$opts" ] || fail "src/main.c's option table has no entry for '$cmd'"
  help=$("$chisel" "$cmd" --help) || fail "chisel $cmd --help failed"
  opts="$opts $(printf '%s\n' "$help" | grep -o -- '--[a-z][a-z0-9-]*' | grep -v -- '--help')"
  for opt in $(printf '%s\n' $opts | sort -u); do
    checks=$((checks + 1))
    grep -qF -- "\`$opt" <<<"$text" || fail "chisel $cmd $opt is not in docs/cli.md's section '## chisel $cmd'"
  done
done
conventions=$(awk '/^## Conventions/ {on = 1; next} /^## / {on = 0} on' "$doc")
for opt in -q --quiet -j --threads --opt=value -h --help; do
  checks=$((checks + 1))
  grep -qF -- "\`$opt" <<<"$conventions" || fail "$opt (every command) is not in docs/cli.md's conventions"
done
for opt in --version; do
  checks=$((checks + 1))
  grep -qF -- "$opt" "$doc" || fail "chisel $opt is not in docs/cli.md"
done
echo "docs/cli.md: $checks checks, $failures failures"
[ "$failures" -eq 0 ]

#!/usr/bin/env bash
# expect_fail.sh CODE REGEX COMMAND [ARGS...]
# Passes when COMMAND exits with status CODE and its stderr+stdout matches the
# extended regular expression REGEX: a comparison that must fail. dkf-run's
# own refusals and failures are tests/cases/ (run_case.sh, which also holds
# them to one stderr line).
set -u
want=$1 regex=$2
shift 2
errf=$(mktemp) outf=$(mktemp)
trap 'rm -f "$errf" "$outf"' EXIT
"$@" >"$outf" 2>"$errf"
got=$?
echo "command: $*"
echo "exit status: $got (want $want)"
echo "--- stderr"; cat "$errf"
echo "--- stdout"; head -n 20 "$outf"
if [[ $got -ne $want ]]; then
  echo "FAIL: exit status $got, expected $want"; exit 1
fi
if ! cat "$errf" "$outf" | grep -Eq -- "$regex"; then
  echo "FAIL: output does not match /$regex/"; exit 1
fi
echo "PASS"

#!/usr/bin/env bash
# run_case.sh DKF_RUN CASE.json - one scenario file as a test case
# (ports/linux/tests/cases.cmake): CASE.expected beside it holds
#   args: dkf-run's options before the file (e.g. --filter kf)
#   status: the exit status dkf-run must give
#   stderr: an extended regular expression the one stderr line must match
# Passes when dkf-run exits with that status and writes exactly one line on
# stderr, which matches.
set -u
run=$1 case=$2
exp=${case%.json}.expected
field() { sed -n "s/^$1: //p" "$exp"; }
[[ -f $exp ]] || { echo "FAIL: $exp missing"; exit 1; }
read -r -a args <<<"$(field args)"
want=$(field status) regex=$(field stderr)
errf=$(mktemp)
trap 'rm -f "$errf"' EXIT
"$run" "${args[@]}" "$case" >/dev/null 2>"$errf"
got=$?
echo "command: $run ${args[*]} $case"
echo "exit status: $got (want $want)"
echo "--- stderr"; cat "$errf"
[[ $got -eq $want ]] || { echo "FAIL: exit status $got, expected $want"; exit 1; }
lines=$(wc -l <"$errf")
[[ $lines -eq 1 ]] || { echo "FAIL: stderr has $lines lines, expected one"; exit 1; }
grep -Eq -- "$regex" "$errf" || { echo "FAIL: stderr does not match /$regex/"; exit 1; }
echo "PASS"

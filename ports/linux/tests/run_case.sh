#!/usr/bin/env bash
# run_case.sh DKF_RUN CASE.expected [@NAME=VALUE...] - one dkf-run invocation
# as a test case (ports/linux/tests/cases.cmake). CASE.expected holds lines
#   args: dkf-run's options before the input (e.g. --filter kf)
#   input: the scenario file (default: CASE.json beside CASE.expected)
#   status: the exit status dkf-run must give
#   stderr: an extended regular expression the one stderr line must match
#   fixture: the ctest fixture that generates the input (read by CMake)
#   max_dim_below: N - a case only for builds with DKF_MAX_DIM < N (CMake)
# and # comments. Every @NAME in args, input and stderr is replaced by the
# VALUE given on the command line (@vectors, @generated, @scenarios, @out,
# @DKF_MAX_DIM: cases.cmake lists them).
# Passes when dkf-run exits with that status and writes exactly one line on
# stderr, and the line matches (the shipped files are in the library's
# letters, so a case in the old ones has the notice as its one line).
set -u
run=$1 exp=$2
shift 2
field() { sed -n "s/^$1: //p" "$exp"; }
subst() {
  local s=$1 kv
  for kv in "${vars[@]}"; do s=${s//${kv%%=*}/${kv#*=}}; done
  printf '%s' "$s"
}
vars=("$@")
[[ -f $exp ]] || { echo "FAIL: $exp missing"; exit 1; }
input=$(field input)
input=$(subst "${input:-${exp%.expected}.json}")
read -r -a args <<<"$(subst "$(field args)")"
want=$(field status) regex=$(subst "$(field stderr)")
[[ -n $want && -n $regex ]] || { echo "FAIL: $exp needs status: and stderr:"; exit 1; }
errf=$(mktemp)
trap 'rm -f "$errf"' EXIT
"$run" "${args[@]}" "$input" >/dev/null 2>"$errf"
got=$?
echo "command: $run ${args[*]} $input"
echo "exit status: $got (want $want)"
echo "--- stderr"; cat "$errf"
[[ $got -eq $want ]] || { echo "FAIL: exit status $got, expected $want"; exit 1; }
msg=$(cat "$errf")
lines=0
[[ -z $msg ]] || lines=$(grep -c '' <<<"$msg")
[[ $lines -eq 1 ]] || { echo "FAIL: stderr has $lines lines, expected one"; exit 1; }
grep -Eq -- "$regex" <<<"$msg" || { echo "FAIL: stderr does not match /$regex/"; exit 1; }
echo "PASS"

#!/usr/bin/env bash
# run_check.sh DKF_RUN PYTHON COMPARE_PY OUT.json --run ARGS... --compare ARGS...
# Runs `DKF_RUN --output OUT.json ARGS...`, then `PYTHON COMPARE_PY ARGS...`
# with every @OUT@ replaced by OUT.json. Fails if either fails.
set -u
dkf_run=$1 python=$2 compare=$3 out=$4
shift 4
[[ ${1:-} == --run ]] || { echo "run_check.sh: expected --run" >&2; exit 2; }
shift
run_args=()
while [[ $# -gt 0 && $1 != --compare ]]; do run_args+=("$1"); shift; done
[[ ${1:-} == --compare ]] || { echo "run_check.sh: expected --compare" >&2; exit 2; }
shift
cmp_args=()
for a in "$@"; do cmp_args+=("${a//@OUT@/$out}"); done
rm -f "$out"
echo "+ $dkf_run --output $out ${run_args[*]}"
"$dkf_run" --output "$out" "${run_args[@]}" || { echo "FAIL: dkf-run exited with $?"; exit 1; }
echo "+ $python $compare ${cmp_args[*]}"
"$python" "$compare" "${cmp_args[@]}"

#!/usr/bin/env bash
# bench/callgrind.sh - instructions per KF step (dkf, Eigen -O2, Eigen -O3),
# counted by valgrind's callgrind: deterministic, unlike the timings of a
# shared VM, so it is the number to watch when tuning. For each type, the
# Joseph form on both sides and the short form P - K H P on both sides
# (BENCH_FORMS, as run_bench.sh).
#
#   bench/callgrind.sh [steps]     (default steps: 2000)
#
# What it builds is what valgrind runs: the baseline ISA of the target
# (x86-64: SSE2), no -march=native whatever BENCH_NATIVE says; valgrind
# 3.19 cannot execute AVX-512 and dies with SIGILL on it. (glibc's own
# AVX-512 string functions are no problem: valgrind's CPUID hides AVX-512,
# so glibc selects other ones.)
#
# Method: every benchmark runs twice under callgrind with fixed step counts
# and one repeat, `--steps S` and `--steps 0`. Both runs do the same setup
# (process start, model generation, the 1000-step checksum run, filter
# init), so
#     Ir/step = (Ir_total(S) - Ir_total(0)) / S
# counts exactly S predict+update steps and nothing else.
#
# Then the same for bench_uif (Joseph build), one filter at a time
# (--filter): DKF, ASKF and OTSKF instructions per step on seed 000
# Example 1; and for bench_nerts: seed 001's NERTSIF and DNERTSIF against
# the plain EKF and cubature KF of the same size.
#
# With BENCH_PROFILE=1 it also prints, for dkf, the functions with the most
# self instructions in the S-step run (callgrind_annotate), to show where a
# step's time goes. Those counts include the 1000 checksum steps, so
# "per step" there is self Ir / (S + 1000) (init is negligible).
#
# Environment: BENCH_TYPES (default "double float"), BENCH_FORMS (default
# "joseph short"), BENCH_BUILD_PREFIX as for run_bench.sh, BENCH_PROFILE=1
# for the profile.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
steps="${1:-2000}"
types="${BENCH_TYPES:-double float}"
forms="${BENCH_FORMS:-joseph short}"
exes="bench_kf bench_kf_eigen_O2 bench_kf_eigen_O3"
export BENCH_NATIVE=0 # valgrind cannot run what -march=native may emit
check_steps=1000 # BENCH_CHECK_STEPS in bench_common.h

command -v valgrind >/dev/null || { echo "callgrind.sh: valgrind not installed" >&2; exit 1; }
[[ "$steps" =~ ^[1-9][0-9]*$ ]] || { echo "usage: callgrind.sh [steps >= 1]" >&2; exit 2; }

out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

# Total instructions (Ir) of a callgrind output file.
total_ir() {
  sed -n 's/^\(summary\|totals\): *\([0-9]*\).*/\2/p' "$1" | head -n1
}

# Instructions per step of `exe args...`: two callgrind runs, one repeat
# each, with --steps $steps and --steps 0 (outputs PREFIX.S and PREFIX.0);
# prints (Ir(S) - Ir(0)) / S to one decimal.
ir_per_step() {
  local f="$1"
  shift
  valgrind --tool=callgrind --callgrind-out-file="$f.S" -q \
    "$@" --steps "$steps" --repeats 1 >/dev/null
  valgrind --tool=callgrind --callgrind-out-file="$f.0" -q \
    "$@" --steps 0 --repeats 1 >/dev/null
  awk -v a="$(total_ir "$f.S")" -v z="$(total_ir "$f.0")" -v s="$steps" \
    'BEGIN { printf "%.1f", (a - z) / s }'
}

printf "%-4s %-4s %-7s %-7s %12s %12s %12s %8s %8s\n" \
  n m type form dkf_Ir eigO2_Ir eigO3_Ir dkf/O2 dkf/O3
for t in $types; do
  for f in $forms; do
    b="$("$here/build_bench.sh" "$t" "$f")"
    for c in 0 1 2; do
      declare -A per=()
      for e in $exes; do
        per[$e]="$(ir_per_step "$out/$e.$t.$f.$c" "$b/bench/$e" --case "$c")"
      done
      nm="$(awk -v c="$c" 'BEGIN { split("4 2,8 4,12 6", v, ","); print v[c + 1] }')"
      awk -v nm="$nm" -v t="$t" -v fo="$f" -v d="${per[bench_kf]}" -v e2="${per[bench_kf_eigen_O2]}" \
          -v e3="${per[bench_kf_eigen_O3]}" 'BEGIN {
        split(nm, g, " ")
        printf "%-4s %-4s %-7s %-7s %12.1f %12.1f %12.1f %8.2f %8.2f\n", g[1], g[2], t, fo, d, e2, e3, d / e2, d / e3
      }'
      unset per
    done
  done
done

echo
printf "%-7s %12s %12s %12s   %s\n" type dkf_Ir askf_Ir otskf_Ir "DKF : ASKF : OTSKF"
for t in $types; do
  b="$("$here/build_bench.sh" "$t" "${forms%% *}")"
  declare -A per=()
  for flt in dkf askf otskf; do
    per[$flt]="$(ir_per_step "$out/uif.$flt.$t" "$b/bench/bench_uif" --filter "$flt")"
  done
  awk -v t="$t" -v d="${per[dkf]}" -v a="${per[askf]}" -v o="${per[otskf]}" 'BEGIN {
    printf "%-7s %12.1f %12.1f %12.1f   1 : %.2f : %.2f\n", t, d, a, o, a / d, o / d
  }'
  unset per
done

echo
printf "%-7s %12s %12s %12s %12s   %s\n" type nertsif_Ir ekf_Ir dnertsif_Ir ckf_Ir "NERTSIF/EKF DNERTSIF/CKF"
for t in $types; do
  b="$("$here/build_bench.sh" "$t" "${forms%% *}")"
  declare -A per=()
  for flt in nertsif ekf dnertsif ckf; do
    per[$flt]="$(ir_per_step "$out/nerts.$flt.$t" "$b/bench/bench_nerts" --filter "$flt")"
  done
  awk -v t="$t" -v a="${per[nertsif]}" -v e="${per[ekf]}" -v d="${per[dnertsif]}" -v c="${per[ckf]}" 'BEGIN {
    printf "%-7s %12.1f %12.1f %12.1f %12.1f   %11.2f %12.2f\n", t, a, e, d, c, a / e, d / c
  }'
  unset per
done

if [[ "${BENCH_PROFILE:-0}" == 1 ]]; then
  for t in $types; do
    fo="${forms%% *}"
    for c in 0 1 2; do
      f="$out/bench_kf.$t.$fo.$c.S"
      echo
      echo "== dkf $t $fo case $c: top self instructions, per step = Ir / $((steps + check_steps))"
      callgrind_annotate --inclusive=no "$f" 2>/dev/null |
        awk -v d="$((steps + check_steps))" '
          /^ *[0-9,]+ *\( *[0-9.]+%\)/ && n < 12 {
            ir = $1; gsub(",", "", ir)
            match($0, /\( *[0-9.]+%\)/); pct = substr($0, RSTART, RLENGTH); gsub(" ", "", pct)
            name = substr($0, RSTART + RLENGTH); sub(/^ */, "", name); sub(/ *\[[^]]*\]$/, "", name)
            sub(/^.*\//, "", name)
            printf "  %10.1f Ir/step %9s  %s\n", ir / d, pct, name; ++n
          }'
    done
  done
fi

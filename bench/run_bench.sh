#!/usr/bin/env bash
# bench/run_bench.sh - builds the KF step benchmarks (dkf, Eigen -O2, Eigen
# -O3 -march=native) for double and float and runs them all in ONE run,
# then prints one table row per (n, m, type): times, ratios, checksums.
# Then, in the same run, bench_uif (DKF : ASKF : OTSKF per step on seed
# 000 Example 1) for each type: a second table of times and ratios.
#
#   bench/run_bench.sh [extra benchmark args, e.g. --repeats 51 --target-ms 40]
#
# Environment:
#   BENCH_BUILD_PREFIX  build directories are <prefix>-double and <prefix>-float
#                       (default: <repo>/build-bench)
#   BENCH_TYPES         real types to run (default: "double float")
#   BENCH_ROUNDS        how many times the whole set is run; each row reports
#                       the median over rounds of the per-run medians (default 1)
#   BENCH_CPU           if set, pin every benchmark to this CPU with taskset
#   BENCH_JOSEPH        ON/OFF, passed as -DDKF_JOSEPH (default ON)
#   BENCH_RAW           if set, also keep the raw lines in this file
#
# bench/build_bench.sh does the builds: the library and bench_kf in Release
# with -O2 -DNDEBUG ("without special flags": no -march, no -ffast-math, the
# default config.h, checks on); Eigen with its own flags (bench/CMakeLists.txt).
#
# Checksum agreement: |dkf - eigen| <= tol * max(1, |dkf|) with tol 1e-9 in
# double and 1e-5 in float (84 FLT_EPSILON). The filter is contractive, so
# rounding differences (different summation orders inside the products) do
# not accumulate over the 1000 checksum steps: measured differences are a
# few units of roundoff (docs/bench.md), the tolerance leaves ~40x margin.
# Timings are only reported, never asserted.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
types="${BENCH_TYPES:-double float}"
rounds="${BENCH_ROUNDS:-1}"
exes="bench_kf bench_kf_eigen_O2 bench_kf_eigen_O3native"

pin=()
if [[ -n "${BENCH_CPU:-}" ]]; then
  command -v taskset >/dev/null || { echo "run_bench: BENCH_CPU set but no taskset" >&2; exit 1; }
  pin=(taskset -c "$BENCH_CPU")
fi

declare -A dir
for t in $types; do
  echo "run_bench: building $t" >&2
  dir[$t]="$("$here/build_bench.sh" "$t")"
done

raw="$(mktemp)"
rawuif="$(mktemp)"
trap 'rm -f "$raw" "$rawuif"' EXIT

{
  echo "# date:     $(date -u '+%Y-%m-%d %H:%M UTC')"
  echo "# git:      $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)$(git -C "$root" diff --quiet 2>/dev/null || echo ' (dirty tree)')"
  echo "# cc:       $(cc --version | head -n1)"
  echo "# c++:      $(c++ --version | head -n1)"
  echo "# eigen:    $(sed -n 's/^#define EIGEN_\(WORLD\|MAJOR\|MINOR\)_VERSION \([0-9]*\)$/\2/p' \
      /usr/include/eigen3/Eigen/src/Core/util/Macros.h 2>/dev/null | paste -sd. -)"
  echo "# cpu:      $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n1) x $(nproc) (nproc)"
  echo "# load:     $(cut -d" " -f1-3 /proc/loadavg) (1/5/15 min load average before the run)"
  echo "# flags:    dkf -O2 -g -DNDEBUG (Release); DKF_JOSEPH=${BENCH_JOSEPH:-ON}; rounds=$rounds; args: ${*:-(none)}"
} >&2

for ((r = 1; r <= rounds; ++r)); do
  for t in $types; do
    for c in 0 1 2; do
      # The three implementations of one case run back to back, so slow
      # phases of a shared machine hit them alike.
      for e in $exes; do
        "${pin[@]}" "${dir[$t]}/bench/$e" --case "$c" "$@" | tee -a "$raw" >&2
      done
    done
    # The three unknown-input filters, back to back in one process.
    "${pin[@]}" "${dir[$t]}/bench/bench_uif" "$@" | tee -a "$rawuif" >&2
  done
done
[[ -n "${BENCH_RAW:-}" ]] && cat "$raw" "$rawuif" >"$BENCH_RAW"

# Lines: impl type n m ns steps repeats checksum
status=0
awk '
function median(key,   n, i, j, t, a) {
  n = cnt[key]
  for (i = 1; i <= n; ++i) a[i] = val[key, i]
  for (i = 2; i <= n; ++i) { t = a[i]; for (j = i - 1; j >= 1 && a[j] > t; --j) a[j + 1] = a[j]; a[j + 1] = t }
  return (n % 2) ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
}
function absv(v) { return v < 0 ? -v : v }
{
  key = $1 SUBSEP $2 SUBSEP $3 SUBSEP $4
  val[key, ++cnt[key]] = $5
  sum[key] = $8
  row = $3 " " $4 " " $2
  if (!(row in seen)) { seen[row] = 1; order[++nrows] = row }
}
END {
  printf "%-4s %-4s %-7s %10s %10s %10s %9s %9s %10s  %s\n", \
    "n", "m", "type", "dkf_ns", "eigO2_ns", "eigO3n_ns", "dkf/O2", "dkf/O3n", "max_rel", "checksum"
  bad = 0
  for (i = 1; i <= nrows; ++i) {
    split(order[i], f, " "); n = f[1]; m = f[2]; ty = f[3]
    kd = "dkf" SUBSEP ty SUBSEP n SUBSEP m
    k2 = "eigen-O2" SUBSEP ty SUBSEP n SUBSEP m
    k3 = "eigen-O3native" SUBSEP ty SUBSEP n SUBSEP m
    d = median(kd); e2 = median(k2); e3 = median(k3)
    tol = (ty == "float") ? 1e-5 : 1e-9
    scale = absv(sum[kd]) > 1 ? absv(sum[kd]) : 1
    r2 = absv(sum[kd] - sum[k2]) / scale; r3 = absv(sum[kd] - sum[k3]) / scale
    rel = r2 > r3 ? r2 : r3
    ok = (rel <= tol) ? "agree" : "MISMATCH"
    if (rel > tol) bad = 1
    printf "%-4s %-4s %-7s %10.1f %10.1f %10.1f %9.2f %9.2f %10.2e  %s (%.10g)\n", \
      n, m, ty, d, e2, e3, d / e2, d / e3, rel, ok, sum[kd]
  }
  exit bad
}' "$raw" || status=$?

# Unknown-input filters: uif-dkf, uif-askf, uif-otskf (the paper: 1 : 1.74 : 1.26)
echo
awk '
function median(key,   n, i, j, t, a) {
  n = cnt[key]
  for (i = 1; i <= n; ++i) a[i] = val[key, i]
  for (i = 2; i <= n; ++i) { t = a[i]; for (j = i - 1; j >= 1 && a[j] > t; --j) a[j + 1] = a[j]; a[j + 1] = t }
  return (n % 2) ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
}
{
  key = $1 SUBSEP $2
  val[key, ++cnt[key]] = $5
  if (!($2 in seen)) { seen[$2] = 1; order[++nt] = $2 }
}
END {
  printf "%-7s %10s %10s %10s   %s\n", "type", "dkf_ns", "askf_ns", "otskf_ns", "DKF : ASKF : OTSKF (paper 1 : 1.74 : 1.26)"
  for (i = 1; i <= nt; ++i) {
    ty = order[i]
    d = median("uif-dkf" SUBSEP ty); a = median("uif-askf" SUBSEP ty); o = median("uif-otskf" SUBSEP ty)
    printf "%-7s %10.1f %10.1f %10.1f   1 : %.2f : %.2f\n", ty, d, a, o, a / d, o / d
  }
}' "$rawuif"
exit "$status"

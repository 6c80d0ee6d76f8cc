#!/usr/bin/env bash
# bench/run_bench.sh - builds the KF step benchmarks (dkf, Eigen -O2, Eigen
# -O3, the reference) for double and float, each with the Joseph form on
# both sides and with the short form P - K H P on both sides, runs them all
# in ONE run, then prints one table row per (n, m, type, form): times,
# ratios, checksum verdicts. Then, in the same run, bench_uif (DKF : ASKF :
# OTSKF per step on seed 000 Example 1, Joseph build) and bench_nerts (seed
# 001: NERTSIF / EKF, DNERTSIF / CKF) for each type.
#
#   bench/run_bench.sh [extra benchmark args, e.g. --repeats 51 --target-ms 40]
#
# Environment:
#   BENCH_BUILD_PREFIX  build directories are <prefix>-<type>-<form>
#                       (default: <repo>/build-bench)
#   BENCH_TYPES         real types to run (default: "double float")
#   BENCH_FORMS         covariance updates (default: "joseph short"):
#                       joseph = dkf DKF_JOSEPH=1 against Eigen's
#                       (I-KH)P(I-KH)^T + KRK^T; short = dkf DKF_JOSEPH=0
#                       against Eigen's P - KHP
#   BENCH_NATIVE=1      also Eigen -O3 -march=native (a by-hand opt-in: it
#                       depends on this CPU; never in the test command)
#   BENCH_ROUNDS        how many times the whole set is run; each row reports
#                       the median over rounds of the per-run medians (default 1)
#   BENCH_CPU           if set, pin every benchmark to this CPU with taskset
#   BENCH_RAW           if set, also keep the raw lines in this file
#
# Then bench_wfusion (seed 002: the fusion's cross covariances, scalar and
# matrix weights against L = 2, 5, 20, 50 sensors), from a third build per
# type with DKF_MAX_DIM = 256 (the joint covariance is 4 L x 4 L), with the
# growth exponent log(t(L2)/t(L1)) / log(L2/L1) between successive L.
# Then bench_fc (the Difference-KF fusion centre's step against N = 2, 12,
# 50, 100, 200 nodes), from a build with DKF_MAX_DIM = 1024, with the
# growth exponent between successive N; then the same with the steady gain
# (dkf_diffkf_fc_set_steady: tol 1e-12 double, 1e-5 float; 400 calls), its
# step after settling beside the recomputing step.
#
# bench/build_bench.sh does the builds: the library and bench_kf in Release
# with -O2 -DNDEBUG ("without special flags": no -march, no -ffast-math, the
# default config.h, checks on); Eigen with its own flags (bench/CMakeLists.txt).
#
# Checksums are judged against the independent reference (bench_kf_ref):
# |impl - reference| <= tol * max(1, |reference|), tol 1e-9 in double and
# 1e-5 in float (84 FLT_EPSILON). dkf off the reference: "dkf WRONG" and
# exit status 1. A peer off the reference: "peer X: wrong answer, excluded",
# its ratio is not printed ("-"), and the exit status is not affected.
# The filter is contractive, so rounding differences (different summation
# orders) do not accumulate over the 1000 checksum steps: measured
# differences are a few units of roundoff (docs/results/bench.md).
# Timings are only reported, never asserted.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
types="${BENCH_TYPES:-double float}"
forms="${BENCH_FORMS:-joseph short}"
rounds="${BENCH_ROUNDS:-1}"
peers="eigen-O2 eigen-O3"
[[ "${BENCH_NATIVE:-0}" == 1 ]] && peers+=" eigen-O3native"

pin=()
if [[ -n "${BENCH_CPU:-}" ]]; then
  command -v taskset >/dev/null || { echo "run_bench: BENCH_CPU set but no taskset" >&2; exit 1; }
  pin=(taskset -c "$BENCH_CPU")
fi

declare -A dir
for t in $types; do
  for f in $forms; do
    echo "run_bench: building $t $f" >&2
    dir[$t.$f]="$("$here/build_bench.sh" "$t" "$f")"
  done
done

declare -A bigdir fcdir
for t in $types; do
  echo "run_bench: building $t with DKF_MAX_DIM=256 (bench_wfusion)" >&2
  bigdir[$t]="$(BENCH_MAX_DIM=256 "$here/build_bench.sh" "$t" joseph)"
  # bench_fc: the stacked model of N = 200 nodes has 500 rows
  echo "run_bench: building $t with DKF_MAX_DIM=1024 (bench_fc)" >&2
  fcdir[$t]="$(BENCH_MAX_DIM=1024 "$here/build_bench.sh" "$t" joseph)"
done

raw="$(mktemp)"
rawuif="$(mktemp)"
rawnerts="$(mktemp)"
rawwf="$(mktemp)"
rawfc="$(mktemp)"
trap 'rm -f "$raw" "$rawuif" "$rawnerts" "$rawwf" "$rawfc"' EXIT

{
  echo "# date:     $(date -u '+%Y-%m-%d %H:%M UTC')"
  echo "# git:      $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)$(git -C "$root" diff --quiet 2>/dev/null || echo ' (dirty tree)')"
  echo "# cc:       $(cc --version | head -n1)"
  echo "# c++:      $(c++ --version | head -n1)"
  echo "# eigen:    $(sed -n 's/^#define EIGEN_\(WORLD\|MAJOR\|MINOR\)_VERSION \([0-9]*\)$/\2/p' \
      /usr/include/eigen3/Eigen/src/Core/util/Macros.h 2>/dev/null | paste -sd. -)"
  echo "# cpu:      $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n1) x $(nproc) (nproc)"
  echo "# load:     $(cut -d" " -f1-3 /proc/loadavg) (1/5/15 min load average before the run)"
  echo "# flags:    dkf -O2 -g -DNDEBUG (Release); forms: $forms; peers: $peers; rounds=$rounds; args: ${*:-(none)}"
} >&2

# Raw lines: form impl type n m ns steps repeats checksum
for t in $types; do
  # The reference does not depend on the form (bench_kf_ref.c): once per type.
  first="${forms%% *}"
  "${dir[$t.$first]}/bench/bench_kf_ref" "$@" --repeats 1 --target-ms 1 | sed 's/^/any /' >>"$raw"
done
for ((r = 1; r <= rounds; ++r)); do
  for t in $types; do
    for f in $forms; do
      for c in 0 1 2; do
        # The implementations of one case run back to back, so slow
        # phases of a shared machine hit them alike.
        "${pin[@]}" "${dir[$t.$f]}/bench/bench_kf" --case "$c" "$@" | sed "s/^/$f /" | tee -a "$raw" >&2
        for p in $peers; do
          # A peer that fails prints no line: it is then excluded (below).
          "${pin[@]}" "${dir[$t.$f]}/bench/bench_kf_${p/-/_}" --case "$c" "$@" | sed "s/^/$f /" |
            tee -a "$raw" >&2 || echo "run_bench: peer $p failed on $t $f case $c" >&2
        done
      done
    done
    # The three unknown-input filters, back to back in one process, in the
    # first form's build (the Joseph one by default).
    "${pin[@]}" "${dir[$t.${forms%% *}]}/bench/bench_uif" "$@" | tee -a "$rawuif" >&2
    # Seed 001's filters against the plain EKF / cubature KF, same build.
    "${pin[@]}" "${dir[$t.${forms%% *}]}/bench/bench_nerts" "$@" | tee -a "$rawnerts" >&2
    "${pin[@]}" "${bigdir[$t]}/bench/bench_wfusion" "$@" | tee -a "$rawwf" >&2
    # the Difference-KF fusion centre against N (its own options only)
    "${pin[@]}" "${fcdir[$t]}/bench/bench_fc" | tee -a "$rawfc" >&2
    if [[ $t == float ]]; then tol=1e-5; else tol=1e-12; fi
    "${pin[@]}" "${fcdir[$t]}/bench/bench_fc" --steady "$tol" --steps 400 --repeats 1 |
      tee -a "$rawfc" >&2
  done
done
[[ -n "${BENCH_RAW:-}" ]] && cat "$raw" "$rawuif" "$rawnerts" "$rawwf" "$rawfc" >"$BENCH_RAW"

status=0
awk -v peers="$peers" '
function median(key,   n, i, j, t, a) {
  n = cnt[key]
  for (i = 1; i <= n; ++i) a[i] = val[key, i]
  for (i = 2; i <= n; ++i) { t = a[i]; for (j = i - 1; j >= 1 && a[j] > t; --j) a[j + 1] = a[j]; a[j + 1] = t }
  return (n % 2) ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
}
function absv(v) { return v < 0 ? -v : v }
function relerr(a, b,   s) { s = absv(b) > 1 ? absv(b) : 1; return (a == a + 0 && a - a == 0) ? absv(a - b) / s : 1e300 }
$2 == "reference" { ref[$3 SUBSEP $4 SUBSEP $5] = $9; next }
{
  key = $1 SUBSEP $2 SUBSEP $3 SUBSEP $4 SUBSEP $5
  val[key, ++cnt[key]] = $6
  sum[key] = $9
  row = $1 " " $3 " " $4 " " $5
  if (!(row in seen)) { seen[row] = 1; order[++nrows] = row }
}
END {
  np = split(peers, pn, " ")
  for (p = 1; p <= np; ++p) { short[p] = pn[p]; sub(/^eigen-/, "", short[p]) }
  printf "%-4s %-4s %-7s %-7s %9s", "n", "m", "type", "form", "dkf_ns"
  for (p = 1; p <= np; ++p) printf " %9s", short[p] "_ns"
  for (p = 1; p <= np; ++p) printf " %8s", "dkf/" short[p]
  printf " %9s  %s\n", "dkf_rel", "checksum (reference)"
  bad = 0; nnote = 0
  for (i = 1; i <= nrows; ++i) {
    split(order[i], f, " "); fo = f[1]; ty = f[2]; n = f[3]; m = f[4]
    tol = (ty == "float") ? 1e-5 : 1e-9
    cs = ty SUBSEP n SUBSEP m
    kd = fo SUBSEP "dkf" SUBSEP cs
    d = median(kd)
    r = (cs in ref) ? ref[cs] : "nan"
    rd = relerr(sum[kd], r)
    verdict = (rd <= tol) ? "agree" : "dkf WRONG"
    if (rd > tol) bad = 1
    printf "%-4s %-4s %-7s %-7s %9.1f", n, m, ty, fo, d
    for (p = 1; p <= np; ++p) {
      kp = fo SUBSEP pn[p] SUBSEP cs
      ran = cnt[kp] > 0
      pt[p] = ran ? median(kp) : 0
      ok[p] = ran && relerr(sum[kp], r) <= tol
      if (!ran) note[++nnote] = sprintf("peer %s: no result, excluded (%s %s n=%s m=%s)", pn[p], ty, fo, n, m)
      else if (!ok[p]) note[++nnote] = sprintf("peer %s: wrong answer, excluded (%s %s n=%s m=%s: %s vs reference %.10g)", pn[p], ty, fo, n, m, sum[kp], r)
      if (ran) printf " %9.1f", pt[p]; else printf " %9s", "-"
    }
    for (p = 1; p <= np; ++p) {
      if (ok[p]) printf " %8.2f", d / pt[p]; else printf " %8s", "-"
    }
    printf " %9.2e  %s (%.10g)\n", rd, verdict, r
    if (fo == "joseph") rj[ty SUBSEP n] = ok[1] ? sprintf("%.2f", d / pt[1]) : "-"
    if (fo == "short") rs[ty SUBSEP n] = ok[1] ? sprintf("%.2f", d / pt[1]) : "-"
    if (!((ty SUBSEP n) in tn)) { tn[ty SUBSEP n] = 1; torder[++nt] = ty " " n }
  }
  for (i = 1; i <= nnote; ++i) print note[i]
  printf "\ndkf / %s per form (joseph: DKF_JOSEPH=1 vs the true Joseph form; short: P - KHP on both sides):\n%-7s %-4s %8s %8s\n", pn[1], "type", "n", "joseph", "short"
  for (i = 1; i <= nt; ++i) {
    split(torder[i], f, " "); k = f[1] SUBSEP f[2]
    printf "%-7s %-4s %8s %8s\n", f[1], f[2], (k in rj) ? rj[k] : "", (k in rs) ? rs[k] : ""
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

# Seed 001: NERTSIF against a plain EKF, DNERTSIF against a plain cubature KF
# (n = 4, m = 3; p = 1 against p = 0)
echo
awk '
{ key = $1 SUBSEP $2; ns[key] = $5; if (!($2 in seen)) { seen[$2] = 1; order[++nt] = $2 } }
END {
  printf "%-7s %10s %10s %10s %10s   %s\n", "type", "nertsif", "ekf", "dnertsif", "ckf", "NERTSIF/EKF  DNERTSIF/CKF"
  for (i = 1; i <= nt; ++i) {
    ty = order[i]
    a = ns["nerts-nertsif" SUBSEP ty]; e = ns["nerts-ekf" SUBSEP ty]
    d = ns["nerts-dnertsif" SUBSEP ty]; c = ns["nerts-ckf" SUBSEP ty]
    printf "%-7s %10.1f %10.1f %10.1f %10.1f   %11.2f  %12.2f\n", ty, a, e, d, c, a / e, d / c
  }
}' "$rawnerts"

echo
echo "seed 002 weighted fusion, ns per call against L sensors (n = 4; exponent: growth from the previous L):"
awk '
/^wfusion-/ { op = $1; sub(/^wfusion-/, "", op); key = op SUBSEP $2 SUBSEP $4; ns[key] = $5
  if (!(($2 SUBSEP $4) in seen)) { seen[$2 SUBSEP $4] = 1; rows[++nr] = $2 SUBSEP $4 } }
END {
  printf "%-7s %4s %12s %6s %12s %6s %12s %6s\n", "type", "L", "cross", "exp", "scalar", "exp", "matrix", "exp"
  for (i = 1; i <= nr; ++i) {
    split(rows[i], f, SUBSEP); ty = f[1]; L = f[2]
    printf "%-7s %4s", ty, L
    split("cross scalar matrix", ops, " ")
    for (o = 1; o <= 3; ++o) {
      t = ns[ops[o] SUBSEP ty SUBSEP L]
      if (i > 1) { split(rows[i - 1], g, SUBSEP) }
      if (i > 1 && g[1] == ty) { tp = ns[ops[o] SUBSEP ty SUBSEP g[2]]; printf " %12.1f %6.2f", t, log(t / tp) / log(L / g[2]) }
      else printf " %12.1f %6s", t, "-"
    }
    printf "\n"
  }
}' "$rawwf"

echo
echo "Difference-KF fusion centre (bench_fc) against N nodes (n = 4, p_i = 2): ns per dkf_diffkf_fc_step"
echo "steady = median of every call after the first (exponent: its growth from the previous N); first = the call after"
echo "fc_start, which computes the model block; start = fc_init + fc_start; storage in MiB (exponent likewise)"
awk '
/^fc-step / { ty = $2; N = $4; t = $5; t1 = $6; t0 = $7; mb = $8 / 1048576
  if (ty == pty) { e = log(t / pt) / log(N / pN); es = log(t0 / pt0) / log(N / pN); em = log(mb / pmb) / log(N / pN)
    printf "%-7s %4s steady %12.1f %5.2f  first %12.1f  start %12.1f %5.2f  storage %8.2f %5.2f\n", ty, N, t, e, t1, t0, es, mb, em }
  else printf "%-7s %4s steady %12.1f %5s  first %12.1f  start %12.1f %5s  storage %8.2f %5s\n", ty, N, t, "-", t1, t0, "-", mb, "-"
  pty = ty; pt = t; pN = N; pt0 = t0; pmb = mb }
/^# fc-step/ { print }' "$rawfc"
echo "with the steady gain (tol): the call at which the central gain settled, and the median ns of the calls after it,"
echo "against the steady step above (ratio) and the previous N (exponent)"
awk '
/^fc-step / { full[$2 " " $4] = $5 }
/^fc-steady / { ty = $2; N = $4; t = $7
  if (t <= 0) { printf "%-7s %4s tol %s: did not settle in %s calls\n", ty, N, $5, $9; next }
  r = (ty " " N) in full ? t / full[ty " " N] : 0
  e = (ty == pty) ? sprintf("%5.2f", log(t / pt) / log(N / pN)) : "    -"
  printf "%-7s %4s tol %-6s settled at %4s  steady %12.1f %s  ratio %.3f\n", ty, N, $5, $6, t, e, r
  pty = ty; pt = t; pN = N }' "$rawfc"
exit "$status"

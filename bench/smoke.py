#!/usr/bin/env python3
"""Bench smoke test for ctest: every benchmark builds, runs a few steps and
computes what the independent reference computes. No timing is asserted
(speed is reported by run_bench.sh, never tested).

usage: smoke.py REL --ref REF --dkf BENCH_KF --uif BENCH_UIF --nerts BENCH_NERTS
                [--wfusion BENCH_WFUSION] [--peer EIGEN]...
                [--expect-wrong NAME]

Each program prints lines `impl type n m ns steps repeats checksum`, the
checksum (sum of x + trace P after a fixed 1000-step run) independent of
--steps. Verdicts, per (type, n, m), against the reference's checksum
(bench_kf_ref: long double, textbook formulas, baseline flags), REL
relative:
  - dkf off the reference: FAIL (dkf computes a wrong answer);
  - a peer (Eigen build) off the reference: reported as
    "peer X: wrong answer, excluded" and excluded from any comparison,
    never a failure (a peer's compiler flags are not dkf's problem);
  - ASKF and OTSKF (exactly equivalent filters) agree to REL, and the DKF
    checksum is finite: else FAIL;
  - bench_nerts's four filters (seed 001) give finite checksums: else FAIL;
  - bench_wfusion (seed 002) gives, for each L this build fits, three
    operations with one finite checksum: else FAIL.

--expect-wrong NAME checks these verdicts themselves (ctest, with
BENCH_PERTURB=NAME making NAME wrong on purpose): it passes only if NAME
got the verdict a wrong NAME must get (a peer: excluded and the rest
passing; dkf: failed) and nothing else went wrong."""
import argparse
import math
import subprocess
import sys


def lines(exe):
    """(impl, type, n, m, checksum) of every result line of one program."""
    out = subprocess.run([exe, "--steps", "20", "--repeats", "1"], check=True,
                         capture_output=True, text=True, timeout=120).stdout
    rows = [(f[0], f[1], f[2], f[3], float(f[7])) for f in map(str.split, out.splitlines())
            if len(f) == 8 and not f[0].startswith("#")]
    if not rows:
        sys.exit(f"FAIL: {exe} printed no result line")
    return rows


def run(exe):
    """KF benchmarks: {(type, n, m): (impl, checksum)}."""
    return {(t, n, m): (impl, c) for impl, t, n, m, c in lines(exe)}


def run_uif(exe):
    """bench_uif / bench_nerts: filters on one (type, n, m): {impl: checksum}."""
    return {impl: c for impl, _, _, _, c in lines(exe)}


def close(a, b, rel):
    return math.isfinite(a) and abs(a - b) <= rel * max(1.0, abs(b))


def wfusion_verdicts(exe):
    """bench_wfusion: per L, the ops cross/scalar/matrix with one finite checksum."""
    by_l = {}
    for impl, _, _, l, c in lines(exe):
        by_l.setdefault(l, {})[impl] = c
    failures = []
    for l, ops in sorted(by_l.items(), key=lambda kv: int(kv[0])):
        sums = set(ops.values())
        ok = (set(ops) == {"wfusion-cross", "wfusion-scalar", "wfusion-matrix"} and len(sums) == 1
              and all(math.isfinite(v) for v in sums))
        print(f"{'ok  ' if ok else 'FAIL'} wfusion L={l}: {sorted(ops)} checksum {sorted(sums)!r}")
        if not ok:
            failures.append(f"wfusion L={l}")
    return failures


def verdicts(rel, ref, dkf, peers, uif, nerts):
    """Returns (failures, excluded peers), printing one line per check."""
    failures, excluded = [], set()
    for case, (_, want) in sorted(ref.items(), key=lambda kv: (kv[0][0], int(kv[0][1]))):
        typ, n, m = case
        where = f"{typ} n={n} m={m}"
        if not math.isfinite(want):
            failures.append("reference")
            print(f"FAIL {where}: the reference checksum is {want!r}")
            continue
        name, got = dkf.get(case, ("dkf", math.nan))
        if close(got, want, rel):
            print(f"ok   {where}: dkf {got!r} vs reference {want!r}")
        else:
            failures.append(name)
            print(f"FAIL {where}: dkf computes a wrong answer: {got!r} vs reference {want!r}")
        for peer in peers:
            pname, pgot = peer.get(case, ("?", math.nan))
            if close(pgot, want, rel):
                print(f"ok   {where}: {pname} {pgot!r} vs reference {want!r}")
            else:
                excluded.add(pname)
                print(f"peer {pname}: wrong answer, excluded ({where}: {pgot!r} vs reference {want!r})")
    ok = close(uif_get(uif, "uif-otskf"), uif_get(uif, "uif-askf"), rel)
    print(f"{'ok  ' if ok else 'FAIL'} OTSKF {uif_get(uif, 'uif-otskf')!r} vs ASKF {uif_get(uif, 'uif-askf')!r}")
    if not ok:
        failures.append("uif-otskf")
    ok = math.isfinite(uif_get(uif, "uif-dkf"))
    print(f"{'ok  ' if ok else 'FAIL'} DKF checksum finite ({uif_get(uif, 'uif-dkf')!r})")
    if not ok:
        failures.append("uif-dkf")
    for name in ("nerts-nertsif", "nerts-dnertsif", "nerts-ekf", "nerts-ckf"):
        ok = math.isfinite(uif_get(nerts, name))
        print(f"{'ok  ' if ok else 'FAIL'} {name} checksum finite ({uif_get(nerts, name)!r})")
        if not ok:
            failures.append(name)
    return failures, excluded


def uif_get(uif, name):
    return uif.get(name, math.nan)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("rel", type=float)
    ap.add_argument("--ref", required=True)
    ap.add_argument("--dkf", required=True)
    ap.add_argument("--uif", required=True)
    ap.add_argument("--nerts", required=True)
    ap.add_argument("--wfusion", default=None)
    ap.add_argument("--peer", action="append", default=[])
    ap.add_argument("--expect-wrong", default=None)
    a = ap.parse_args()
    ref, dkf = run(a.ref), run(a.dkf)
    peers = [run(p) for p in a.peer]
    failures, excluded = verdicts(a.rel, ref, dkf, peers, run_uif(a.uif), run_uif(a.nerts))
    if a.wfusion:
        failures += wfusion_verdicts(a.wfusion)
    if excluded:
        print(f"excluded peers: {', '.join(sorted(excluded))}")
    if a.expect_wrong is None:
        if failures:
            sys.exit(f"{len(failures)} check(s) failed: {', '.join(sorted(set(failures)))}")
        print("BENCH SMOKE PASSED")
        return
    # Self-test of the verdicts: exactly the expected one, nothing else.
    want = a.expect_wrong
    if want == "dkf":
        good = set(failures) == {"dkf"} and not excluded
        what = "dkf made wrong: failed, as it must be"
    else:
        good = not failures and excluded == {want}
        what = f"peer {want} made wrong: reported and excluded, not failed"
    if not good:
        sys.exit(f"FAIL: --expect-wrong {want}: failures {failures}, excluded {sorted(excluded)}")
    print(f"{what}\nBENCH SMOKE PASSED")


if __name__ == "__main__":
    main()

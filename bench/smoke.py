#!/usr/bin/env python3
"""Bench smoke test for ctest: every benchmark builds, runs a few steps and
computes the same thing as its reference. No timing is asserted (speed is
reported by run_bench.sh, never tested).

usage: smoke.py REL BENCH_KF EIGEN_O2 EIGEN_O3NATIVE BENCH_UIF

Each program prints lines `impl type n m ns steps repeats checksum`, the
checksum (sum of x + trace P after a fixed 1000-step run) independent of
--steps. Checks: the dkf and both Eigen checksums agree per (type, n, m) to
REL relative; ASKF and OTSKF (exactly equivalent filters) agree to REL; the
DKF checksum is finite."""
import math
import subprocess
import sys


def run(exe):
    out = subprocess.run([exe, "--steps", "20", "--repeats", "1"], check=True,
                         capture_output=True, text=True, timeout=120).stdout
    rows = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) == 8 and not line.startswith("#"):
            rows[(f[0], f[1], f[2], f[3])] = float(f[7])
    if not rows:
        sys.exit(f"FAIL: {exe} printed no result line")
    return rows


def close(a, b, rel):
    return abs(a - b) <= rel * max(1.0, abs(b))


def main():
    rel = float(sys.argv[1])
    dkf, eig2, eig3, uif = (run(e) for e in sys.argv[2:6])
    bad = 0
    for (impl, typ, n, m), c in sorted(dkf.items()):
        for other in (eig2, eig3):
            (key,) = [k for k in other if k[1:] == (typ, n, m)]
            ok = close(c, other[key], rel)
            bad += not ok
            print(f"{'ok  ' if ok else 'FAIL'} {typ} n={n} m={m}: dkf {c!r} vs {key[0]} {other[key]!r}")
    by = {k[0]: v for k, v in uif.items()}
    ok = close(by["uif-otskf"], by["uif-askf"], rel)
    bad += not ok
    print(f"{'ok  ' if ok else 'FAIL'} OTSKF {by['uif-otskf']!r} vs ASKF {by['uif-askf']!r}")
    ok = math.isfinite(by["uif-dkf"])
    bad += not ok
    print(f"{'ok  ' if ok else 'FAIL'} DKF checksum finite ({by['uif-dkf']!r})")
    if bad:
        sys.exit(f"{bad} check(s) failed")
    print("BENCH SMOKE PASSED")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""bench/python_speed.py - what a Kalman step costs from Python.

At n = 4, m = 2 (a constant-velocity track in the plane, position
measured) it times, per step:

  filter      dkf.KalmanFilter.filter(Y): T steps in one C call
  loop        kf.predict(); kf.update(Y[t]) from Python, T times
  C           the C library's own loop of dkf_kf_predict + dkf_kf_update:
              bench_kf --case 0 (n = 4, m = 2, its own model of that size;
              the step's cost does not depend on the values)
  filterpy    filterpy.kalman.KalmanFilter's predict() + update(z), if
              FilterPy is installed

and prints one run's medians and their ratios, and the Python overhead
of a step (loop - C). Timings are reported, never asserted.

usage: bench/python_speed.py [--steps T] [--repeats R] [--bench-kf PATH] [--quick]
  --steps T      steps per timed run (default 10000)
  --repeats R    timed runs, the median reported (default 7)
  --bench-kf P   the bench_kf executable of a double, Joseph-form build
                 (default: the first of build-bench-double-joseph/bench/bench_kf,
                 build/*/bench/bench_kf that exists; bench/build_bench.sh double
                 builds the first)
  --quick        200 steps, 1 run: a smoke run (the numbers mean little)
Needs the package dkf (pip install .) and numpy.
"""

from __future__ import annotations

import argparse
import glob
import os
import statistics
import subprocess
import sys
import time

import numpy as np

import dkf

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def model(T: int):
    """A constant-velocity model in the plane (x = [px, vx, py, vy]), the
    positions measured, and T measurements of a simulated track."""
    dt = 0.1
    F1 = np.array([[1.0, dt], [0.0, 1.0]])
    Q1 = 0.05 * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    F, Q = np.kron(np.eye(2), F1), np.kron(np.eye(2), Q1)
    H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    R = 0.2 * np.eye(2)
    rng = np.random.default_rng(42)
    x = np.array([0.0, 1.0, 0.0, -0.5])
    Y = np.empty((T, 2))
    for t in range(T):
        x = F @ x + rng.multivariate_normal(np.zeros(4), Q)
        Y[t] = H @ x + rng.normal(scale=np.sqrt(0.2), size=2)
    return dict(F=F, Q=Q, H=H, R=R, x0=np.zeros(4), P0=10.0 * np.eye(4)), Y


def median_ns_per_step(run, steps: int, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        run()
        times.append((time.perf_counter_ns() - t0) / steps)
    return statistics.median(times)


def time_filter(md, Y, repeats):
    kf = dkf.KalmanFilter(**md)
    return median_ns_per_step(lambda: kf.filter(Y), len(Y), repeats)


def time_loop(md, Y, repeats):
    kf = dkf.KalmanFilter(**md)
    rows = list(Y)  # the rows as arrays, made once (not part of a step)

    def run():
        predict, update = kf.predict, kf.update
        for y in rows:
            predict()
            update(y)

    return median_ns_per_step(run, len(Y), repeats)


def time_filterpy(md, Y, repeats):
    try:
        from filterpy.kalman import KalmanFilter
    except ImportError:
        return None
    f = KalmanFilter(dim_x=4, dim_z=2)
    f.F, f.Q, f.H, f.R = md["F"], md["Q"], md["H"], md["R"]
    f.x, f.P = md["x0"].reshape(4, 1).copy(), md["P0"].copy()
    rows = [y.reshape(2, 1) for y in Y]

    def run():
        for z in rows:
            f.predict()
            f.update(z)

    return median_ns_per_step(run, len(Y), repeats)


def find_bench_kf(given):
    if given:
        return given if os.access(given, os.X_OK) else None
    cands = [os.path.join(ROOT, "build-bench-double-joseph", "bench", "bench_kf")]
    cands += sorted(glob.glob(os.path.join(ROOT, "build", "*", "bench", "bench_kf")))
    return next((c for c in cands if os.access(c, os.X_OK)), None)


def time_c(path, steps, repeats):
    """bench_kf's median ns per step at case 0, and its line."""
    out = subprocess.run([path, "--case", "0", "--steps", str(steps), "--repeats", str(repeats)],
                         check=True, capture_output=True, text=True).stdout.split()
    # "dkf <type> <n> <m> <ns> <steps> <repeats> <checksum>"
    if out[0] != "dkf" or out[1] != "double" or out[2:4] != ["4", "2"]:
        raise SystemExit(f"python_speed: {path}: not a double bench_kf at n = 4, m = 2: {out}")
    return float(out[4])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=10000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--bench-kf", default=None)
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    if a.quick:
        a.steps, a.repeats = 200, 1
    md, Y = model(a.steps)
    rows = {}
    rows["filter"] = time_filter(md, Y, a.repeats)
    rows["loop"] = time_loop(md, Y, a.repeats)
    path = find_bench_kf(a.bench_kf)
    rows["C"] = time_c(path, a.steps, a.repeats) if path else None
    rows["filterpy"] = time_filterpy(md, Y, a.repeats)

    print(f"# python_speed: n = 4, m = 2, T = {a.steps}, median of {a.repeats}; dkf "
          f"{dkf.dtype} (Joseph form {dkf._dkf_double.JOSEPH}), numpy {np.__version__}, Python "
          f"{sys.version.split()[0]}")
    print(f"# C: {path or 'bench_kf not found (bench/build_bench.sh double builds it)'}")
    for name, ns in rows.items():
        print(f"{name:9s} {'-' if ns is None else f'{ns:10.1f}'} ns/step")

    def ratio(x, y):
        if rows[x] is None or rows[y] is None:
            return f"{x} / {y}: -"
        return f"{x} / {y}: {rows[x] / rows[y]:.2f}"

    for x, y in (("filter", "C"), ("loop", "C"), ("loop", "filter"), ("filterpy", "loop"),
                 ("filterpy", "filter")):
        print(ratio(x, y))
    if rows["C"] is not None:
        print(f"Python overhead of a predict() + update(y): {rows['loop'] - rows['C']:.1f} ns "
              f"(loop - C); of a step in filter(): {rows['filter'] - rows['C']:.1f} ns")
    return 0


if __name__ == "__main__":
    sys.exit(main())

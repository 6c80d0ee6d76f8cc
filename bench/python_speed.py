#!/usr/bin/env python3
"""bench/python_speed.py - what a Kalman step costs from Python.

At n = 4, m = 2 (a constant-velocity track in the plane, position
measured) it times, per step:

  filter      dkf.KalmanFilter.filter(Y): T steps in one C call
  loop        kf.predict(); kf.update(Y[t]) from Python, T times
  C           the C library's own loop of dkf_kf_predict + dkf_kf_update:
              bench_kf --case 0 (n = 4, m = 2, its own model of that size;
              the step's cost does not depend on the values), run once a
              round like the others
  filterpy    filterpy.kalman.KalmanFilter's predict() + update(z), if
              FilterPy is installed

and the plain cubature Kalman filter (dkf.NERTS kind DNERTSF with p = 0) at
n = 4, m = 2 (the same track, measured in range and bearing), per step:

  ckf_jit      filter(Z) with the model compiled by dkf.jit_model (numba)
  ckf_python   filter(Z) with the model as Python callables (dkf.NLModel)
  ckf_filterpy filterpy.kalman.CubatureKalmanFilter's predict() + update(z)
               on the same model (numpy callables)

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
Needs the package dkf (pip install .) and numpy; numba for ckf_jit.
"""

from __future__ import annotations

import argparse
import glob
import math
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


def interleaved_medians(runs, repeats: int):
    """runs: name -> (run, steps), or (measure, None) for a run that reports
    its own ns per step. Each round times every run once, in turn, so that a
    change in the machine's load touches all of them alike; the median ns
    per step of each over the rounds. A timed run follows an untimed one of
    its own (caches and branch predictors warm, as bench_kf's own timing
    has them after its calibration)."""
    times = {name: [] for name in runs}
    for _ in range(repeats):
        for name, (run, steps) in runs.items():
            if steps is None:
                times[name].append(run())
                continue
            run()
            t0 = time.perf_counter_ns()
            run()
            times[name].append((time.perf_counter_ns() - t0) / steps)
    return {name: statistics.median(t) for name, t in times.items()}


def time_filter(md, Y):
    kf = dkf.KalmanFilter(**md)
    return (lambda: kf.filter(Y)), len(Y)


def time_loop(md, Y):
    kf = dkf.KalmanFilter(**md)
    rows = list(Y)  # the rows as arrays, made once (not part of a step)

    def run():
        predict, update = kf.predict, kf.update
        for y in rows:
            predict()
            update(y)

    return run, len(Y)


def time_filterpy(md, Y):
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

    return run, len(Y)


def ckf_model(T: int):
    """The track of model() measured in range and bearing from the origin:
    f, h as fill-in functions (dkf.jit_model's form), Q, R, the prior and
    T measurements."""
    dt = 0.1
    F1 = np.array([[1.0, dt], [0.0, 1.0]])
    F = np.kron(np.eye(2), F1)
    Q = np.kron(np.eye(2), 0.05 * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]))
    R = np.diag([0.1, 0.001])

    def f(x, d, u, out):
        out[0], out[1], out[2], out[3] = x[0] + dt * x[1], x[1], x[2] + dt * x[3], x[3]

    def h(x, d, u, y):
        y[0], y[1] = math.sqrt(x[0] * x[0] + x[2] * x[2]), math.atan2(x[2], x[0])

    rng = np.random.default_rng(43)
    x = np.array([10.0, 1.0, 5.0, -0.5])
    Z = np.zeros((T + 1, 2))  # row 0 is not read (x0 is x_{0|0})
    for t in range(1, T + 1):
        x = F @ x + rng.multivariate_normal(np.zeros(4), Q)
        Z[t] = [math.hypot(x[0], x[2]), math.atan2(x[2], x[0])] + rng.normal(size=2) * [
            math.sqrt(0.1), math.sqrt(0.001)]
    return dict(f=f, h=h, F=F, Q=Q, R=R, x0=np.array([10.0, 1.0, 5.0, -0.5]), P0=np.eye(4)), Z


def time_ckf(model, md, Z):
    def run():
        dkf.NERTS(model, md["x0"], md["P0"], kind="DNERTSF").filter(Z, Q=md["Q"], R=md["R"])

    return run, len(Z) - 1


def ckf_python_model(md):
    def call(fill, size):
        def g(x, d, u):
            out = np.empty(size)
            fill(x, d, u, out)
            return out
        return g

    return dkf.NLModel(call(md["f"], 4), call(md["h"], 2), n=4, m=2, p=0, angles=[1])


def time_ckf_filterpy(md, Z):
    try:
        from filterpy.kalman import CubatureKalmanFilter
    except ImportError:
        return None
    F = md["F"]

    def hx(x):
        return np.array([math.hypot(x[0], x[2]), math.atan2(x[2], x[0])])

    rows = [z.reshape(2, 1) for z in Z[1:]]

    def run():
        f = CubatureKalmanFilter(dim_x=4, dim_z=2, dt=0.1, hx=hx, fx=lambda x, dt: F @ x)
        f.x, f.P, f.Q, f.R = md["x0"].copy(), md["P0"].copy(), md["Q"], md["R"]
        for z in rows:
            f.predict()
            f.update(z)

    return run, len(rows)


def find_bench_kf(given):
    if given:
        return given if os.access(given, os.X_OK) else None
    cands = [os.path.join(ROOT, "build-bench-double-joseph", "bench", "bench_kf")]
    cands += sorted(glob.glob(os.path.join(ROOT, "build", "*", "bench", "bench_kf")))
    return next((c for c in cands if os.access(c, os.X_OK)), None)


def time_c(path, steps):
    """A round of the C loop: bench_kf's median ns per step at case 0 over 5
    runs of T steps (its own timing, without the process's start)."""

    def measure():
        out = subprocess.run([path, "--case", "0", "--steps", str(steps), "--repeats", "5"],
                             check=True, capture_output=True, text=True).stdout.split()
        # "dkf <type> <n> <m> <ns> <steps> <repeats> <checksum>"
        if out[0] != "dkf" or out[1] != "double" or out[2:4] != ["4", "2"]:
            raise SystemExit(f"python_speed: {path}: not a double bench_kf at n = 4, m = 2: {out}")
        return float(out[4])

    return measure, None


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
    cm, Z = ckf_model(a.steps)
    slow = Z[: min(len(Z), 2001)]  # the CKFs that call Python: fewer steps
    path = find_bench_kf(a.bench_kf)
    runs = {"filter": time_filter(md, Y), "loop": time_loop(md, Y)}
    if path:
        runs["C"] = time_c(path, a.steps)
    fp = time_filterpy(md, Y)
    if fp is not None:
        runs["filterpy"] = fp
    try:
        runs["ckf_jit"] = time_ckf(dkf.jit_model(cm["f"], cm["h"], n=4, m=2, angles=[1]), cm, Z)
    except ImportError:  # numba is not installed
        pass
    runs["ckf_python"] = time_ckf(ckf_python_model(cm), cm, slow)
    fp = time_ckf_filterpy(cm, slow)
    if fp is not None:
        runs["ckf_filterpy"] = fp
    rows = dict.fromkeys(["filter", "loop", "C", "filterpy", "ckf_jit", "ckf_python",
                          "ckf_filterpy"])
    rows.update(interleaved_medians(runs, a.repeats))

    print(f"# python_speed: n = 4, m = 2, T = {a.steps}, median of {a.repeats}; dkf "
          f"{dkf.dtype} (Joseph form {dkf._dkf_double.JOSEPH}), numpy {np.__version__}, Python "
          f"{sys.version.split()[0]}")
    print(f"# C: {path or 'bench_kf not found (bench/build_bench.sh double builds it)'}")
    for name, ns in rows.items():
        print(f"{name:12s} {'-' if ns is None else f'{ns:10.1f}'} ns/step")

    def ratio(x, y):
        if rows[x] is None or rows[y] is None:
            return f"{x} / {y}: -"
        return f"{x} / {y}: {rows[x] / rows[y]:.2f}"

    for x, y in (("filter", "C"), ("loop", "C"), ("loop", "filter"), ("filterpy", "loop"),
                 ("filterpy", "filter"), ("ckf_python", "ckf_jit"),
                 ("ckf_filterpy", "ckf_jit"), ("ckf_filterpy", "ckf_python")):
        print(ratio(x, y))
    if rows["C"] is not None:
        print(f"Python overhead of a predict() + update(y): {rows['loop'] - rows['C']:.1f} ns "
              f"(loop - C); of a step in filter(): {rows['filter'] - rows['C']:.1f} ns")
    return 0


if __name__ == "__main__":
    sys.exit(main())

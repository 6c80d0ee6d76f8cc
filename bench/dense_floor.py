#!/usr/bin/env python3
"""bench/dense_floor.py - what one dense covariance step of state n costs in
OpenBLAS on one thread (docs/design/diffkf-fusion.md §10).

Where the paper's condition for its fusion formulas holds, N nodes need a
state of n >= sum p_i >= N components, and whatever the fusion formula, a
centre that publishes the central P_{k|k} must at least predict it
(F P F^T + Q) and fold in sum p_i differenced measurements. This times those
pieces at n = p (the smallest such centre) with numpy's BLAS, a well-tuned
peer, pinned to one thread: a floor for that centre on this machine, not a
dkf measurement. Times are the fastest of --repeats runs of --steps calls.

  OPENBLAS_NUM_THREADS=1 bench/dense_floor.py [--n 200] [--repeats 7] [--steps 50]
"""
import argparse
import os
import sys
import time

for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")  # before numpy loads its BLAS

import numpy as np  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200, help="state = measurement size (default 200)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--steps", type=int, default=50)
    a = ap.parse_args()
    if not (1 <= a.n <= 2000 and 1 <= a.repeats <= 100 and 1 <= a.steps <= 10000):
        ap.error("need 1 <= n <= 2000, 1 <= repeats <= 100, 1 <= steps <= 10000")
    rng = np.random.default_rng(1)
    n = a.n
    F = rng.standard_normal((n, n)) / np.sqrt(n)
    M = rng.standard_normal((n, n))
    Q, R, P = 0.1 * np.eye(n), np.eye(n), np.eye(n)

    def predict():
        return F @ P @ F.T + Q

    def predict_and_update():
        Pp = F @ P @ F.T + Q
        J = Pp @ M.T
        Lc = np.linalg.cholesky(M @ J + R)
        W = np.linalg.solve(Lc, J.T)
        return Pp - W.T @ W

    print("n = %d, one thread (OPENBLAS_NUM_THREADS=%s), fastest of %d x %d calls"
          % (n, os.environ["OPENBLAS_NUM_THREADS"], a.repeats, a.steps))
    for name, f in (("F P F^T + Q", predict), ("predict + update with p = n", predict_and_update)):
        f()
        best = float("inf")
        for _ in range(a.repeats):
            t = time.perf_counter()
            for _ in range(a.steps):
                f()
            best = min(best, (time.perf_counter() - t) / a.steps)
            print(".", end="", file=sys.stderr, flush=True)
        print("\r%-30s %.3f ms" % (name, best * 1e3))
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""High-precision references for the covariance-update stress tests.

Writes tests/vectors/stress/<filter>.json (committed; the C tests read them
and never run Python): models in the regimes where a covariance update
that subtracts from P loses its digits, with the filter's results computed
in 60-digit arithmetic (mpmath) from the very inputs the C tests use.

Every input is rounded to IEEE single precision first (numpy.float32), so
it is exactly representable in both builds (DKF_REAL=float and double):
the reference is then the exact answer for the float build's inputs too,
and a tolerance measures the filter's own rounding only.

Regimes (docs/decisions.md, "The covariance update"):
* pinned:   P0 = 1e8 I, R = 1e-8 I, n = m = 4: the measurements pin the
            state, P_{1|1} ~ 1e-8 is 1e16 below P0;
* moderate: P0 SPD with eigenvalues in [1e4, 1e6], R SPD with
            eigenvalues in [1e-4, 1e-3], n = m (4 and 6), five
            predict + update steps;
* near-singular R (float): R = [[1, 1 - 2^-27], [1 - 2^-27, 1]] (exact in
            double, singular once rounded to float) and strong P, for
            the "never OK with an indefinite P" tests; the reference is
            for the double inputs (the float build sees a singular R).

Numbers are written with 17 significant digits (the reference rounded to
double: 1e-17 relative, far below every tolerance).

Usage: python3 tools/make_stress_vectors.py [--check-only]
Requires mpmath and numpy (Debian python3-mpmath, python3-numpy).
Deterministic (fixed seeds).
"""
import json
import os
import sys

import mpmath as mp
import numpy as np

mp.mp.dps = 60
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "tests", "vectors", "stress")


# ---- inputs: float32-exact numbers ----------------------------------------

def f32(a):
    """a rounded to float32, as float64 (exactly representable in both)."""
    return np.asarray(a, dtype=np.float32).astype(np.float64)


def spd_with_eigs(rng, eigs):
    """Q diag(eigs) Q^T with a random orthogonal Q, symmetrised, then
    float32-rounded (symmetric after rounding: both triangles round alike)."""
    n = len(eigs)
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    a = q @ np.diag(eigs) @ q.T
    a = (a + a.T) / 2
    return f32(a)


def logspace_eigs(rng, lo, hi, n):
    return np.exp(rng.uniform(np.log(lo), np.log(hi), n))


# ---- 60-digit linear algebra (mpmath) --------------------------------------

def M(a):
    return mp.matrix([[mp.mpf(float(v)) for v in row] for row in np.atleast_2d(a)])


def V(a):
    return mp.matrix([mp.mpf(float(v)) for v in np.ravel(a)])


def kf_update(x, P, H, R, y):
    """Exact (60-digit) measurement update: S = H P H^T + R,
    K = P H^T S^{-1}, x+ = x + K (y - H x), P+ = (I-KH) P (I-KH)^T + K R K^T
    (at 60 digits every algebraic form agrees to ~40 digits)."""
    S = H * P * H.T + R
    K = P * H.T * mp.inverse(S)
    n = P.rows
    A = mp.eye(n) - K * H
    xn = x + K * (y - H * x)
    Pn = A * P * A.T + K * R * K.T
    Pn = (Pn + Pn.T) / 2
    return xn, Pn


def kf_predict(x, P, F, Q):
    return F * x, F * P * F.T + Q


def tolist(m):
    return [[float(m[i, j]) for j in range(m.cols)] for i in range(m.rows)]


def tovec(v):
    return [float(v[i]) for i in range(v.rows)]


def min_eig(m):
    e = mp.eigsy(m)[0]
    return min(e[i] for i in range(e.rows))


# ---- the KF cases ------------------------------------------------------------

def kf_case(name, note, x0, P0, steps):
    """steps: list of dicts with H, R, y and optionally F, Q (predict
    first). Adds the 60-digit x, P after each step."""
    x, P = V(x0), M(P0)
    out = []
    for st in steps:
        rec = {}
        if "F" in st:
            x, P = kf_predict(x, P, M(st["F"]), M(st["Q"]))
            rec["F"], rec["Q"] = st["F"].tolist(), st["Q"].tolist()
        x, P = kf_update(x, P, M(st["H"]), M(st["R"]), V(st["y"]))
        rec.update(H=st["H"].tolist(), R=st["R"].tolist(), y=st["y"].tolist(),
                   x=tovec(x), P=tolist(P), P_min_eig=float(min_eig(P)),
                   cond_H=float(np.linalg.cond(st["H"])))
        out.append(rec)
    return {"name": name, "note": note, "n": len(x0), "m": len(steps[0]["y"]),
            "x0": list(map(float, x0)), "P0": P0.tolist(), "steps": out}


def kf_cases():
    rng = np.random.default_rng(20261201)
    cases = []
    # pinned: P0 = 1e8 I, R = 1e-8 I (float32-rounded), n = m = 4
    n = 4
    H = f32(rng.standard_normal((n, n)))
    cases.append(kf_case(
        "pinned_n4", "P0 = 1e8 I, R = 1e-8 I, n = m = 4, one update",
        f32(rng.standard_normal(n)), f32(1e8 * np.eye(n)),
        [{"H": H, "R": f32(1e-8 * np.eye(n)), "y": f32(rng.standard_normal(n))}]))
    # moderate: P0 eigenvalues in [1e4, 1e6], R in [1e-4, 1e-3], n = m
    for n in (4, 6):
        P0 = spd_with_eigs(rng, logspace_eigs(rng, 1e4, 1e6, n))
        steps = []
        for k in range(5):
            st = {"H": f32(rng.standard_normal((n, n))),
                  "R": spd_with_eigs(rng, logspace_eigs(rng, 1e-4, 1e-3, n)),
                  "y": f32(100 * rng.standard_normal(n))}
            if k > 0:
                st["F"] = f32(np.eye(n) + 0.1 * rng.standard_normal((n, n)))
                st["Q"] = spd_with_eigs(rng, logspace_eigs(rng, 1e3, 1e5, n))
            steps.append(st)
        cases.append(kf_case(
            "moderate_n%d" % n,
            "P0 eigenvalues in [1e4, 1e6], R in [1e-4, 1e-3], n = m = %d, 5 steps" % n,
            f32(rng.standard_normal(n)), P0, steps))
    # near-singular R: exact in double, singular in float
    c = 1.0 - 2.0 ** -27
    R = np.array([[1.0, c], [c, 1.0]])
    for n, p0 in ((2, 1e6), (4, 1e6)):
        H = f32(rng.standard_normal((2, n)))
        steps = [{"H": H, "R": R, "y": f32(rng.standard_normal(2))} for _ in range(3)]
        for st in steps[1:]:
            st["F"] = f32(np.eye(n))
            st["Q"] = f32(np.zeros((n, n)))
        cases.append(kf_case(
            "singular_r_float_n%d" % n,
            "R = [[1, 1-2^-27], [1-2^-27, 1]] (singular in float), P0 = %g I, "
            "3 updates of the same H" % p0,
            f32(rng.standard_normal(n)), f32(p0 * np.eye(n)), steps))
    return cases


def write(name, doc):
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, name + ".json")
    text = json.dumps(doc, separators=(",", ":")) + "\n"
    if "--check-only" in sys.argv:
        with open(path) as f:
            if f.read() != text:
                sys.exit("make_stress_vectors: %s differs from a fresh run" % path)
        return
    with open(path, "w") as f:
        f.write(text)


def main():
    write("kf", {
        "generator": "tools/make_stress_vectors.py (mpmath, 60 digits)",
        "layout": "cases[]: n, m, x0, P0, steps[] {F, Q (predict first, if present), "
                  "H, R, y, and the reference x, P after the update, P_min_eig, "
                  "cond_H (2-norm condition number of H, for the tests' bounds)}",
        "cases": kf_cases()})


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Generate the built-in demo scenario (canonical format, docs/reference/scenario-format.md).

    tools/make_scenario.py [--out scenarios/demo_cv2d.json] [--steps 100] [--seed 2024]

A target moving in the plane with a (nearly) constant velocity, state
x = [px, vx, py, vy] (m, m/s), sampling period T = 1 s, white acceleration
noise of spectral density q in each axis:

    F = blockdiag(Fa, Fa),  Fa = [[1, T], [0, 1]]
    Q = q * blockdiag(Qa, Qa),  Qa = [[T^3/3, T^2/2], [T^2/2, T]]

Two position sensors see y^i_k = H x_k + w^i_k, H = [[1,0,0,0],[0,0,1,0]]:
sensor 0 is accurate in px, poor in py; sensor 1 the reverse, with
correlated noise. The truth x_0 ~ N(x00, P00), x_k = F x_{k-1} + v_{k-1},
measurements for k = 1..N (y_0 is not used by the format). Python's
`random` with a fixed seed makes the file reproducible bit for bit.
"""
import argparse
import json
import math
import os
import random
import sys


def chol(A):
    """Lower Cholesky factor of a small SPD matrix (list of rows)."""
    n = len(A)
    L = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            s = A[i][j] - sum(L[i][k] * L[j][k] for k in range(j))
            L[i][j] = math.sqrt(s) if i == j else s / L[j][j]
    return L


def matvec(A, x):
    return [sum(a * b for a, b in zip(row, x)) for row in A]


def gauss_vec(rng, cov):
    L = chol(cov)
    return matvec(L, [rng.gauss(0.0, 1.0) for _ in range(len(cov))])


def add(a, b):
    return [p + q for p, q in zip(a, b)]


def build(steps, seed):
    T, q = 1.0, 0.05
    F = [[1, T, 0, 0], [0, 1, 0, 0], [0, 0, 1, T], [0, 0, 0, 1]]
    qa = [[q * T ** 3 / 3, q * T ** 2 / 2], [q * T ** 2 / 2, q * T]]
    Q = [[qa[0][0], qa[0][1], 0, 0], [qa[1][0], qa[1][1], 0, 0],
         [0, 0, qa[0][0], qa[0][1]], [0, 0, qa[1][0], qa[1][1]]]
    H = [[1, 0, 0, 0], [0, 0, 1, 0]]
    R = [[[1.0, 0.0], [0.0, 25.0]],      # sensor 0: good in px, poor in py (m^2)
         [[16.0, -2.0], [-2.0, 2.25]]]   # sensor 1: the reverse, correlated
    x00 = [0.0, 10.0, 0.0, 5.0]
    P00 = [[100.0, 0, 0, 0], [0, 4.0, 0, 0], [0, 0, 100.0, 0], [0, 0, 0, 4.0]]

    rng = random.Random(seed)
    x = add(x00, gauss_vec(rng, P00))
    truth = [x]
    ys = [[], []]
    for _k in range(1, steps + 1):
        x = add(matvec(F, x), gauss_vec(rng, Q))
        truth.append(x)
        for i in range(2):
            ys[i].append(add(matvec(H, x), gauss_vec(rng, R[i])))

    ks = list(range(1, steps + 1))
    return {
        "scenario": "demo_cv2d: 2-D constant-velocity target, 2 position sensors",
        "generator": "tools/make_scenario.py --steps %d --seed %d" % (steps, seed),
        "seed": seed,
        "N": steps,
        "conventions": ("Time index k is absolute. Filters start from (x_{0|0}, P_{0|0}) at k=0; "
                        "step k (k=1..N) predicts with F_{k-1}, Q_{k-1} and updates with y_k. "
                        "State x = [px, vx, py, vy] in m and m/s, T = 1 s. "
                        "Matrices are row-major nested lists."),
        "dims": {"n": 4, "m_i": [2, 2]},
        "model": {
            "F": {"const": F},
            "Q": {"const": Q},
            "sensors": [{"H": {"const": H}, "R": {"const": R[0]}},
                        {"H": {"const": H}, "R": {"const": R[1]}}],
        },
        "init": {"x00": x00, "P00": P00},
        "y": [{"k": ks, "values": ys[0]}, {"k": ks, "values": ys[1]}],
        "truth": {"k": list(range(0, steps + 1)), "x": truth},
        "k": ks,
    }


def dump(doc, f):
    """One top-level key per line, compact values: diff-friendly, small."""
    f.write("{\n")
    items = list(doc.items())
    for j, (k, v) in enumerate(items):
        f.write(" %s: %s%s\n" % (json.dumps(k), json.dumps(v, separators=(",", ":")),
                                 "," if j + 1 < len(items) else ""))
    f.write("}\n")


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(here, "..", "scenarios", "demo_cv2d.json"),
                    help="output file (default scenarios/demo_cv2d.json); '-' for stdout")
    ap.add_argument("--steps", type=int, default=100, help="number of steps N (default 100)")
    ap.add_argument("--seed", type=int, default=2024, help="random seed (default 2024)")
    a = ap.parse_args()
    if a.steps < 1:
        ap.error("--steps must be at least 1")
    doc = build(a.steps, a.seed)
    if a.out == "-":
        dump(doc, sys.stdout)
    else:
        with open(a.out, "w") as f:
            dump(doc, f)
    return 0


if __name__ == "__main__":
    sys.exit(main())

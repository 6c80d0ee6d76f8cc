#!/usr/bin/env python3
"""Writes scenarios/nl_mixed_expr.json: seed 001's consensus network with
nodes that measure different things (docs/reference/scenario-format.md, "Nonlinear
cases"; docs/design/dfnerts.md, "Nodes with different sensors").

    tools/make_nl_mixed.py [--out scenarios/nl_mixed_expr.json] [--steps 25] [--seed 2014]

One system, x = [x1, x2, x3], one unknown input d1 (the lin_x_sin_d
dynamics of tests/vectors/infofusion/nertsif.json):
    f(x, d) = [x1 + 0.1 x2, 0.95 x2 + 0.1 x3 + 0.1 sin(d1), 0.9 x3 + 0.05 sin(d1)]
    d1_k    = 0.8 sin(0.25 k) + 0.2,  w ~ N(0, diag(1, 2, 1) 1e-3)
three nodes with 2, 3 and 2 measurements, each its own expressions and R:

  cases 0, 1  path graph 0 - 1 - 2 (Metropolis weights), T_p = 2, s = 1
              (the paper's Algorithm 3) and s = 3 (the N-scaled variant);
              node 0 a range and an input channel, node 1 three linear
              channels, node 2 a bearing and an input channel quadratic in
              x (the input channels depend on x weakly, so that Algorithm
              3's mixed joint covariance stays positive definite)
  case 2      the complete graph, W = 1 1^T / 3, T_p = 2, s = 3, every
              sensor linear in x (f stays nonlinear): there the joint
              variant equals the centralised filter on the stacked sensors
              (cf_dnertsf), a check of ports/linux/tests/check_df_mixed.py
  case 3      case 1's graph and s without unknown input (p = 0: DF-CKF),
              f = [x1 + 0.1 x2, 0.95 x2 + 0.1 x3, 0.9 x3 + 0.05 sin(x1)]

Every node starts from the same prior; the truth x_0 ~ N(x0, Px0). Python's
`random` with a fixed seed makes the file reproducible bit for bit.
"""
import argparse
import json
import math
import random

F = ["x1 + 0.1*x2", "0.95*x2 + 0.1*x3 + 0.1*sin(d1)", "0.9*x3 + 0.05*sin(d1)"]
F_CKF = ["x1 + 0.1*x2", "0.95*x2 + 0.1*x3", "0.9*x3 + 0.05*sin(x1)"]
Q = [[0.001, 0.0, 0.0], [0.0, 0.002, 0.0], [0.0, 0.0, 0.001]]
INIT = {"x0": [0.0, 0.0, 0.0], "Px0": [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]],
        "d0": [0.0], "Pd0": [[0.25]], "Pxd0": [[0.0], [0.0], [0.0]]}
INIT_CKF = dict(INIT, d0=[], Pd0=[], Pxd0=[[], [], []])

# (g as expressions, the same as Python lambdas of (x, d), R diagonal)
NONLINEAR = [
    (["hypot(x1 - 2, x3 + 1)", "2*d1 + 0.1*x2"],
     lambda x, d: [math.hypot(x[0] - 2, x[2] + 1), 2 * d + 0.1 * x[1]],
     [0.01, 0.02]),
    (["x1", "x3 + 0.1*x2", "d1 + 0.05*x1"],
     lambda x, d: [x[0], x[2] + 0.1 * x[1], d + 0.05 * x[0]],
     [0.02, 0.03, 0.01]),
    (["atan2(x3 + 2, x1 + 3)", "d1 + 0.05*x1^2"],
     lambda x, d: [math.atan2(x[2] + 2, x[0] + 3), d + 0.05 * x[0] ** 2],
     [0.0004, 0.02]),
]
LINEAR = [
    (["x1 + 0.2*x3", "2*d1 + 0.1*x2"],
     lambda x, d: [x[0] + 0.2 * x[2], 2 * d + 0.1 * x[1]],
     [0.01, 0.02]),
    NONLINEAR[1],
    (["x3 - 0.3*x2", "d1 + 0.05*x1"],
     lambda x, d: [x[2] - 0.3 * x[1], d + 0.05 * x[0]],
     [0.01, 0.02]),
]
CKF = [
    (["hypot(x1 - 2, x3 + 1)", "x2"], lambda x, d: [math.hypot(x[0] - 2, x[2] + 1), x[1]],
     [0.01, 0.02]),
    (["x1", "x3 + 0.1*x2", "x2"], lambda x, d: [x[0], x[2] + 0.1 * x[1], x[1]],
     [0.02, 0.03, 0.01]),
    (["atan2(x3 + 2, x1 + 3)", "x3 + 0.05*x1^2"],
     lambda x, d: [math.atan2(x[2] + 2, x[0] + 3), x[2] + 0.05 * x[0] ** 2],
     [0.0004, 0.02]),
]


def f(x, d):
    return [x[0] + 0.1 * x[1], 0.95 * x[1] + 0.1 * x[2] + 0.1 * math.sin(d),
            0.9 * x[2] + 0.05 * math.sin(d)]


def f_ckf(x, d):
    return [x[0] + 0.1 * x[1], 0.95 * x[1] + 0.1 * x[2], 0.9 * x[2] + 0.05 * math.sin(x[0])]


def simulate(rng, sensors, steps, fn):
    """The truth X (k = 0..N), omega (d_k, k = 0..N) and every node's z_k."""
    x = [m + rng.gauss(0.0, math.sqrt(INIT["Px0"][i][i])) for i, m in enumerate(INIT["x0"])]
    ds = [0.8 * math.sin(0.25 * k) + 0.2 for k in range(steps + 1)]
    X, zs = [x], []
    for k in range(1, steps + 1):
        x = [v + rng.gauss(0.0, math.sqrt(Q[i][i])) for i, v in enumerate(fn(x, ds[k - 1]))]
        X.append(x)
        zs.append([[v + rng.gauss(0.0, math.sqrt(r)) for v, r in zip(g(x, ds[k]), R)]
                   for _, g, R in sensors])
    return X, ds, zs


def case(name, sensors, edges, W, scale, rng, steps, ckf=False):
    X, ds, zs = simulate(rng, sensors, steps, f_ckf if ckf else f)
    models = [{"expr": {"f": F_CKF if ckf else F, "g": g}, "Q": Q,
               "R": [[r if i == j else 0.0 for j in range(len(R))] for i, r in enumerate(R)]}
              for g, _, R in sensors]
    truth = {"X": X} if ckf else {"X": X, "omega": [[d] for d in ds]}
    return {"name": name, "node_models": models,
            "init_per_node": [INIT_CKF if ckf else INIT] * len(sensors),
            "edges": edges, "W": W, "Tp": 2, "scale": scale, "truth": truth,
            "steps": [{"k": k + 1, "z": z} for k, z in enumerate(zs)]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="scenarios/nl_mixed_expr.json")
    ap.add_argument("--steps", type=int, default=25)
    ap.add_argument("--seed", type=int, default=2014)
    a = ap.parse_args()
    rng = random.Random(a.seed)
    third = 1.0 / 3.0
    path_w = [[1 - third, third, 0.0], [third, third, third], [0.0, third, 1 - third]]
    full_w = [[third] * 3 for _ in range(3)]
    doc = {"description": "Seed 001's consensus network with mixed sensors: three nodes measure "
                          "2, 3 and 2 values with their own expressions and R (written by "
                          "tools/make_nl_mixed.py, seed %d). Cases 0, 1: path graph 0-1-2, "
                          "T_p = 2, s = 1 and s = 3; case 2: complete graph, W = 11^T/3, s = 3, "
                          "sensors linear in x (the joint variant equals cf_dnertsf there); case 3: "
                          "case 1 without unknown input (DF-CKF). "
                          "docs/design/dfnerts.md, \"Nodes with different sensors\"." % a.seed,
           "cases": [case("mixed_path3_Tp2_scale1", NONLINEAR, [[0, 1], [1, 2]], path_w, 1.0,
                          rng, a.steps),
                     case("mixed_path3_Tp2_scale3", NONLINEAR, [[0, 1], [1, 2]], path_w, 3.0,
                          rng, a.steps),
                     case("mixed_complete3_Tp2_scale3_linear_g", LINEAR,
                          [[0, 1], [0, 2], [1, 2]], full_w, 3.0, rng, a.steps),
                     case("mixed_path3_DF_CKF_Tp2_scale3", CKF, [[0, 1], [1, 2]], path_w, 3.0,
                          rng, a.steps, ckf=True)]}
    with open(a.out, "w") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""make_wf_scenario.py - a seed-002 weighted-fusion scenario for the network
programs (docs/design/network.md, "The weighted-fusion centre"), in the layout of
tests/vectors/infofusion/s2_weighted_fusion.json (docs/reference/scenario-format.md,
"Weighted-fusion cases"): one case with Phi, Gamma, Qe, H[i], R[i],
H_signal, P0, x_hat0, x_true and steps [{t, y}] (no `expected`).

The model is seed 002's (docs/design/derivation-seed001-002.md §5): H = (1 0 1 0),
H_signal = (1 0 0 0), R_i = 0.1 i (i = 1..L); the common prior x_hat0 = 0,
P0 = the stationary covariance of x, x(0) ~ N(0, P0); numpy's default_rng(seed).

  make_wf_scenario.py --steps 200 --seed 2 --out wf5.json
"""
import argparse
import json

import numpy as np

PHI = [[1.5, 1, 0, 0], [-0.56, 0, 0, 0], [0, 0, 0.7, 1], [0, 0, -0.5, 0]]
GAMMA = [[1, 0], [0.4, 0], [0, 1], [0, 0]]
QE = [[0.8, 0], [0, 0.3]]


def stationary(F, Q):
    n = F.shape[0]
    vec = np.linalg.solve(np.eye(n * n) - np.kron(F, F), Q.reshape(-1))
    P = vec.reshape(n, n)
    return (P + P.T) / 2


def case(G, Qe, H, R, P0, ys, xs, name, desc):
    N = len(ys)
    return {"schema": "infofusion-golden-v1", "description": desc,
            "cases": [{"name": name, "description": desc, "Phi": PHI, "Gamma": G, "Qe": Qe,
                       "H": H, "R": R, "H_signal": [[1.0, 0.0, 0.0, 0.0]], "P0": P0,
                       "x_hat0": [0.0] * 4, "x_true": xs,
                       "steps": [{"t": t + 1, "y": ys[t]} for t in range(N)]}]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--sensors", type=int, default=5)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    F, G, Qe = np.array(PHI), np.array(GAMMA), np.array(QE)
    Q = G @ Qe @ G.T
    P0 = stationary(F, Q)
    L, N = a.sensors, a.steps
    H = [[[1.0, 0.0, 1.0, 0.0]] for _ in range(L)]
    R = [[[0.1 * (i + 1)]] for i in range(L)]
    x = rng.multivariate_normal(np.zeros(4), P0)
    xs, ys = [x.tolist()], []
    for _ in range(N):
        x = F @ x + G @ rng.multivariate_normal(np.zeros(2), Qe)
        xs.append(x.tolist())
        ys.append([[float(np.array(H[i][0]) @ x + rng.normal(0, np.sqrt(R[i][0][0])))]
                   for i in range(L)])
    d = case(GAMMA, QE, H, R, P0.tolist(), ys, xs, "wf%d_%dsteps_seed%d" % (L, N, a.seed),
             "seed-002 model, %d sensors, %d steps, numpy default_rng(%d) "
             "(tools/make_wf_scenario.py)" % (L, N, a.seed))
    with open(a.out, "w") as f:
        json.dump(d, f)


if __name__ == "__main__":
    main()

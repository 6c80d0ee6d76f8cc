#!/usr/bin/env python3
"""make_wf_scenario.py - a seed-002 weighted-fusion scenario for the network
programs (docs/network.md, "The weighted-fusion centre"), in the canonical
layout (docs/scenario-format.md): model {F, Q, Hs, sensors: [{H, R}]},
init {x00, P00}, one y series per sensor, truth.

The model is seed 002's (docs/infofusion.md section 5): F = Phi, Q = Gamma
Qe Gamma^T, H = (1 0 1 0), Hs = (1 0 0 0), R_i = 0.1 i (i = 1..L); the
common prior x00 = 0, P00 = the stationary covariance of x, x(0) ~ N(0, P00).

  make_wf_scenario.py --steps 200 --seed 2 --out wf5.json
  make_wf_scenario.py --from-vector tests/vectors/infofusion/s2_weighted_fusion.json --out v.json
      (the vector's 30 steps, its model, prior and y, unchanged; x_fused_matrix
       kept under outputs.reference for comparisons)
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


def doc(F, Q, Hs, H, R, x00, P00, ys, xs, desc):
    L, N = len(H), len(ys)
    return {
        "description": desc,
        "N": N,
        "model": {"F": {"const": F}, "Q": {"const": Q}, "Hs": {"const": Hs},
                  "sensors": [{"H": {"const": H[i]}, "R": {"const": R[i]}} for i in range(L)]},
        "init": {"x00": x00, "P00": P00},
        "y": [{"k": list(range(1, N + 1)), "values": [ys[t][i] for t in range(N)]}
              for i in range(L)],
        "truth": {"k": list(range(0, len(xs))), "x": xs},
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--sensors", type=int, default=5)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--from-vector")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    if a.from_vector:
        c = json.load(open(a.from_vector))["cases"][0]
        G = np.array(c["Gamma"], float)
        Q = (G @ np.array(c["Qe"], float) @ G.T).tolist()
        d = doc(c["Phi"], Q, c["H_signal"], c["H"], c["R"], c["x_hat0"], c["P0"],
                [s["y"] for s in c["steps"]], c["x_true"],
                "seed-002 vector case %s converted by tools/make_wf_scenario.py" % c["name"])
        d["outputs"] = {"reference": {"x_fused_matrix": [s["expected"]["x_fused_matrix"]
                                                         for s in c["steps"]],
                                      "s_fused": [s["expected"]["s_fused"] for s in c["steps"]]}}
    else:
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
        d = doc(F.tolist(), Q.tolist(), [[1.0, 0.0, 0.0, 0.0]], H, R, [0.0] * 4, P0.tolist(), ys,
                xs, "seed-002 model, %d sensors, %d steps, numpy seed %d "
                "(tools/make_wf_scenario.py)" % (L, N, a.seed))
    with open(a.out, "w") as f:
        json.dump(d, f)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Generate a several-node Difference-KF network scenario (docs/guide/network.md).

    make_net_scenario.py --nodes 12 --steps 100 --seed 12 --out net12.json

Target: 2-D constant velocity, x = (px, vx, py, vy), T = 1 s. Every node i
has its own measurement matrix H^i (m_i x 4, m_i in {2, 3, 4}), noise R^i,
unknown input d^i (p_i in {1, 2}, p_i <= m_i; most nodes have p_i < m_i)
entering through D^i (m_i x p_i, full column rank), with d^i_{k+1} =
B^i d^i_k + wd^i_k. The output is the canonical scenario layout
(docs/reference/scenario-format.md) with y_1..y_{N+1} (the Difference KF needs
y_{N+1}) and the truth x_0..x_{N+1}. Everything comes from one seeded
numpy Generator: the same arguments give the same file, byte for byte.
"""
import argparse
import json
import sys

import numpy as np


def rand_full_rank(rng, rows, cols, smin=0.3):
    """rows x cols with singular values in [smin, 1.5] (full rank)."""
    while True:
        a = rng.normal(size=(rows, cols))
        s = np.linalg.svd(a, compute_uv=False)
        if s.min() > smin * s.max():
            return a / s.max() * 1.5


def make(nodes, steps, seed, max_dim=48):
    rng = np.random.default_rng(seed)
    T = 1.0
    F = np.kron(np.eye(2), np.array([[1.0, T], [0.0, 1.0]]))
    q = 0.05
    Q = np.kron(np.eye(2), q * np.array([[T ** 3 / 3, T ** 2 / 2], [T ** 2 / 2, T]]))
    n = 4
    sensors, ms, ps = [], [], []
    for i in range(nodes):
        m = int(rng.integers(2, 5))            # 2..4
        p = 1 if m <= 2 else int(rng.integers(1, 3))  # p < m for m = 2; 1..2 otherwise
        if i == 0:
            m, p = 2, 2                        # one node with p = m, like Example 3
        H = rand_full_rank(rng, m, n)
        D = rand_full_rank(rng, m, p)
        R = np.diag(rng.uniform(0.2, 2.0, size=m))
        B = np.diag(rng.uniform(0.8, 1.0, size=p))
        Rd = np.diag(rng.uniform(0.01, 0.2, size=p))
        sensors.append(dict(H=H, D=D, R=R, B=B, Rd=Rd))
        ms.append(m)
        ps.append(p)
    if sum(ms) > max_dim or sum(ps) > max_dim:
        raise SystemExit(f"stacked dimensions (sum m_i = {sum(ms)}, sum p_i = {sum(ps)}) exceed"
                         f" --max-dim {max_dim} (the DKF_MAX_DIM of the build that runs it)")
    x00 = np.array([0.0, 1.0, 0.0, 0.5])
    P00 = np.diag([4.0, 1.0, 4.0, 1.0])
    # simulate k = 0..N+1
    x = x00 + np.linalg.cholesky(P00) @ rng.normal(size=n)
    d = [rng.normal(size=p) * 2.0 for p in ps]
    xs, ys = [x.copy()], [[] for _ in range(nodes)]
    for k in range(1, steps + 2):
        x = F @ x + np.linalg.cholesky(Q) @ rng.normal(size=n)
        xs.append(x.copy())
        for i, s in enumerate(sensors):
            d[i] = s["B"] @ d[i] + np.sqrt(np.diag(s["Rd"])) * rng.normal(size=ps[i])
            w = np.sqrt(np.diag(s["R"])) * rng.normal(size=ms[i])
            ys[i].append(s["H"] @ x + s["D"] @ d[i] + w)

    def mat(a):
        return {"const": np.asarray(a).tolist()}

    return {
        "scenario": f"net{nodes}: 2-D CV target, {nodes} heterogeneous nodes with unknown inputs",
        "seed": seed,
        "conventions": "docs/reference/scenario-format.md canonical layout; y_1..y_{N+1}, truth x_0..x_{N+1}",
        "dims": {"n": n, "m_i": ms, "p_i": ps},
        "N": steps,
        "model": {"F": mat(F), "Q": mat(Q),
                  "sensors": [{k: mat(v) for k, v in s.items()} for s in sensors]},
        "init": {"x00": x00.tolist(), "P00": P00.tolist()},
        "y": [{"k": list(range(1, steps + 2)), "values": [v.tolist() for v in ys[i]]}
              for i in range(nodes)],
        "truth": {"k": list(range(0, steps + 2)), "x": [v.tolist() for v in xs]},
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, default=12)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--seed", type=int, default=12)
    ap.add_argument("--max-dim", type=int, default=48,
                    help="DKF_MAX_DIM of the build that will run it (default 48)")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    if not 1 <= a.nodes <= 256 or a.steps < 1:
        print("make_net_scenario.py: --nodes must be 1..256 and --steps >= 1", file=sys.stderr)
        return 2
    doc = make(a.nodes, a.steps, a.seed, a.max_dim)
    with open(a.out, "w") as f:
        json.dump(doc, f, separators=(",", ":"))
        f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
